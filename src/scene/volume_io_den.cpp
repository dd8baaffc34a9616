// sombra — VolPack density files (.den).
//
// Header: 29 little-endian int16 then one int32, 62 bytes in all. int16 0 is the map version
// (1); int16 25..27 are the map dimensions x, y, z; the int32 is the map length (x * y * z).
// uint8 voxels follow, x fastest.
#include "scene/volume_io_common.h"

namespace sombra::volume_io {
namespace {
constexpr std::size_t kHeaderBytes = 62;

long long le16(const unsigned char* p) { return std::int16_t(std::uint16_t(p[0] | (p[1] << 8))); }
long long le32(const unsigned char* p) {
    return std::int32_t(std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 |
                        std::uint32_t(p[3]) << 24);
}
}  // namespace

Volume read_den(const std::string& path) {
    const std::vector<unsigned char> bytes = read_file(path);
    if (bytes.size() < kHeaderBytes)
        throw file_error(path, "header", "truncated: a .den header is 62 bytes, the file has " +
                                             std::to_string(bytes.size()));
    const long long version = le16(bytes.data());
    if (version != 1) throw file_error(path, "version", "unsupported map version " + std::to_string(version));
    const std::array<long long, 3> dims = {le16(&bytes[50]), le16(&bytes[52]), le16(&bytes[54])};
    const std::size_t count = checked_voxel_count(path, dims);
    const long long map_length = le32(&bytes[58]);
    if (map_length != static_cast<long long>(count))
        throw file_error(path, "map_length", "header says " + std::to_string(map_length) + " voxels, dims " +
                                                 std::to_string(dims[0]) + " x " + std::to_string(dims[1]) +
                                                 " x " + std::to_string(dims[2]) + " need " + std::to_string(count));
    check_exact_size(path, "data", count, bytes.size() - kHeaderBytes);

    Volume volume;
    volume.dims = {int(dims[0]), int(dims[1]), int(dims[2])};
    volume.voxels = to_float(bytes.data() + kHeaderBytes, count, ScalarType::u8, Endian::little);
    volume.stored_type = type_name(ScalarType::u8);
    volume.source = path;
    return volume;
}

}  // namespace sombra::volume_io
