// sombra — the walk of an OpenVDB file before OpenVDB reads it (volume_io_vdb_checks.h). The layout
// is OpenVDB 10's (io/Archive.cc, io/GridDescriptor.cc, MetaMap.cc, math/Maps.h, tree/RootNode.h,
// tree/InternalNode.h, tree/LeafNode.h, io/Compression.h): little endian, as OpenVDB writes on x86.
#include "scene/volume_io_vdb_checks.h"

#include "scene/byte_cursor.h"
#include "scene/input_file.h"
#include "sombra/error.h"

#include <algorithm>
#include <array>
#include <bitset>
#include <cctype>
#include <climits>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <set>
#include <string>
#include <vector>

namespace sombra::volume_io {
namespace {

using Cursor = detail::ByteCursor;
constexpr std::int64_t kVdbMagic = 0x56444220;  // "VDB " (OPENVDB_MAGIC)
constexpr std::uint32_t kOldestFormat = 222, kNewestFormat = 224;  // OpenVDB 3 … 10
constexpr std::uint32_t kZip = 1, kActiveMask = 2, kBlosc = 4;     // io::COMPRESS_*
constexpr std::uint64_t kMaxTreeBytes = std::uint64_t(4) << 30;    // the sparse tree in memory
constexpr std::uint32_t kMaxName = 1 << 16;                        // names and type names
constexpr std::int32_t kRootChildSide = 4096;                      // voxels a root child spans

// A grid's value type as stored: full size, the size of a value saved as a half float, and what
// this grid stores (set_half).
struct ValueType {
    std::uint32_t full = 0, half_size = 0, stored = 0;
    bool half = false;  // read through io::HalfReader, which reads nothing at all for no values
    // Whether the values are stored as halves is the grid's metadata "is_saved_as_half_float"
    // (GridBase::saveFloatAsHalf reads it), not its type name's "_HalfFloat": OpenVDB sets the flag
    // from the name, then the grid's metadata replace it (MetaMap::readMeta clears first).
    void set_half(bool saved_as_half) {
        half = saved_as_half && half_size != full;
        stored = half ? half_size : full;
    }
};

// The grid types sombra lets OpenVDB read (Tree_T_5_4_3, optionally "_HalfFloat").
bool value_type_of(std::string type, ValueType* v) {
    const std::string half = "_HalfFloat";
    const bool as_half = type.size() > half.size() && type.compare(type.size() - half.size(), half.size(), half) == 0;
    if (as_half) type.erase(type.size() - half.size());
    static const struct { const char* name; std::uint32_t full, half; } kTypes[] = {
        {"Tree_float_5_4_3", 4, 2}, {"Tree_double_5_4_3", 8, 2}, {"Tree_int32_5_4_3", 4, 4},
        {"Tree_int64_5_4_3", 8, 8}, {"Tree_vec3s_5_4_3", 12, 6}, {"Tree_vec3d_5_4_3", 24, 6},
        {"Tree_vec3i_5_4_3", 12, 12}};
    for (const auto& t : kTypes)
        if (type == t.name) {
            *v = {t.full, t.half, t.full, false};
            return true;
        }
    return false;
}

// The value size of OpenVDB's fixed-size metadata types; 0 for strings and types it keeps as bytes.
std::uint32_t metadata_size(const std::string& type) {
    static const struct { const char* name; std::uint32_t size; } kSizes[] = {
        {"bool", 1}, {"float", 4}, {"double", 8}, {"int32", 4}, {"int64", 8}, {"vec2i", 8}, {"vec2s", 8},
        {"vec2d", 16}, {"vec3i", 12}, {"vec3s", 12}, {"vec3d", 24}, {"vec4i", 16}, {"vec4s", 16},
        {"vec4d", 32}, {"mat4s", 64}, {"mat4d", 128}};
    for (const auto& s : kSizes)
        if (type == s.name) return s.size;
    return 0;
}

void walk_header(Cursor& c) {
    if (c.get<std::int64_t>("magic") != kVdbMagic) c.fail("magic", "not an OpenVDB file");
    const std::uint32_t format = c.get<std::uint32_t>("format version");
    if (format < kOldestFormat || format > kNewestFormat)
        c.fail("format version", std::to_string(format) + "; sombra reads formats " + std::to_string(kOldestFormat) +
                                     " … " + std::to_string(kNewestFormat) + " (OpenVDB 3 to 10)");
    c.skip(8, "library version");
    c.skip(1, "grid offsets flag");
    char uuid[36];
    c.read(uuid, sizeof uuid, "uuid");
    for (int i = 0; i < 36; ++i)
        if (i == 8 || i == 13 || i == 18 || i == 23 ? uuid[i] != '-' : !std::isxdigit(static_cast<unsigned char>(uuid[i])))
            c.fail("uuid", "not a UUID in text form");
}

// A MetaMap: count, then name, type name and a sized value for each item. `saved_as_half`, when
// given: the value of the last "is_saved_as_half_float" item (a bool), false without one.
void walk_metadata(Cursor& c, bool* saved_as_half = nullptr) {
    if (saved_as_half) *saved_as_half = false;
    const std::uint32_t count = c.get<std::uint32_t>("metadata count");
    c.need(std::uint64_t(count) * 12, "metadata count");  // two empty names and a size at least
    for (std::uint32_t i = 0; i < count; ++i) {
        const std::string name = c.string(kMaxName, "metadata name");
        const std::string type = c.string(kMaxName, "metadata type");
        const std::uint32_t size = c.get<std::uint32_t>("metadata size");
        const std::uint32_t fixed = metadata_size(type);
        if (fixed && size != fixed)
            c.fail("metadata '" + name + "'", "a " + type + " of " + std::to_string(size) + " bytes (expected " + std::to_string(fixed) + ")");
        if (saved_as_half && name == "is_saved_as_half_float" && type != "bool")
            c.fail("metadata '" + name + "'", "a " + type + " where OpenVDB writes a bool");
        if (type == "bool") {
            const std::uint8_t value = c.get<std::uint8_t>("metadata value");
            if (value > 1) c.fail("metadata '" + name + "'", "a bool that is neither 0 nor 1");
            if (saved_as_half && name == "is_saved_as_half_float") *saved_as_half = value == 1;
        } else {
            c.need(size, "metadata '" + name + "'");
            c.skip(size, "metadata value");
        }
    }
}

// Transform: a map type name, then that map's fixed fields (doubles).
void walk_transform(Cursor& c) {
    const std::string type = c.string(kMaxName, "transform type");
    static const struct { const char* name; std::uint32_t bytes; } kMaps[] = {
        {"AffineMap", 128}, {"UnitaryMap", 128}, {"ScaleMap", 120}, {"UniformScaleMap", 120},
        {"ScaleTranslateMap", 144}, {"UniformScaleTranslateMap", 144}, {"TranslationMap", 24}};
    for (const auto& m : kMaps)
        if (type == m.name) return c.skip(m.bytes, "transform");
    if (type == "NonlinearFrustumMap") c.fail("transform", "a non-linear (frustum) transform, which sombra cannot place");
    c.fail("transform type", "'" + type + "' is not a transform OpenVDB knows");
}

// A node's value or mask bits, read whole (at most 4096 bytes).
std::vector<std::uint8_t> read_mask(Cursor& c, std::uint32_t values, const char* field) {
    std::vector<std::uint8_t> bits(values / 8);
    c.read(bits.data(), bits.size(), field);
    return bits;
}

std::uint32_t count_on(const std::vector<std::uint8_t>& bits) {
    std::uint32_t n = 0;
    for (std::uint8_t b : bits) n += std::uint32_t(std::bitset<8>(b).count());
    return n;
}

// One chunk of `bytes` values as io::readData reads it when the grid is compressed: a signed size
// (≤ 0: that many raw bytes), then zlib or Blosc data that must decompress to `bytes`.
void walk_chunk(Cursor& c, std::uint64_t bytes, bool blosc) {
    const std::int64_t size = c.get<std::int64_t>("chunk size");
    if (size <= 0) {
        if (size == INT64_MIN || std::uint64_t(-size) != bytes)
            c.fail("chunk size", "an uncompressed chunk of " + (size == INT64_MIN ? std::string("2^63") : std::to_string(-size)) +
                                     " bytes where the node holds " + std::to_string(bytes));
        return c.skip(bytes, "chunk");
    }
    c.need(std::uint64_t(size), "chunk");
    if (!blosc) return c.skip(std::uint64_t(size), "chunk");
    // Blosc's header: version, versionlz, flags, typesize, then nbytes, blocksize, cbytes (uint32 each)
    std::uint8_t head[16];
    if (size < 16) c.fail("chunk", "a Blosc chunk of " + std::to_string(size) + " bytes (its header alone is 16)");
    c.read(head, sizeof head, "chunk");
    std::uint32_t nbytes, cbytes;
    std::memcpy(&nbytes, head + 4, 4);
    std::memcpy(&cbytes, head + 12, 4);
    if (nbytes != bytes || cbytes < 16 || cbytes > std::uint64_t(size))
        c.fail("chunk", "a Blosc chunk declaring " + std::to_string(nbytes) + " bytes in " + std::to_string(cbytes) +
                            " (the node holds " + std::to_string(bytes) + ", the chunk is " + std::to_string(size) + " bytes)");
    c.skip(std::uint64_t(size) - 16, "chunk");
}

// io::readCompressedValues for a node of `values` values, `active` of them on.
void walk_values(Cursor& c, std::uint32_t values, std::uint32_t active, const ValueType& type, std::uint32_t compression) {
    const std::uint8_t how = c.get<std::uint8_t>("value compression");
    if (how > 6) c.fail("value compression", std::to_string(how) + " is not one of OpenVDB's 0 … 6");
    if (how == 2 || how == 4 || how == 5) c.skip(type.full, "inactive value");
    if (how == 5) c.skip(type.full, "inactive value");
    if (how >= 3 && how <= 5) c.skip(values / 8, "selection mask");
    const std::uint32_t stored = (compression & kActiveMask) && how != 6 ? active : values;
    if (type.half && stored == 0) return;
    const std::uint64_t bytes = std::uint64_t(stored) * type.stored;
    if (compression & (kBlosc | kZip)) walk_chunk(c, bytes, compression & kBlosc);
    else c.skip(bytes, "values");
}

struct TreeCount {
    std::uint64_t leaves = 0, memory = 0;
};

void add_memory(Cursor& c, TreeCount& tree, std::uint64_t bytes) {
    tree.memory += bytes;
    if (tree.memory > kMaxTreeBytes)
        c.fail("tree", "would need more than " + std::to_string(kMaxTreeBytes >> 20) + " MiB of memory as OpenVDB holds it");
}

// InternalNode::readTopology: child and value masks, the tile values, then each child's topology.
void walk_internal(Cursor& c, int log2_dim, const ValueType& type, std::uint32_t compression, TreeCount& tree) {
    const std::uint32_t values = 1u << (3 * log2_dim);
    add_memory(c, tree, std::uint64_t(values) * std::max<std::uint32_t>(8, type.full) + values / 4);
    const std::vector<std::uint8_t> children = read_mask(c, values, "child mask");
    const std::vector<std::uint8_t> active = read_mask(c, values, "value mask");
    for (std::size_t i = 0; i < children.size(); ++i)
        if (children[i] & active[i]) c.fail("value mask", "a child node and an active tile in one place");
    walk_values(c, values, count_on(active), type, compression);
    const std::uint32_t n = count_on(children);
    if (log2_dim == 4) {  // the children are leaves: their value masks (8³ bits)
        tree.leaves += n;
        add_memory(c, tree, std::uint64_t(n) * (512u * type.full + 96));
        return c.skip(std::uint64_t(n) * 64, "leaf value masks");
    }
    for (std::uint32_t i = 0; i < n; ++i) walk_internal(c, 4, type, compression, tree);
}

// Tree::readTopology: buffer count, background, root tiles and children (origins aligned, distinct).
TreeCount walk_topology(Cursor& c, const ValueType& type, std::uint32_t compression) {
    if (c.get<std::int32_t>("buffer count") != 1) c.fail("buffer count", "must be 1");
    c.skip(type.full, "background");
    const std::uint32_t tiles = c.get<std::uint32_t>("root tiles"), children = c.get<std::uint32_t>("root children");
    c.need(std::uint64_t(tiles) * (13 + type.full) + std::uint64_t(children) * 12, "root tiles");
    std::set<std::array<std::int32_t, 3>> origins;
    const auto origin = [&](const char* field) {
        std::array<std::int32_t, 3> o;
        c.read(o.data(), sizeof o, field);
        for (std::int32_t v : o)
            if (v % kRootChildSide != 0) c.fail(field, "not a multiple of " + std::to_string(kRootChildSide));
        if (!origins.insert(o).second) c.fail(field, "two root entries at one origin");
    };
    for (std::uint32_t i = 0; i < tiles; ++i) {
        origin("root tile origin");
        c.skip(type.full, "root tile value");
        if (c.get<std::uint8_t>("root tile active") > 1) c.fail("root tile active", "neither 0 nor 1");
    }
    TreeCount tree;
    for (std::uint32_t i = 0; i < children; ++i) {
        origin("root child origin");
        walk_internal(c, 5, type, compression, tree);
    }
    return tree;
}

// LeafNode::readBuffers of every leaf: its value mask again, then its values.
void walk_leaf_buffers(Cursor& c, std::uint64_t leaves, const ValueType& type, std::uint32_t compression) {
    c.need(leaves * 65, "leaf buffers");  // mask and compression byte at least
    for (std::uint64_t i = 0; i < leaves; ++i) {
        const std::vector<std::uint8_t> mask = read_mask(c, 512, "leaf value mask");
        walk_values(c, 512, count_on(mask), type, compression);
    }
}

struct Descriptor {
    std::string name, type, parent;
};

Descriptor walk_descriptor(Cursor& c) {
    Descriptor d;
    d.name = c.string(kMaxName, "grid name");
    d.type = c.string(kMaxName, "grid type");
    d.parent = c.string(kMaxName, "instance parent");
    c.skip(24, "grid offsets");
    return d;
}

void walk_grid(Cursor& c, const Descriptor& d, const std::vector<Descriptor>& earlier) {
    c.where = "grid '" + d.name + "': ";
    ValueType type;
    if (!value_type_of(d.type, &type))
        c.fail("type", "'" + d.type + "': sombra reads files whose grids are float, double, int32, int64 or vec3 trees");
    const std::uint32_t compression = c.get<std::uint32_t>("compression");
    if (compression & ~(kZip | kActiveMask | kBlosc)) c.fail("compression", "unknown flags " + std::to_string(compression));
    bool saved_as_half = false;
    walk_metadata(c, &saved_as_half);
    type.set_half(saved_as_half);
    walk_transform(c);
    if (!d.parent.empty()) {  // an instance shares an earlier grid's tree: nothing more is stored
        for (const Descriptor& e : earlier)
            if (e.name == d.parent && e.type == d.type) return;
        c.fail("instance parent", "'" + d.parent + "' is not an earlier grid of the same type");
    }
    const TreeCount tree = walk_topology(c, type, compression);
    walk_leaf_buffers(c, tree.leaves, type, compression);
}

}  // namespace

void check_vdb_file(const std::string& path) {
    Cursor c(path, detail::regular_file_size(path));
    walk_header(c);
    walk_metadata(c);
    const std::int32_t grids = c.get<std::int32_t>("grid count");
    if (grids < 0) c.fail("grid count", std::to_string(grids));
    c.need(std::uint64_t(grids) * 36, "grid count");  // three empty names and the offsets at least
    std::vector<Descriptor> seen;
    for (std::int32_t i = 0; i < grids; ++i) {
        c.where.clear();
        Descriptor d = walk_descriptor(c);
        walk_grid(c, d, seen);
        seen.push_back(std::move(d));
    }
}

}  // namespace sombra::volume_io
