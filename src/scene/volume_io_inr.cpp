// sombra — INRIMAGE-4 (.inr): an ASCII header of KEY=VALUE lines, "#INRIMAGE-4#{" ... "##}\n",
// padded to a multiple of 256 bytes, then the voxels, x fastest.
#include "scene/volume_io_common.h"

#include <algorithm>
#include <map>
#include <sstream>

namespace sombra::volume_io {
namespace {

constexpr char kInrMagic[] = "#INRIMAGE-4#{";
constexpr char kEnd[] = "##}\n";

ScalarType inr_type(const std::string& path, const std::string& type, long long bits) {
    if (type == "float") {
        if (bits == 32) return ScalarType::f32;
        if (bits == 64) return ScalarType::f64;
    } else if (type == "unsigned fixed" || type == "signed fixed") {
        const bool is_signed = type[0] == 's';
        if (bits == 8) return is_signed ? ScalarType::i8 : ScalarType::u8;
        if (bits == 16) return is_signed ? ScalarType::i16 : ScalarType::u16;
        if (bits == 32) return is_signed ? ScalarType::i32 : ScalarType::u32;
    }
    throw file_error(path, "TYPE", "unsupported TYPE=" + type + " with PIXSIZE=" + std::to_string(bits) + " bits");
}

Endian inr_endian(const std::string& path, const std::string& cpu) {
    if (cpu == "decm" || cpu == "pc" || cpu == "alpha") return Endian::little;
    if (cpu == "sun" || cpu == "sgi" || cpu == "hp") return Endian::big;
    throw file_error(path, "CPU", "unknown byte order '" + cpu + "' (expected decm, pc, alpha, sun, sgi or hp)");
}

}  // namespace

Volume read_inr(const std::string& path) {
    const std::vector<unsigned char> bytes = read_file(path);
    const std::string text(bytes.begin(), bytes.begin() + std::min<std::size_t>(bytes.size(), 1 << 16));
    if (text.compare(0, sizeof(kInrMagic) - 1, kInrMagic) != 0) throw file_error(path, "header", "not an INRIMAGE-4 file");
    const std::size_t end = text.find(kEnd);
    if (end == std::string::npos) throw file_error(path, "header", "no end marker \"##}\" found");
    const std::size_t header_bytes = end + sizeof(kEnd) - 1;
    if (header_bytes % 256 != 0)
        throw file_error(path, "header", "size " + std::to_string(header_bytes) + " is not a multiple of 256 bytes");

    std::map<std::string, std::string> keys;
    std::istringstream lines(text.substr(sizeof(kInrMagic) - 1, end - (sizeof(kInrMagic) - 1)));
    for (std::string line; std::getline(lines, line);) {
        const std::size_t eq = line.find('=');
        if (line.empty() || line[0] == '#' || eq == std::string::npos) continue;
        keys[line.substr(0, eq)] = line.substr(eq + 1);
    }
    const auto get = [&](const std::string& key, const char* fallback) -> std::string {
        const auto it = keys.find(key);
        if (it != keys.end()) return it->second;
        if (!fallback) throw file_error(path, key, "missing from the header");
        return fallback;
    };

    const std::array<long long, 3> dims = {parse_int(path, "XDIM", get("XDIM", nullptr)),
                                           parse_int(path, "YDIM", get("YDIM", nullptr)),
                                           parse_int(path, "ZDIM", get("ZDIM", nullptr))};
    if (parse_int(path, "VDIM", get("VDIM", "1")) != 1) throw file_error(path, "VDIM", "only scalar images (VDIM=1) are supported");
    std::string pixsize = get("PIXSIZE", nullptr);
    if (pixsize.size() > 5 && pixsize.compare(pixsize.size() - 5, 5, " bits") == 0) pixsize.resize(pixsize.size() - 5);
    const ScalarType type = inr_type(path, get("TYPE", nullptr), parse_int(path, "PIXSIZE", pixsize));
    const Endian endian = type_size(type) == 1 ? Endian::little : inr_endian(path, get("CPU", nullptr));
    const std::size_t count = checked_voxel_count(path, dims);
    check_exact_size(path, "data", std::uint64_t(count) * type_size(type), bytes.size() - header_bytes);

    Volume volume;
    volume.dims = {int(dims[0]), int(dims[1]), int(dims[2])};
    const char* spacing_keys[3] = {"VX", "VY", "VZ"};
    for (int a = 0; a < 3; ++a) {
        const double s = parse_number(path, spacing_keys[a], get(spacing_keys[a], "1"));
        if (s <= 0) throw file_error(path, spacing_keys[a], "voxel size must be > 0");
        volume.spacing[a] = float(s);
    }
    volume.voxels = to_float(bytes.data() + header_bytes, count, type, endian);
    volume.stored_type = type_name(type);
    volume.source = path;
    return volume;
}

}  // namespace sombra::volume_io
