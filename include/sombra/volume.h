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
    std::vector<float> voxels;
    std::string source;  // file path or generator name, for messages
    float value_min = 0.f, value_max = 0.f;

    std::size_t voxel_count() const {
        return std::size_t(dims[0]) * std::size_t(dims[1]) * std::size_t(dims[2]);
    }
    float at(int x, int y, int z) const {
        return voxels[std::size_t(x) + std::size_t(dims[0]) * (std::size_t(y) + std::size_t(dims[1]) * std::size_t(z))];
    }
    void update_range();  // recomputes value_min / value_max
};

// What to do with NaN or Inf voxels found in a file.
enum class NonFinitePolicy {
    Reject,   // throw sombra::Error naming the file and the count
    Sanitize  // replace by 0 and report the count in VolumeLoadReport
};

struct VolumeLoadOptions {
    NonFinitePolicy non_finite = NonFinitePolicy::Reject;
    std::uint64_t max_voxels = std::uint64_t(1) << 30;  // per volume (file or generator); ≤ limits::kMaxVolumeVoxels
};

struct VolumeLoadReport {
    std::size_t non_finite_replaced = 0;
    std::string format;  // "nifti", "npy", "npz", "den", "raw", "inr", "vtk"
};

// Reads a volume, choosing the reader by the file name:
//   .nii, .nii.gz        NIfTI-1 (niftiio)
//   .npy, .npz           NumPy array (3D, C order, shape (z, y, x)); .npz holds exactly one array
//   .den                 VolPack density file
//   .inr                 INRIMAGE-4
//   .vtk                 legacy VTK STRUCTURED_POINTS (ASCII or BINARY)
//   .json                raw voxels described by a small JSON header (see data/README.md: "Raw volumes")
// Throws sombra::Error with "FILE: FIELD: what" on any malformed, truncated or empty input.
Volume load_volume(const std::string& path, const VolumeLoadOptions& options = {},
                   VolumeLoadReport* report = nullptr);

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
