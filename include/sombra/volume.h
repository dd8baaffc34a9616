// sombra — scalar volumes: in-memory form, file readers and procedural generators.
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace sombra {

// A scalar volume on a regular grid. Voxels are stored x fastest, then y, then z:
// index = x + dims[0] * (y + dims[1] * z).
struct Volume {
    std::array<int, 3> dims{0, 0, 0};
    std::array<float, 3> spacing{1.f, 1.f, 1.f};  // voxel size along x, y, z (file units, e.g. mm)
    // Where the file puts the volume, spacing aside: a row-major 4×4 affine map from the volume's
    // object frame (voxel (i, j, k) at ((i − (nx−1)/2)·sx, …), centred at the origin, as in
    // VolumeInstance) to the file's world frame. Its 3×3 part holds the direction cosines (rotation,
    // flips; for OpenVDB any shear left after the spacing is taken out), its last column the world
    // position of the volume's centre. Medical images (NIfTI, DICOM, NRRD, MetaImage) are placed in
    // RAS+ millimetres (+x towards the patient's right, +y anterior, +z superior: NIfTI's and 3D
    // Slicer's frame; ITK's LPS is converted); OpenVDB grids in the grid's own world units. Identity for
    // formats without a placement (npy, den, inr, vtk, raw) and for the generators: centred at the
    // origin, axes as stored. load_scene folds it into VolumeInstance::transform.
    std::array<float, 16> placement{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    std::vector<float> voxels;
    std::string source;  // file path or generator name, for messages
    // The voxel type in the file, before conversion to float: "uint8", "int16", "float32", "half"
    // (OpenVDB) …; "float32" for the generators, "" where unknown.
    std::string stored_type;
    float value_min = 0.f, value_max = 0.f;

    std::size_t voxel_count() const {
        return std::size_t(dims[0]) * std::size_t(dims[1]) * std::size_t(dims[2]);
    }
    float at(int x, int y, int z) const {
        return voxels[std::size_t(x) + std::size_t(dims[0]) * (std::size_t(y) + std::size_t(dims[1]) * std::size_t(z))];
    }
    void update_range();  // recomputes value_min / value_max
    // Loaded with VolumeLoadOptions::header_only from a format that reads parts: dims, spacing,
    // placement and stored_type as the file says, no voxels; load_volume with
    // VolumeLoadOptions::part reads a box of it (a rank of a distributed render, sombra/distributed.h).
    bool header_only = false;
};

// Voxels first[a] … last[a] (inclusive) along each axis a of a volume file.
struct VoxelBox {
    std::array<int, 3> first{0, 0, 0}, last{0, 0, 0};
};

// What to do with NaN or Inf voxels found in a file.
enum class NonFinitePolicy {
    Reject,   // throw sombra::Error naming the file and the count
    Sanitize  // replace by 0 and report the count in VolumeLoadReport
};

struct VolumeLoadOptions {
    NonFinitePolicy non_finite = NonFinitePolicy::Reject;
    std::uint64_t max_voxels = std::uint64_t(1) << 30;  // per volume (file or generator); ≤ limits::kMaxVolumeVoxels
    // .vdb: the grid to read, by name; empty: "density" if the file has that scalar grid, else the
    // first float or double grid in OpenVDB's listing (by name)
    std::string grid;
    // Only the header of formats that can read parts (.npy, raw .json, and NRRD with raw or gzip data
    // in one file): Volume::header_only, no voxels, and dims up to limits::kMaxPartedVolumeVoxels in
    // all; other formats read whole.
    bool header_only = false;
    // Only this box of the file's voxels: the Volume's dims are the box's. Those formats read just
    // those bytes, so no process holds the whole volume (a gzip NRRD inflates its stream up to the
    // box's last row and keeps only the box); the other formats read the whole file and crop.
    // max_voxels applies to the box.
    bool read_part = false;
    VoxelBox part;
};

struct VolumeLoadReport {
    std::size_t non_finite_replaced = 0;
    // "nifti", "npy", "npz", "den", "raw", "inr", "vtk", "vdb", "nrrd", "metaimage", "tiff",
    // "dicom" (one file) or "dicom-series" (a folder)
    std::string format;
    std::string grid;        // .vdb: the grid read
    float background = 0.f;  // .vdb: the grid's background value (inactive voxels inside the box hold it)
};

// Reads a volume, choosing the reader by the file name:
//   .nii, .nii.gz        NIfTI-1 (niftiio)
//   .npy, .npz           NumPy array (3D, C order, shape (z, y, x)); .npz holds exactly one array
//   .den                 VolPack density file
//   .inr                 INRIMAGE-4
//   .vtk                 legacy VTK STRUCTURED_POINTS (ASCII or BINARY)
//   .json                raw voxels described by a small JSON header (see data/README.md: "Raw volumes")
//   .vdb                 OpenVDB float/double grid (fog volume, or level set turned into fog), its
//                        active bounding box made dense; options.grid chooses the grid
//   .nrrd, .nhdr         NRRD (raw, gzip; attached or detached data) through ITK
//   .mha, .mhd           MetaImage through ITK
//   .tif, .tiff          TIFF, a multi-page file read as a stack of z slices, through ITK
//   .dcm                 one DICOM file (a slice or a multi-frame volume) through ITK/GDCM
//   a folder             a DICOM series: its slices sorted by position, rescale slope and
//                        intercept applied, spacing and orientation from the headers (ITK/GDCM)
// Fills Volume::placement where the file has one (NIfTI, OpenVDB, NRRD, MetaImage, DICOM).
// Throws sombra::Error with "FILE: FIELD: what" on any malformed, truncated or empty input.
Volume load_volume(const std::string& path, const VolumeLoadOptions& options = {},
                   VolumeLoadReport* report = nullptr);

// The values of a volume's voxels, for `sombra info` and the transfer-function presets of volume
// scenes (scene.h). Percentiles interpolate linearly between the closest ranks (numpy's default);
// they are exact up to 2^24 voxels, and over every k-th voxel (k = ⌈voxels / 2^24⌉) above. The
// background is the voxels at most 1 % of the value range above the minimum (air, empty space).
struct VolumeStatistics {
    static constexpr std::array<double, 7> kPercentiles{1, 5, 25, 50, 75, 95, 99};
    std::size_t voxels = 0;
    double min = 0, max = 0, mean = 0;
    std::array<double, 7> percentiles{};             // of every voxel, at kPercentiles
    double background_threshold = 0;                 // min + 0.01 · (max − min)
    std::size_t background_voxels = 0;               // voxels ≤ background_threshold
    std::array<double, 7> foreground_percentiles{};  // of the voxels above it (= percentiles when none is)
    std::vector<std::size_t> histogram;              // equal bins over [min, max], the last one closed
};
VolumeStatistics volume_statistics(const Volume& volume, int bins = 16);

// Writes a volume as NIfTI-1 (.nii or .nii.gz, float32). Used by the converter and by tests.
void save_volume_nifti(const Volume& volume, const std::string& path);

// Procedural volumes, for tests and small scenes. All values lie in [0, 1].
Volume make_sphere(int n, float radius_fraction = 0.4f, float density = 1.f);  // n³, sharp-edged ball
Volume make_slab(int n, int axis, float lo_fraction, float hi_fraction, float density = 1.f);
Volume make_gaussian_blobs(int n, int blob_count, std::uint32_t seed);
Volume make_cloud_noise(int n, std::uint32_t seed);  // fractal value noise in a soft ball
// Steam or smoke rising along +z from a narrow base at the bottom's centre: fractal noise in a
// swaying plume that widens with height and fades out towards the top.
Volume make_steam_plume(int n, std::uint32_t seed);

}  // namespace sombra
