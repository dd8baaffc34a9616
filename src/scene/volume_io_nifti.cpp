// sombra — NIfTI-1 (.nii, .nii.gz) reading and writing through niftiio.
#include "scene/volume_io_common.h"

#include "scene/input_file.h"

#include <nifti1_io.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>

namespace sombra {
namespace volume_io {
namespace {

constexpr int kMsbFirst = 2;  // nifti_image::byteorder of big-endian files (MSB_FIRST is private to niftiio)

struct NiftiFree {
    void operator()(nifti_image* nim) const { nifti_image_free(nim); }
};
using NiftiPtr = std::unique_ptr<nifti_image, NiftiFree>;

ScalarType scalar_type(const std::string& path, int datatype) {
    switch (datatype) {
        case NIFTI_TYPE_UINT8: return ScalarType::u8;
        case NIFTI_TYPE_INT8: return ScalarType::i8;
        case NIFTI_TYPE_UINT16: return ScalarType::u16;
        case NIFTI_TYPE_INT16: return ScalarType::i16;
        case NIFTI_TYPE_UINT32: return ScalarType::u32;
        case NIFTI_TYPE_INT32: return ScalarType::i32;
        case NIFTI_TYPE_FLOAT32: return ScalarType::f32;
        case NIFTI_TYPE_FLOAT64: return ScalarType::f64;
        default:
            throw file_error(path, "datatype", "unsupported NIfTI datatype " + std::to_string(datatype) +
                                                   (nifti_is_valid_datatype(datatype)
                                                        ? std::string(" (") + nifti_datatype_string(datatype) + ")"
                                                        : std::string()) +
                                                   " (expected uint8, int8, uint16, int16, uint32, int32, float32 or float64)");
    }
}

float spacing_of(float pixdim) { return std::isfinite(pixdim) && pixdim != 0.f ? std::fabs(pixdim) : 1.f; }

// Checks the header as stored, before niftiio sees it: nifti_image_read prints to stderr on a bad
// header (dimensions, datatype) whatever the debug level, and silently turns dimensions <= 0 into 1.
std::array<long long, 3> checked_header(const std::string& path) {
    int swapped = 0;
    std::unique_ptr<nifti_1_header, void (*)(void*)> header(nifti_read_header(path.c_str(), &swapped, 0), std::free);
    if (!header) throw file_error(path, "header", "not a readable NIfTI-1 header");
    if (std::memcmp(header->magic, "n+1", 4) != 0 && std::memcmp(header->magic, "ni1", 4) != 0)
        throw file_error(path, "magic", "not a NIfTI-1 file");
    if (header->dim[0] < 1 || header->dim[0] > 7)
        throw file_error(path, "dim", "dim[0] = " + std::to_string(header->dim[0]) + " is not in 1..7");
    for (int d = 4; d <= header->dim[0]; ++d)
        if (header->dim[d] < 1) throw file_error(path, "dim", "dim[" + std::to_string(d) + "] must be >= 1");
    const std::array<long long, 3> dims = {header->dim[1], header->dim[2], header->dim[3]};
    checked_voxel_count(path, dims);
    scalar_type(path, header->datatype);
    return dims;
}

// Reads the voxel bytes ourselves (not nifti_image_load): niftiio neither reports a short read
// of an uncompressed file nor keeps NaN/Inf (it silently turns them into 0).
// Memory grows with the bytes that really arrive, so a header that promises gigabytes over a short
// (or compressed) file allocates nothing up front.
std::vector<unsigned char> read_voxel_bytes(const std::string& path, const nifti_image& nim, std::size_t bytes) {
    const bool compressed = nifti_is_gzfile(nim.iname);
    const std::uint64_t file_size = detail::regular_file_size(nim.iname);  // znzopen would block on a FIFO
    if (!compressed && file_size < std::uint64_t(nim.iname_offset) + bytes)
        check_exact_size(path, "data", bytes, file_size - std::min<std::uint64_t>(file_size, nim.iname_offset));
    znzFile file = znzopen(nim.iname, "rb", compressed);
    if (znz_isnull(file)) throw file_error(path, "", "cannot open for reading");
    std::vector<unsigned char> data;
    bool overrun = false, failed = znzseek(file, nim.iname_offset, SEEK_SET) < 0;
    if (!failed)
        data = detail::read_declared(
            bytes,
            [&](unsigned char* to, std::size_t n) -> long long {
                const std::size_t got = znzread(to, 1, n, file);
                return got > n ? -1 : static_cast<long long>(got);  // (size_t)-1: a corrupt stream
            },
            &overrun, &failed);
    znzclose(file);
    if (failed) throw file_error(path, "data", "unreadable voxel data (corrupt compressed stream)");
    check_exact_size(path, "data", bytes, data.size());  // a short read: truncated
    return data;
}

}  // namespace

Volume read_nifti(const std::string& path) {
    detail::regular_file_size(path);
    nifti_set_debug_level(0);
    const std::array<long long, 3> dims = checked_header(path);
    NiftiPtr nim(nifti_image_read(path.c_str(), 0));
    if (!nim) throw file_error(path, "header", "not a readable NIfTI-1 header");

    const bool one_frame = nim->ndim == 3 || (nim->ndim == 4 && nim->nt == 1);
    if (!one_frame)
        throw file_error(path, "dim", "expected a 3-D image (or 4-D with one frame), found " +
                                          std::to_string(nim->ndim) + " dimensions");
    const ScalarType type = scalar_type(path, nim->datatype);
    const std::size_t count = checked_voxel_count(path, dims);
    if (std::size_t(nim->nvox) != count || std::size_t(nim->nbyper) != type_size(type) || nim->iname_offset < 0)
        throw file_error(path, "dim", "header sizes are inconsistent");
    const std::vector<unsigned char> data = read_voxel_bytes(path, *nim, count * type_size(type));

    Volume volume;
    volume.dims = {int(nim->nx), int(nim->ny), int(nim->nz)};
    volume.spacing = {spacing_of(nim->pixdim[1]), spacing_of(nim->pixdim[2]), spacing_of(nim->pixdim[3])};
    volume.voxels = to_float(data.data(), count, type, nim->byteorder == kMsbFirst ? Endian::big : Endian::little);
    volume.stored_type = type_name(type);
    // Orientation and position: the sform when it has a code, else the qform (nibabel's rule);
    // both map (i, j, k) to RAS+ millimetres, sombra's frame for medical images. Neither: identity.
    const mat44* xform = nim->sform_code > 0 ? &nim->sto_xyz : nim->qform_code > 0 ? &nim->qto_xyz : nullptr;
    if (xform) {
        std::array<std::array<double, 3>, 3> axes{};
        for (int a = 0; a < 3; ++a)
            for (int r = 0; r < 3; ++r) axes[std::size_t(a)][std::size_t(r)] = xform->m[r][a];
        set_geometry(volume, path, nim->sform_code > 0 ? "srow" : "quatern", axes,
                     {xform->m[0][3], xform->m[1][3], xform->m[2][3]});
    }
    const float slope = nim->scl_slope, inter = nim->scl_inter;
    if (std::isfinite(slope) && slope != 0.f && !(slope == 1.f && inter == 0.f))
        for (float& v : volume.voxels) v = v * slope + inter;
    volume.source = path;
    return volume;
}

}  // namespace volume_io

void save_volume_nifti(const Volume& volume, const std::string& path) {
    const std::size_t count = volume_io::checked_voxel_count(path, {volume.dims[0], volume.dims[1], volume.dims[2]});
    if (volume.voxels.size() != count)
        throw file_error(path, "voxels", "volume holds " + std::to_string(volume.voxels.size()) +
                                             " voxels, its dims need " + std::to_string(count));
    nifti_set_debug_level(0);
    const int dims[8] = {3, volume.dims[0], volume.dims[1], volume.dims[2], 1, 1, 1, 1};
    volume_io::NiftiPtr nim(nifti_make_new_nim(dims, NIFTI_TYPE_FLOAT32, 0));
    if (!nim) throw file_error(path, "", "cannot create a NIfTI image");
    nim->dx = nim->pixdim[1] = volume.spacing[0];
    nim->dy = nim->pixdim[2] = volume.spacing[1];
    nim->dz = nim->pixdim[3] = volume.spacing[2];
    nim->xyz_units = NIFTI_UNITS_MM;
    const std::array<float, 16> identity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    if (volume.placement != identity) {  // the sform: voxel (i, j, k) → placement · (S·((i, j, k) − c))
        nim->sform_code = NIFTI_XFORM_SCANNER_ANAT;
        for (int r = 0; r < 3; ++r) {
            double t = volume.placement[std::size_t(r * 4 + 3)];
            for (int a = 0; a < 3; ++a) {
                const double step = double(volume.placement[std::size_t(r * 4 + a)]) * volume.spacing[std::size_t(a)];
                nim->sto_xyz.m[r][a] = float(step);
                t -= step * 0.5 * double(volume.dims[std::size_t(a)] - 1);
            }
            nim->sto_xyz.m[r][3] = float(t);
        }
        nim->sto_xyz.m[3][0] = nim->sto_xyz.m[3][1] = nim->sto_xyz.m[3][2] = 0.f;
        nim->sto_xyz.m[3][3] = 1.f;
    }
    if (nifti_set_filenames(nim.get(), path.c_str(), 0, 1) != 0)
        throw file_error(path, "", "not a valid NIfTI file name (use .nii or .nii.gz)");

    nim->data = const_cast<float*>(volume.voxels.data());  // niftiio only reads it while writing
    // write_opts 3 = write the data and leave the file open, so that a failure shows as NULL.
    znzFile file = nifti_image_write_hdr_img2(nim.get(), 3, "wb", nullptr, nullptr);
    nim->data = nullptr;  // not ours to free
    if (file == nullptr) {
        std::remove(path.c_str());  // leave no partial file behind
        throw file_error(path, "", "cannot write the NIfTI file");
    }
    znzclose(file);
    if (!std::ifstream(path, std::ios::binary)) throw file_error(path, "", "cannot write the NIfTI file");
}

}  // namespace sombra
