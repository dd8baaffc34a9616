// sombra — Volume helpers and load_volume: reader dispatch plus the checks every format shares.
#include "sombra/volume.h"

#include "scene/input_file.h"
#include "scene/volume_io_common.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

namespace sombra {

void Volume::update_range() {
    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
    for (float v : voxels) {
        if (!std::isfinite(v)) continue;
        lo = std::min(lo, v);
        hi = std::max(hi, v);
    }
    if (lo > hi) lo = hi = 0.f;  // empty, or nothing finite
    value_min = lo;
    value_max = hi;
}

namespace {

bool ends_with(const std::string& s, const std::string& suffix) {
    return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

struct Reader {
    const char* extension;
    const char* format;
    Volume (*read)(const std::string&, const VolumeLoadOptions&, VolumeLoadReport&);
};

template <Volume (*F)(const std::string&)>
Volume plain(const std::string& path, const VolumeLoadOptions&, VolumeLoadReport&) { return F(path); }
template <volume_io::ItkFormat F>
Volume itk(const std::string& path, const VolumeLoadOptions& options, VolumeLoadReport&) {
    return volume_io::read_itk(path, F, options);
}

using volume_io::ItkFormat;
const Reader kReaders[] = {
    {".nii.gz", "nifti", plain<volume_io::read_nifti>}, {".nii", "nifti", plain<volume_io::read_nifti>},
    {".npy", "npy", plain<volume_io::read_npy>},         {".npz", "npz", plain<volume_io::read_npz>},
    {".den", "den", plain<volume_io::read_den>},         {".inr", "inr", plain<volume_io::read_inr>},
    {".vtk", "vtk", plain<volume_io::read_vtk>},         {".json", "raw", plain<volume_io::read_raw_json>},
    {".vdb", "vdb", volume_io::read_vdb},
    {".nrrd", "nrrd", itk<ItkFormat::nrrd>},             {".nhdr", "nrrd", itk<ItkFormat::nrrd>},
    {".mha", "metaimage", itk<ItkFormat::metaimage>},    {".mhd", "metaimage", itk<ItkFormat::metaimage>},
    {".tif", "tiff", itk<ItkFormat::tiff>},              {".tiff", "tiff", itk<ItkFormat::tiff>},
    {".dcm", "dicom", itk<ItkFormat::dicom>},
};
const Reader kDicomSeries{"", "dicom-series", itk<ItkFormat::dicom_series>};
const Reader kDicomFile{"", "dicom", itk<ItkFormat::dicom>};

constexpr const char* kKnown =
    "expected .nii, .nii.gz, .npy, .npz, .den, .inr, .vtk, .json, .vdb, .nrrd, .nhdr, .mha, .mhd, .tif, .tiff, "
    ".dcm, or a folder holding one DICOM series";

// A DICOM Part 10 file has "DICM" at byte 128, whatever its name (series files often have none).
bool has_dicom_magic(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    char magic[132] = {};
    return in.read(magic, sizeof magic) && std::memcmp(magic + 128, "DICM", 4) == 0;
}

const Reader& reader_for(const std::string& path) {
    std::string lower = path;
    std::transform(lower.begin(), lower.end(), lower.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    for (const Reader& r : kReaders)
        if (ends_with(lower, r.extension)) return r;
    std::error_code ec;
    const auto status = std::filesystem::status(path, ec);
    if (!ec && std::filesystem::is_directory(status)) return kDicomSeries;
    if (!ec && std::filesystem::is_regular_file(status) && has_dicom_magic(path)) return kDicomFile;
    if (ec || !std::filesystem::exists(status))
        throw file_error(path, "", "no such file or folder (" + std::string(kKnown) + ")");
    throw file_error(path, "", std::string("unknown volume format (") + kKnown + ")");
}

}  // namespace

namespace {
// Voxels `box` of `whole`, for the formats that cannot read a part alone.
Volume crop(const std::string& path, const Volume& whole, const VoxelBox& box) {
    Volume part = whole;
    for (std::size_t a = 0; a < 3; ++a) {
        if (box.first[a] < 0 || box.first[a] > box.last[a] || box.last[a] >= whole.dims[a])
            throw file_error(path, "part", "voxels " + std::to_string(box.first[a]) + "…" + std::to_string(box.last[a]) + " of axis " +
                                               std::to_string(a) + " lie outside the file's " + std::to_string(whole.dims[a]));
        part.dims[a] = box.last[a] - box.first[a] + 1;
    }
    part.voxels.clear();
    part.voxels.reserve(part.voxel_count());
    for (int z = box.first[2]; z <= box.last[2]; ++z)
        for (int y = box.first[1]; y <= box.last[1]; ++y)
            for (int x = box.first[0]; x <= box.last[0]; ++x) part.voxels.push_back(whole.at(x, y, z));
    return part;
}
}  // namespace

Volume load_volume(const std::string& path, const VolumeLoadOptions& options, VolumeLoadReport* report) {
    std::error_code ec;
    const auto status = std::filesystem::status(path, ec);
    if (!ec && std::filesystem::exists(status) && !std::filesystem::is_directory(status) && !std::filesystem::is_regular_file(status))
        detail::regular_file_size(path);  // a FIFO or a device says so, whatever its name
    const Reader& reader = reader_for(path);
    if (!options.grid.empty() && std::string(reader.format) != "vdb")
        throw file_error(path, "grid", "only .vdb files have named grids");
    if (&reader != &kDicomSeries)
        detail::regular_file_size(path);  // no directory, FIFO or device, whatever the reader
    VolumeLoadReport local;
    Volume volume;
    std::optional<volume_io::RawLayout> layout;
    if (options.header_only || options.read_part) layout = volume_io::raw_layout(path, reader.format, volume);
    if (layout && options.header_only) {  // dims, type and geometry; the voxels come in parts
        volume.header_only = true;
        if (report) *report = local, report->format = reader.format;
        return volume;
    }
    if (layout) {
        volume.voxels = volume_io::read_raw_box(path, *layout, options.part);
        for (std::size_t a = 0; a < 3; ++a) volume.dims[a] = options.part.last[a] - options.part.first[a] + 1;
    } else {
        volume = reader.read(path, options, local);
        if (options.read_part) volume = crop(path, volume, options.part);  // read whole: the format cannot seek
    }

    const std::size_t count = volume_io::checked_voxel_count(
        path, {volume.dims[0], volume.dims[1], volume.dims[2]});
    if (count > options.max_voxels)
        throw file_error(path, "dims", std::to_string(count) + " voxels exceed the limit of " +
                                           std::to_string(options.max_voxels));
    if (volume.voxels.size() != count)
        throw file_error(path, "data", "holds " + std::to_string(volume.voxels.size()) + " voxels, expected " +
                                           std::to_string(count));

    std::size_t non_finite = 0;
    for (float v : volume.voxels) non_finite += std::isfinite(v) ? 0 : 1;
    if (non_finite > 0 && options.non_finite == NonFinitePolicy::Reject)
        throw file_error(path, "voxels", std::to_string(non_finite) +
                                             " non-finite voxels (NaN/Inf); load with the sanitize policy to "
                                             "replace them by 0");
    if (non_finite > 0)
        for (float& v : volume.voxels)
            if (!std::isfinite(v)) v = 0.f;

    volume.source = path;
    volume.update_range();
    if (report) {
        *report = local;
        report->non_finite_replaced = non_finite;
        report->format = reader.format;
    }
    return volume;
}

}  // namespace sombra
