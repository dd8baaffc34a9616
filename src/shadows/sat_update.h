// sombra — Ament et al. 2014 Algorithm 1, first pass, made granular: a render on a kept Context
// rebuilds only the summed-area tables and shadow-cache entries whose inputs changed.
//
// - A table (a CSAT per frame of orthodirectional lights, an SSAT per point/spot light, the
//   baselines' volume-aligned SAT) is keyed by its geometry (sat_table_geometry_key: frame or
//   spherical grid, bit for bit) and the extinction inputs of every volume (the tables hold them
//   all). Light colour and intensity are in no key: changing them rebuilds nothing.
// - A shadow-cache entry (volume i × light m) is keyed by the geometry of light m's table and m's
//   place in it, volume i's lattice, the filter (width, kernel, cone angle), and the extinction
//   inputs of the volumes that can reach the entry's filtered shadow region (`influences`): a
//   transfer-function change of one volume rebuilds every table but only the entries it can reach.
#pragma once
#include <string>
#include <vector>

#include "shadows/sat_grid.h"
#include "sombra/render.h"

namespace sombra::shadows {

// What a volume's voxels are: identity, size and a sample of the values (meshes and volumes are
// immutable once shared; the sample catches a reused address).
std::string volume_data_key(const Volume& volume);
// Its size and the sample of the values only: the same for two copies of the same voxels.
std::string volume_sample_key(const Volume& volume);
// Its identity alone: the Volume's address.
std::string volume_identity(const Volume& volume);
// A weighted sum of about 4096 of the n values, evenly strided: the "sample" of the keys above
// (and of mesh corners, renderer.cpp scene_keys).
double sampled_checksum(const float* values, std::size_t n);

// Per volume, everything its extinction σ at a world point depends on: the voxels, the placement
// (world_to_voxel), the σ column of its transfer-function table and the table's domain, and buffer
// or image sampling. Colour points change it only when they change the domain.
std::vector<std::string> extinction_keys(const Scene& scene, const packing::PackedScene& packed, bool use_images);

// The buffer the tables live in and which table sits where, under which key; kept between calls
// (by the low-pass module, src/techniques/sat_shadows.cpp) so that unchanged tables are reused.
struct SatPool {
    struct Slot {
        std::string key;
        std::size_t offset = 0, entries = 0;
    };
    cl::Buffer data;
    std::size_t capacity = 0;  // entries
    std::vector<Slot> slots;
};

struct SatUpdateCounts {
    int built = 0, reused = 0;
};

// Ament Alg. 1, lines 2–3 and 8 (recomputeCSAT, recomputeSSAT), per table: plans the tables that
// the lights need (light_aligned: CSATs and SSATs; else the volume-aligned SAT of the baselines),
// keeps every table of `pool` (the previous call's) whose key is unchanged, where it is, and builds
// the others into the gaps (or into a new, compact buffer, the kept tables copied, stage
// "sat_copy"). coarsen: how much coarser than a voxel the cells may be — the light-aligned tables'
// across the light (plan_light_sats), the volume-aligned table's on every axis (plan_volume_sat).
// Returned stage_ms: this call's kernels only.
DeviceSat update_sats(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
                      const packing::DeviceScene& device_scene, bool light_aligned, std::size_t max_entries, int lanes,
                      SatPool& pool, SatUpdateCounts& counts, double coarsen = 1);

// Whether the extinction of volume j can reach the shadow term that `options.shadows` gives volume
// i's lattice towards light m (conservative: world bounding boxes, the filter patch and two cells
// of margin; cone shadows: always).
bool influences(const packing::PackedScene& packed, const DeviceSat& sat, const RenderOptions& options, std::size_t i,
                std::size_t j, std::size_t m);

// The key of every shadow-cache entry, volume-major (entry i · lights + m); see the file comment.
std::vector<std::string> shadow_cache_keys(const Scene& scene, const packing::PackedScene& packed, const DeviceSat& sat,
                                           const std::vector<std::string>& extinction, const RenderOptions& options);

}  // namespace sombra::shadows
