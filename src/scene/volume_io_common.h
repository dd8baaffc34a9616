// sombra — helpers shared by the volume file readers (internal to src/scene).
#pragma once
#include "sombra/error.h"
#include "sombra/limits.h"
#include "sombra/volume.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace sombra::volume_io {

enum class ScalarType { u8, i8, u16, i16, u32, i32, f32, f64 };
enum class Endian { little, big };

std::size_t type_size(ScalarType type);
Endian native_endian();

// The largest volume file read whole: the largest volume in the widest type, plus headers.
constexpr std::uint64_t kMaxVolumeFileBytes = limits::kMaxVolumeVoxels * 8 + (std::uint64_t(1) << 24);

// Reads a whole regular file (detail::read_regular_file); throws "FILE: cannot open ..." etc.
std::vector<unsigned char> read_file(const std::string& path);

// Checks that every dimension is positive and that the voxel count is at most
// limits::kMaxVolumeVoxels; throws "FILE: dims: ..." otherwise. Returns the voxel count.
std::size_t checked_voxel_count(const std::string& file, const std::array<long long, 3>& dims);

// Throws "FILE: FIELD: [SUBJECT is ]truncated: ..." when actual < expected and
// "FILE: FIELD: [SUBJECT ]has N extra bytes ..." when actual > expected.
void check_exact_size(const std::string& file, const std::string& field, std::uint64_t expected,
                      std::uint64_t actual, const std::string& subject = "");

// Parse a whole token as an integer / a finite number; throw "FILE: FIELD: not ..." otherwise.
long long parse_int(const std::string& file, const std::string& field, const std::string& text);
double parse_number(const std::string& file, const std::string& field, const std::string& text);

// Converts count values of the given type and byte order starting at data to floats.
// The caller guarantees data holds count * type_size(type) bytes.
std::vector<float> to_float(const unsigned char* data, std::size_t count, ScalarType type,
                            Endian endian);

// Per-format readers. Each returns a volume with dims, spacing, voxels and source set; the
// NaN/Inf policy, the empty-volume check and the value range are applied by load_volume.
Volume read_nifti(const std::string& path);
Volume read_npy(const std::string& path);
Volume read_npz(const std::string& path);
Volume read_den(const std::string& path);
Volume read_inr(const std::string& path);
Volume read_vtk(const std::string& path);
Volume read_raw_json(const std::string& path);

// Parses an in-memory .npy file; `name` is used in error messages (a path or "archive:member").
Volume parse_npy(const std::string& name, const unsigned char* data, std::size_t size);

}  // namespace sombra::volume_io
