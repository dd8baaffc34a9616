// sombra — reading a box of a volume file without the rest (VolumeLoadOptions::part): the formats
// whose voxels are one contiguous run in a file (.npy, raw .json), read row by row.
#include "scene/volume_io_common.h"

#include "scene/input_file.h"

#include <fstream>

namespace sombra::volume_io {

std::optional<RawLayout> raw_layout(const std::string& path, const std::string& format, Volume& header) {
    if (format == "raw") return raw_json_layout(path, header, limits::kMaxPartedVolumeVoxels);
    if (format != "npy") return std::nullopt;
    const std::uint64_t size = detail::regular_file_size(path);
    std::ifstream in(path, std::ios::binary);
    if (!in) throw file_error(path, "", "cannot open");
    unsigned char start[12] = {};
    in.read(reinterpret_cast<char*>(start), sizeof start);
    const std::size_t header_size = npy_header_size(path, start, std::size_t(in.gcount()));
    if (header_size > size || header_size > limits::kMaxInputFileBytes) throw file_error(path, "header", "truncated header");
    std::vector<unsigned char> bytes(header_size);
    in.seekg(0);
    in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(header_size));
    if (std::size_t(in.gcount()) != header_size) throw file_error(path, "header", "truncated header");
    RawLayout layout = parse_npy_header(path, bytes.data(), header_size, size, limits::kMaxPartedVolumeVoxels);
    header.dims = {int(layout.dims[0]), int(layout.dims[1]), int(layout.dims[2])};
    header.stored_type = type_name(layout.type);
    header.source = path;
    return layout;
}

std::vector<float> read_raw_box(const std::string& path, const RawLayout& layout, const VoxelBox& box) {
    std::array<long long, 3> extent{};
    for (std::size_t a = 0; a < 3; ++a) {
        if (box.first[a] < 0 || box.first[a] > box.last[a] || box.last[a] >= layout.dims[a])
            throw file_error(path, "part", "voxels " + std::to_string(box.first[a]) + "…" + std::to_string(box.last[a]) +
                                               " of axis " + std::to_string(a) + " lie outside the file's " +
                                               std::to_string(layout.dims[a]));
        extent[a] = box.last[a] - box.first[a] + 1;
    }
    checked_voxel_count(path, extent);
    std::ifstream in(layout.data_file, std::ios::binary);
    if (!in) throw file_error(path, "part", "cannot open '" + layout.data_file + "'");
    const std::size_t size = type_size(layout.type);
    const std::uint64_t row_bytes = std::uint64_t(extent[0]) * size;
    std::vector<unsigned char> row(row_bytes);
    std::vector<float> voxels;
    voxels.reserve(std::size_t(extent[0] * extent[1] * extent[2]));
    for (long long z = box.first[2]; z <= box.last[2]; ++z)
        for (long long y = box.first[1]; y <= box.last[1]; ++y) {
            const std::uint64_t voxel = std::uint64_t(box.first[0]) + std::uint64_t(layout.dims[0]) * (std::uint64_t(y) + std::uint64_t(layout.dims[1]) * std::uint64_t(z));
            in.seekg(std::streamoff(layout.offset + voxel * size));
            in.read(reinterpret_cast<char*>(row.data()), std::streamsize(row_bytes));
            if (std::uint64_t(in.gcount()) != row_bytes) throw file_error(path, "part", "'" + layout.data_file + "' ends within row (y " +
                                                                                      std::to_string(y) + ", z " + std::to_string(z) + ")");
            const std::vector<float> values = to_float(row.data(), std::size_t(extent[0]), layout.type, layout.endian);
            voxels.insert(voxels.end(), values.begin(), values.end());
        }
    return voxels;
}

}  // namespace sombra::volume_io
