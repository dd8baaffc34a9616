// sombra — helpers shared by the volume file readers (internal to src/scene).
#pragma once
#include "sombra/error.h"
#include "sombra/limits.h"
#include "sombra/volume.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
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
std::size_t checked_voxel_count(const std::string& file, const std::array<long long, 3>& dims,
                                std::uint64_t limit = limits::kMaxVolumeVoxels);

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
// "uint8", "int16", "float32", … (Volume::stored_type).
const char* type_name(ScalarType type);

// Sets v.spacing and v.placement (see Volume::placement) from an index → world affine map:
// voxel (i, j, k) of v lies at world = origin + i·axes[0] + j·axes[1] + k·axes[2], axes[a] being
// the world step of one voxel along index axis a. spacing[a] = |axes[a]|. v.dims must be set.
// Throws "FILE: FIELD: ..." for a zero, non-finite or degenerate (flat) set of axes.
void set_geometry(Volume& v, const std::string& file, const std::string& field,
                  const std::array<std::array<double, 3>, 3>& axes, const std::array<double, 3>& origin);

// One line from a library's message: newlines and runs of blanks become one space, trimmed.
std::string one_line(const std::string& text);

// Formats whose voxels lie in one file as contiguous data, x fastest (C order (z, y, x)): a
// box of them can be read without the rest (VolumeLoadOptions::part).
struct RawLayout {
    std::string data_file;  // the file that holds the voxels
    std::uint64_t offset = 0;  // of voxel (0, 0, 0) in it
    std::array<long long, 3> dims{};
    ScalarType type = ScalarType::u8;
    Endian endian = Endian::little;
    // gzip-encoded (NRRD): the voxels lie in a gzip stream that starts at byte stream_start of
    // data_file, and offset counts decompressed bytes
    bool gzip = false;
    std::uint64_t stream_start = 0;
};
// The layout of a .npy, raw .json or NRRD file (raw or gzip, one data file), its geometry and
// stored type in `header` (dims up to limits::kMaxPartedVolumeVoxels); nullopt for other formats
// and other NRRD encodings. Checks the data's size against the file's (not a gzip stream's).
// Throws "FILE: FIELD: …".
std::optional<RawLayout> raw_layout(const std::string& path, const std::string& format, Volume& header);
// The voxels of `box` (inside layout.dims), read row by row (a gzip stream is decompressed up to
// the box's last row and the rest of it discarded); throws "FILE: part: …".
std::vector<float> read_raw_box(const std::string& path, const RawLayout& layout, const VoxelBox& box);
// The header of a .npy file (data at data_start in a file of `size` bytes; the header is
// bytes [0, header_size)): its layout; throws for a malformed header. `name` names the file in messages.
RawLayout parse_npy_header(const std::string& name, const unsigned char* data, std::size_t header_size,
                           std::uint64_t file_size, std::uint64_t voxel_limit = limits::kMaxVolumeVoxels);
// The bytes a .npy header spans: 8 + its length field + the dict (from its first 12 bytes).
std::size_t npy_header_size(const std::string& name, const unsigned char* data, std::size_t size);
// The layout and geometry of a raw .json file (see volume_io_raw.cpp).
RawLayout raw_json_layout(const std::string& path, Volume& header, std::uint64_t voxel_limit = limits::kMaxVolumeVoxels);

// Per-format readers. Each returns a volume with dims, spacing, voxels and source set; the
// NaN/Inf policy, the empty-volume check and the value range are applied by load_volume.
// The library readers (OpenVDB, ITK) also check options.max_voxels before they allocate.
Volume read_vdb(const std::string& path, const VolumeLoadOptions& options, VolumeLoadReport& report);
enum class ItkFormat { nrrd, metaimage, tiff, dicom, dicom_series };
Volume read_itk(const std::string& path, ItkFormat format, const VolumeLoadOptions& options);
// A file's header read by ITK alone (NRRD, MetaImage): dims, spacing, placement and stored_type in
// `volume` exactly as a whole read gives them, and the voxels' type and byte order; dims up to
// voxel_limit. nullopt for types sombra cannot read in parts (64-bit integers).
struct ItkHeader {
    Volume volume;
    ScalarType type = ScalarType::u8;
    Endian endian = Endian::little;
};
std::optional<ItkHeader> read_itk_header(const std::string& path, ItkFormat format, std::uint64_t voxel_limit);
Volume read_nifti(const std::string& path);
Volume read_npy(const std::string& path);
Volume read_npz(const std::string& path);
Volume read_den(const std::string& path);
Volume read_inr(const std::string& path);
Volume read_vtk(const std::string& path);
Volume read_raw_json(const std::string& path);

// Parses an in-memory .npy file; `name` is used in error messages (a path or "archive:member").
Volume parse_npy(const std::string& name, const unsigned char* data, std::size_t size);

// ---- Test-data writers: files written by the libraries themselves (tests, scripts) ----

// One grid of a .vdb file written by write_vdb.
struct VdbGridSpec {
    enum class Kind { Float, Double, Vec3 } kind = Kind::Float;
    std::string name;
    bool level_set = false;          // grid class: level set (values are signed distances) or fog
    std::array<int, 3> dims{0, 0, 0};
    std::vector<float> values;       // x fastest; a voxel equal to `background` stays inactive
    std::array<int, 3> index_min{0, 0, 0};  // VDB index of values[0]
    // Row-major 4×4: the world position of VDB index (i, j, k) is M · (i, j, k, 1).
    std::array<double, 16> index_to_world{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    float background = 0.f;
};
void write_vdb(const std::string& path, const std::vector<VdbGridSpec>& grids);

// Geometry as ITK holds it (LPS): physical point of index (i, j, k) = origin + D · diag(spacing) · (i, j, k),
// D row-major (its column a is the direction of index axis a).
struct ItkGeometry {
    std::array<double, 3> spacing{1, 1, 1};
    std::array<double, 3> origin{0, 0, 0};
    std::array<double, 9> direction{1, 0, 0, 0, 1, 0, 0, 0, 1};
};
// .nrrd, .nhdr, .mha, .mhd (float32) or .tif (uint16: values rounded) through ITK's writers.
void write_itk(const std::string& path, const std::array<int, 3>& dims, const std::vector<float>& values,
               const ItkGeometry& geometry, bool compress);
// A DICOM series through GDCM: one CT slice per file, named in no position order, holding the int16
// `stored` values with Rescale Slope/Intercept tags (the real value is stored · slope + intercept).
void write_dicom_series(const std::string& folder, const std::array<int, 3>& dims,
                        const std::vector<std::int16_t>& stored, const ItkGeometry& geometry, double slope,
                        double intercept);

}  // namespace sombra::volume_io
