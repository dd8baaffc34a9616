// sombra — Volume helpers and load_volume: reader dispatch plus the checks every format shares.
#include "sombra/volume.h"

#include "scene/input_file.h"
#include "scene/volume_io_common.h"

#include <algorithm>
#include <cctype>
#include <cmath>
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
    Volume (*read)(const std::string&);
};

const Reader kReaders[] = {
    {".nii.gz", "nifti", volume_io::read_nifti}, {".nii", "nifti", volume_io::read_nifti},
    {".npy", "npy", volume_io::read_npy},        {".npz", "npz", volume_io::read_npz},
    {".den", "den", volume_io::read_den},        {".inr", "inr", volume_io::read_inr},
    {".vtk", "vtk", volume_io::read_vtk},        {".json", "raw", volume_io::read_raw_json},
};

const Reader& reader_for(const std::string& path) {
    std::string lower = path;
    std::transform(lower.begin(), lower.end(), lower.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    for (const Reader& r : kReaders)
        if (ends_with(lower, r.extension)) return r;
    throw file_error(path, "", "unknown volume format (expected .nii, .nii.gz, .npy, .npz, .den, .inr, .vtk or .json)");
}

}  // namespace

Volume load_volume(const std::string& path, const VolumeLoadOptions& options, VolumeLoadReport* report) {
    const Reader& reader = reader_for(path);
    detail::regular_file_size(path);  // no directory, FIFO or device, whatever the reader
    Volume volume = reader.read(path);

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
        report->non_finite_replaced = non_finite;
        report->format = reader.format;
    }
    return volume;
}

}  // namespace sombra
