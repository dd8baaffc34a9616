// sombra — reading a box of a volume file without the rest (VolumeLoadOptions::part): the formats
// whose voxels are one contiguous run in a file (.npy, raw .json, NRRD raw or gzip), read row by
// row; a gzip stream is decompressed in order and the rows outside the box thrown away.
#include "scene/volume_io_common.h"

#include "scene/input_file.h"
#include "scene/volume_io_itk_checks.h"

#include <cstdio>
#include <fstream>
#include <memory>

#include <fcntl.h>
#include <unistd.h>
#include <zlib.h>

namespace sombra::volume_io {
namespace {

std::optional<RawLayout> nrrd_layout(const std::string& path, Volume& header) {
    std::optional<ItkHeader> itk = read_itk_header(path, ItkFormat::nrrd, limits::kMaxPartedVolumeVoxels);
    if (!itk) return std::nullopt;
    const std::optional<NrrdDataLocation> where = nrrd_data_location(path);
    if (!where) return std::nullopt;
    RawLayout layout;
    layout.data_file = where->data_file;
    layout.dims = {itk->volume.dims[0], itk->volume.dims[1], itk->volume.dims[2]};
    layout.type = itk->type;
    layout.endian = itk->endian;
    const std::uint64_t bytes = std::uint64_t(checked_voxel_count(path, layout.dims, limits::kMaxPartedVolumeVoxels)) *
                                type_size(layout.type);
    if (where->gzip) {
        layout.gzip = true;
        layout.stream_start = where->start;
        layout.offset = std::uint64_t(where->byte_skip);
    } else {
        const std::uint64_t size = detail::regular_file_size(layout.data_file);
        layout.offset = where->byte_skip == -1 ? (size >= bytes ? size - bytes : 0) : where->start + std::uint64_t(where->byte_skip);
        if (where->byte_skip == -1 ? size < where->start + bytes : layout.offset + bytes > size)
            throw file_error(path, "data", "truncated: '" + layout.data_file + "' holds " + std::to_string(size) +
                                               " bytes, the header declares " + std::to_string(bytes) + " bytes of voxels from byte " +
                                               std::to_string(where->byte_skip == -1 ? where->start : layout.offset));
    }
    header = std::move(itk->volume);
    return layout;
}

// Reads bytes [offset, offset + n) of a file or of a gzip stream, in increasing offsets.
class DataReader {
public:
    DataReader(const std::string& path, const RawLayout& layout) : path_(path), layout_(layout) {
        if (!layout.gzip) {
            plain_.open(layout.data_file, std::ios::binary);
            if (!plain_) throw file_error(path, "part", "cannot open '" + layout.data_file + "'");
            return;
        }
        const int fd = ::open(layout.data_file.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd < 0 || ::lseek(fd, off_t(layout.stream_start), SEEK_SET) < 0) {
            if (fd >= 0) ::close(fd);
            throw file_error(path, "part", "cannot open '" + layout.data_file + "'");
        }
        gz_ = gzdopen(fd, "rb");  // decompresses from the descriptor's position
        if (!gz_) {
            ::close(fd);
            throw file_error(path, "part", "cannot open the gzip stream of '" + layout.data_file + "'");
        }
        gzbuffer(gz_, 1 << 20);
    }
    ~DataReader() {
        if (gz_) gzclose(gz_);
    }
    DataReader(const DataReader&) = delete;
    DataReader& operator=(const DataReader&) = delete;

    // false when the data ends before offset + n
    bool read(std::uint64_t offset, unsigned char* out, std::size_t n) {
        if (!gz_) {
            plain_.seekg(std::streamoff(offset));
            plain_.read(reinterpret_cast<char*>(out), std::streamsize(n));
            return std::size_t(plain_.gcount()) == n;
        }
        if (gzseek(gz_, z_off_t(offset), SEEK_SET) != z_off_t(offset)) return stream_failed();  // forward: inflates and discards
        for (std::size_t done = 0; done < n;) {
            const unsigned chunk = unsigned(std::min<std::size_t>(n - done, 1u << 30));
            const int got = gzread(gz_, out + done, chunk);
            if (got <= 0) return stream_failed();
            done += std::size_t(got);
        }
        return true;
    }

private:
    bool stream_failed() {
        int code = Z_OK;
        const char* message = gzerror(gz_, &code);
        if (code != Z_OK && code != Z_BUF_ERROR)  // Z_BUF_ERROR: the stream simply ends early
            throw file_error(path_, "data", "corrupt gzip stream in '" + layout_.data_file + "': " + (message ? message : "?"));
        return false;
    }

    std::string path_;
    const RawLayout& layout_;
    std::ifstream plain_;
    gzFile gz_ = nullptr;
};

}  // namespace

std::optional<RawLayout> raw_layout(const std::string& path, const std::string& format, Volume& header) {
    if (format == "raw") return raw_json_layout(path, header, limits::kMaxPartedVolumeVoxels);
    if (format == "nrrd") return nrrd_layout(path, header);
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
    DataReader in(path, layout);
    const std::size_t size = type_size(layout.type);
    const std::uint64_t row_bytes = std::uint64_t(extent[0]) * size;
    std::vector<unsigned char> row(row_bytes);
    std::vector<float> voxels;
    voxels.reserve(std::size_t(extent[0] * extent[1] * extent[2]));
    for (long long z = box.first[2]; z <= box.last[2]; ++z)
        for (long long y = box.first[1]; y <= box.last[1]; ++y) {
            const std::uint64_t voxel = std::uint64_t(box.first[0]) + std::uint64_t(layout.dims[0]) * (std::uint64_t(y) + std::uint64_t(layout.dims[1]) * std::uint64_t(z));
            if (!in.read(layout.offset + voxel * size, row.data(), std::size_t(row_bytes)))
                throw file_error(path, "part", "'" + layout.data_file + "' ends within row (y " + std::to_string(y) + ", z " +
                                                   std::to_string(z) + ")");
            const std::vector<float> values = to_float(row.data(), std::size_t(extent[0]), layout.type, layout.endian);
            voxels.insert(voxels.end(), values.begin(), values.end());
        }
    return voxels;
}

}  // namespace sombra::volume_io
