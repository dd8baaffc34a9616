// sombra — PLY meshes (ASCII, binary little and big endian), read by our own strict reader: Assimp's
// PLY importer segfaults, aborts on an assertion or loops for ever on malformed files (issue 12).
// The header is checked whole, and its element counts against the bytes the file really holds,
// before anything is allocated; every read is bounds-checked; errors are one line.
#include "scene/mesh_formats.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <sstream>

#include "scene/input_file.h"
#include "scene/volume_io_common.h"
#include "sombra/error.h"
#include "sombra/limits.h"

namespace sombra::detail {
namespace {

using volume_io::ScalarType;

struct Property {
    std::string name;
    ScalarType type = ScalarType::f32;
    bool is_list = false;
    ScalarType count_type = ScalarType::u8;  // lists only
};

struct Element {
    std::string name;
    std::uint64_t count = 0;
    std::vector<Property> properties;
    int find(const std::string& property) const {
        for (std::size_t i = 0; i < properties.size(); ++i)
            if (properties[i].name == property) return int(i);
        return -1;
    }
};

enum class Format { ascii, binary_le, binary_be };

ScalarType scalar_type(const std::string& path, const std::string& name) {
    static const std::map<std::string, ScalarType> types = {
        {"char", ScalarType::i8},    {"int8", ScalarType::i8},     {"uchar", ScalarType::u8},
        {"uint8", ScalarType::u8},   {"short", ScalarType::i16},   {"int16", ScalarType::i16},
        {"ushort", ScalarType::u16}, {"uint16", ScalarType::u16},  {"int", ScalarType::i32},
        {"int32", ScalarType::i32},  {"uint", ScalarType::u32},    {"uint32", ScalarType::u32},
        {"float", ScalarType::f32},  {"float32", ScalarType::f32}, {"double", ScalarType::f64},
        {"float64", ScalarType::f64}};
    const auto it = types.find(name);
    if (it == types.end()) throw file_error(path, "header", "unknown property type '" + name + "'");
    return it->second;
}

bool is_integer(ScalarType t) { return t != ScalarType::f32 && t != ScalarType::f64; }

// Reads the body value by value; every read checks that the bytes are there.
class BodyReader {
public:
    BodyReader(const std::string& path, const std::vector<unsigned char>& bytes, std::size_t pos, Format format)
        : path_(path), b_(bytes), pos_(pos), format_(format) {}

    double value(ScalarType type, const std::string& where) {
        return format_ == Format::ascii ? ascii_value(type, where) : binary_value(type, where);
    }
    // A list's item count or an index: an integer in [0, max].
    std::uint64_t count(ScalarType type, std::uint64_t max, const std::string& where) {
        const double v = value(type, where);
        if (!(v >= 0 && v <= double(max)) || v != std::floor(v))
            throw file_error(path_, where, "expected an integer in [0, " + std::to_string(max) + "], found " + text_of(v));
        return std::uint64_t(v);
    }
    std::size_t remaining() const { return b_.size() - pos_; }

private:
    static std::string text_of(double v) {
        std::ostringstream s;
        s << v;
        return s.str();
    }
    double ascii_value(ScalarType type, const std::string& where) {
        while (pos_ < b_.size() && std::isspace(b_[pos_])) ++pos_;
        const std::size_t start = pos_;
        while (pos_ < b_.size() && !std::isspace(b_[pos_])) ++pos_;
        if (start == pos_) throw file_error(path_, where, "truncated: the file ends before this value");
        const std::string token(b_.begin() + std::ptrdiff_t(start), b_.begin() + std::ptrdiff_t(std::min(pos_, start + 65)));
        char* end = nullptr;
        const double v = token.size() > 64 ? NAN : std::strtod(token.c_str(), &end);
        if (token.size() > 64 || *end != '\0' || (is_integer(type) && v != std::floor(v)))
            throw file_error(path_, where, "not a number of its type: '" + token.substr(0, 64) + "'");
        return v;
    }
    double binary_value(ScalarType type, const std::string& where) {
        const std::size_t size = volume_io::type_size(type);
        if (remaining() < size) throw file_error(path_, where, "truncated: the file ends before this value");
        std::uint64_t u = 0;  // the value's bits, most significant byte first
        for (std::size_t i = 0; i < size; ++i) u = (u << 8) | b_[pos_ + (format_ == Format::binary_be ? i : size - 1 - i)];
        pos_ += size;
        switch (type) {
            case ScalarType::f32: { float f; const std::uint32_t bits = std::uint32_t(u); std::memcpy(&f, &bits, 4); return f; }
            case ScalarType::f64: { double d; std::memcpy(&d, &u, 8); return d; }
            case ScalarType::i8: case ScalarType::i16: case ScalarType::i32:  // sign-extend
                return (u >> (8 * size - 1)) ? double(std::int64_t(u) - (std::int64_t(1) << (8 * size))) : double(u);
            default: return double(u);
        }
    }

    const std::string& path_;
    const std::vector<unsigned char>& b_;
    std::size_t pos_;
    Format format_;
};

std::vector<std::string> words_of(const std::string& line) {
    std::istringstream in(line);
    std::vector<std::string> w;
    for (std::string t; in >> t;) w.push_back(t);
    return w;
}

// Parses the header; returns the elements and sets *body to the first byte after end_header.
std::vector<Element> parse_header(const std::string& path, const std::vector<unsigned char>& b, Format* format,
                                  std::size_t* body) {
    std::size_t pos = 0;
    const auto next_line = [&]() -> std::string {
        const std::size_t start = pos;
        while (pos < b.size() && b[pos] != '\n') ++pos;
        if (pos >= b.size()) throw file_error(path, "header", "truncated: no end_header line");
        std::string line(b.begin() + std::ptrdiff_t(start), b.begin() + std::ptrdiff_t(pos));
        ++pos;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        return line;
    };
    if (next_line() != "ply") throw file_error(path, "header", "not a PLY file (first line must be 'ply')");
    std::vector<Element> elements;
    bool have_format = false;
    for (;;) {
        const std::string line = next_line();
        const std::vector<std::string> w = words_of(line);
        if (w.empty() || w[0] == "comment" || w[0] == "obj_info") continue;
        if (w[0] == "end_header") break;
        if (w[0] == "format") {
            if (w.size() != 3 || w[2] != "1.0") throw file_error(path, "format", "expected 'format TYPE 1.0'");
            if (w[1] == "ascii") *format = Format::ascii;
            else if (w[1] == "binary_little_endian") *format = Format::binary_le;
            else if (w[1] == "binary_big_endian") *format = Format::binary_be;
            else throw file_error(path, "format", "unknown format '" + w[1] + "'");
            have_format = true;
        } else if (w[0] == "element") {
            if (w.size() != 3) throw file_error(path, "header", "expected 'element NAME COUNT'");
            char* end = nullptr;
            errno = 0;
            const unsigned long long count = std::strtoull(w[2].c_str(), &end, 10);
            if (*end != '\0' || errno != 0 || w[2][0] == '-')
                throw file_error(path, "element " + w[1], "count is not an integer: '" + w[2] + "'");
            elements.push_back({w[1], count, {}});
        } else if (w[0] == "property") {
            if (elements.empty()) throw file_error(path, "header", "property before any element");
            Property p;
            if (w.size() == 5 && w[1] == "list") {
                p = {w[4], scalar_type(path, w[3]), true, scalar_type(path, w[2])};
                if (!is_integer(p.count_type)) throw file_error(path, "property " + p.name, "list count type must be an integer");
            } else if (w.size() == 3) {
                p = {w[2], scalar_type(path, w[1]), false, ScalarType::u8};
            } else {
                throw file_error(path, "header", "expected 'property TYPE NAME' or 'property list COUNT_TYPE TYPE NAME'");
            }
            elements.back().properties.push_back(p);
        } else {
            throw file_error(path, "header", "unknown keyword '" + w[0].substr(0, 32) + "'");
        }
    }
    if (!have_format) throw file_error(path, "format", "missing");
    *body = pos;
    return elements;
}

// The least number of body bytes one instance of the element takes (ASCII: a digit and a separator
// per value), so that counts can be checked against the file before anything is allocated.
std::uint64_t min_bytes(const Element& e, Format format) {
    std::uint64_t bytes = 0;
    for (const Property& p : e.properties)
        bytes += format == Format::ascii ? 2 : volume_io::type_size(p.is_list ? p.count_type : p.type);
    return bytes;
}

}  // namespace

Mesh read_ply(const std::string& path) {
    const std::vector<unsigned char> bytes = read_regular_file(path, limits::kMaxInputFileBytes);
    Format format = Format::ascii;
    std::size_t body = 0;
    const std::vector<Element> elements = parse_header(path, bytes, &format, &body);

    std::uint64_t needed = 0;  // each term is at most the body's size + 1 (checked first): no overflow
    for (const Element& e : elements) {
        const std::uint64_t each = min_bytes(e, format);
        if (each > 0 && e.count > (bytes.size() - body + 1) / each)
            throw file_error(path, "element " + e.name, std::to_string(e.count) + " entries cannot fit in the " +
                                                            std::to_string(bytes.size() - body) + " bytes after the header");
        needed += e.count * each;
    }
    if (needed > bytes.size() - body + 1)
        throw file_error(path, "header", "the elements need at least " + std::to_string(needed) + " bytes, the body has " +
                                             std::to_string(bytes.size() - body));

    Mesh mesh;
    mesh.source = path;
    BodyReader in(path, bytes, body, format);
    bool have_vertices = false;
    for (const Element& e : elements) {
        const bool is_vertex = e.name == "vertex", is_face = e.name == "face";
        const int xyz[3] = {e.find("x"), e.find("y"), e.find("z")};
        const int nxyz[3] = {e.find("nx"), e.find("ny"), e.find("nz")};
        const int indices = is_face ? std::max(e.find("vertex_indices"), e.find("vertex_index")) : -1;
        if (is_vertex) {
            if (xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0) throw file_error(path, "element vertex", "needs properties x, y and z");
            if (e.count > limits::kMaxMeshVertices)
                throw file_error(path, "element vertex", "more than " + std::to_string(limits::kMaxMeshVertices) + " vertices");
            have_vertices = true;
        }
        if (is_face && (indices < 0 || !e.properties[std::size_t(indices)].is_list))
            throw file_error(path, "element face", "needs a list property vertex_indices");
        const bool with_normals = is_vertex && nxyz[0] >= 0 && nxyz[1] >= 0 && nxyz[2] >= 0;
        // an element without properties takes no bytes, whatever its count (up to 2^64): nothing
        // to read, and no loop over its entries (fuzzing found a count of 4.8·10¹⁰ that hung)
        if (e.properties.empty()) continue;
        for (std::uint64_t i = 0; i < e.count; ++i) {
            const std::string where = "element " + e.name + " " + std::to_string(i);
            std::array<float, 3> position{}, normal{};
            for (std::size_t k = 0; k < e.properties.size(); ++k) {
                const Property& p = e.properties[k];
                if (p.is_list) {
                    const std::uint64_t n = in.count(p.count_type, UINT32_MAX, where);
                    if (n > in.remaining())  // every item takes at least one byte
                        throw file_error(path, where, "truncated: a list of " + std::to_string(n) + " items cannot fit in the " +
                                                          std::to_string(in.remaining()) + " bytes left");
                    if (int(k) != indices) {
                        for (std::uint64_t j = 0; j < n; ++j) in.value(p.type, where);
                        continue;
                    }
                    if (!have_vertices) throw file_error(path, "element face", "comes before element vertex");
                    if (n > 0 && mesh.positions.empty()) throw file_error(path, where, "vertex index out of range (no vertices)");
                    // a fan over the polygon's corners, streamed: nothing is allocated from n
                    std::uint32_t first = 0, previous = 0;
                    for (std::uint64_t j = 0; j < n; ++j) {
                        const auto index = std::uint32_t(in.count(p.type, mesh.positions.size() - 1, where + " vertex index"));
                        if (j >= 2) mesh.triangles.push_back({first, previous, index});
                        if (j == 0) first = index;
                        previous = index;
                        if (mesh.triangles.size() > limits::kMaxMeshTriangles)
                            throw file_error(path, "element face", "more than " +
                                                                       std::to_string(limits::kMaxMeshTriangles) + " triangles");
                    }
                    continue;
                }
                const double v = in.value(p.type, where);
                for (int a = 0; a < 3; ++a) {
                    if (int(k) == xyz[a]) position[std::size_t(a)] = float(v);
                    if (int(k) == nxyz[a]) normal[std::size_t(a)] = float(v);
                }
            }
            if (is_vertex) mesh.positions.push_back(position);
            if (with_normals) mesh.normals.push_back(normal);
        }
    }
    if (!have_vertices) throw file_error(path, "element vertex", "missing");
    return mesh;
}

}  // namespace sombra::detail
