// sombra — light-aligned summed-area tables for low-pass filtered shadows (Ament et al. 2014
// §4.2.1–4.2.2): a Cartesian SAT (CSAT) per group of orthodirectional directional lights, built on
// the device by cl/sat_build.cl and read by cl/lowpass.h.
#pragma once
#include <CL/opencl.hpp>

#include <algorithm>
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "geometry/scene_upload.h"

namespace sombra::shadows {

using D3 = std::array<double, 3>;

// World corners of every volume's box [−0.5, dims − 0.5] (8 per volume, in volume order) and the
// smallest world voxel length.
std::vector<D3> scene_corners(const packing::PackedScene& packed, double& voxel_size);
// The same for the part of each volume where σ can be non-zero: the box of its occupied bricks
// (PackedScene::occupancy; a brick covers voxels [4b, 4b + 4], and every trilinear sample outside
// the occupied bricks reads only voxels of unoccupied ones). A volume with no occupied brick has
// no corners; when no volume has one, the whole boxes (a table of zeros, as before).
std::vector<D3> occupied_corners(const packing::PackedScene& packed, double& voxel_size);
// The same per volume (in volume order; empty for a volume with no occupied brick).
std::vector<std::vector<D3>> occupied_corners_per_volume(const packing::PackedScene& packed, double& voxel_size);

// A grid aligned with a light: axes[2] points towards the (first) light, axes[0] × axes[1] =
// axes[2] (Ament Eq. 9). Cell (i, j, k) covers origin + [i, i+1]·h·axes[0] + … ; the grid is
// centred on the scene's bounds, which it contains.
struct SatFrame {
    std::array<D3, 3> axes;
    D3 origin;
    std::array<int, 3> dims{0, 0, 0};
    double cell_size = 0;   // h, world units
    // per axis, the cell's length in units of h: 1 except across the light of a frame whose filter
    // allows coarser cells (sat_cell_coarsening)
    std::array<double, 3> cell_scale{1, 1, 1};
    double voxel_size = 0;  // smallest world voxel of the scene: the unit of the filter width
    cl_uint volume_mask = ~cl_uint(0);  // the volumes whose σ the table holds (bit i: volume i)
    int next = -1;  // the next table on the same lattice for the same lights (a group of volumes each), or −1
    std::size_t entries() const { return std::size_t(dims[0] + 1) * std::size_t(dims[1] + 1) * std::size_t(dims[2] + 1); }
    D3 cell_centre(int i, int j, int k) const;  // world position
    double cell(std::size_t axis) const { return cell_size * cell_scale[axis]; }  // along grid axis `axis`, world units
};

// Cells across the light no finer than the filter can use (issue 30 item 1): with a low-pass patch
// of W voxels that must span at least N table cells (SatOptions::cells_across_patch, default 8;
// 0: no limit), cells across the light coarsen by W / N when W > N — never along the light, whose
// depth is not filtered. The lookup's cell averaging and linear blend widen the box filter's
// standard deviation by at most √(1 + 3/N²) − 1 (variance W²/12 + c²/4 for cells c ≤ W/N): 2.3 %
// at N = 8 (at the default W = 3 on cells of one voxel it is 15 %).
inline double sat_cell_coarsening(double filter_voxels, double cells_across_patch) {
    return cells_across_patch > 0 ? std::max(1.0, filter_voxels / cells_across_patch) : 1.0;
}

// The frame for a light shining towards `towards_light` (unit vector from the scene to the light)
// over the volumes of `packed`, with cells of the smallest voxel size, coarsened until the table
// has at most `max_entries` entries.
SatFrame make_csat_frame(const packing::PackedScene& packed, const D3& towards_light, std::size_t max_entries);
// The CSAT frame a group of orthodirectional lights shares (Ament §4.2.2): the axes of
// make_csat_frame made canonical (each axis signed so that its largest component is positive, the
// axes ordered by that component), so that every light of the group founds the same frame — bit
// for bit when the axes are the world axes. The light lies along any of its axes.
SatFrame make_shared_csat_frame(const packing::PackedScene& packed, const D3& towards_light, std::size_t max_entries);
// The canonical axes of make_shared_csat_frame.
std::array<D3, 3> shared_csat_axes(const D3& towards_light);
// The CSATs of one frame with `axes` (Ament §4.2.1), one per group of volumes whose occupied boxes
// overlap (volume_mask; their optical depths add up at lookup), each over its group's cells of one
// lattice centred on all the groups' bounds (`next` left −1: the caller chains them where it puts them),
// cells of the smallest voxel coarsened in 5 % steps until they hold at most `max_entries`
// together. One group: make_sat_frame's frame over the occupied corners.
// cell_scale: SatFrame::cell_scale of every table.
std::vector<SatFrame> plan_csat_tables(const packing::PackedScene& packed, const std::array<D3, 3>& axes, std::size_t max_entries,
                                       const std::array<double, 3>& cell_scale = {1, 1, 1});
// A frame aligned with the first volume's axes around every volume's occupied bricks (the
// volume-aligned SAT of the baselines, Schlegel et al. 2011), and one for any orthonormal axes
// around `corners` (the points the frame must contain: scene_corners or occupied_corners).
// Cells start at `coarsen` voxels (≥ 1: SAT ambient occlusion's cube of W voxels, sat_cell_coarsening).
SatFrame make_volume_sat_frame(const packing::PackedScene& packed, std::size_t max_entries, double coarsen = 1);
SatFrame make_sat_frame(const std::vector<D3>& corners, double voxel_size, const std::array<D3, 3>& axes, std::size_t max_entries,
                        double coarsen = 1);

// A point (or spot) light's spherical grids (SSAT, Ament §4.2.3), one per group of volumes whose
// occupied boxes overlap (volume_mask; their optical depths add up at lookup): φ, θ around a frame
// whose x axis points from the light to the group, r from the light. A light outside the group's
// bounds gets the angles the group subtends; a light inside them (or seeing it over more than 80°)
// the whole sphere, wrapping at φ = ±π. Cells of one voxel along r and of one voxel at the group's
// distance across, all coarsened by one factor until the tables have at most `max_entries` entries
// together; across, coarsened to `coarsen_across` voxels (sat_cell_coarsening) at the table's
// farthest radius, where a patch is narrowest. half_width and next are left 0.
std::vector<SsatGridGpu> plan_ssat_tables(const packing::PackedScene& packed, const D3& light_position, std::size_t max_entries,
                                          double coarsen_across = 1);
inline std::size_t ssat_entries(const SsatGridGpu& g) {
    return std::size_t(g.dims.s[0] + 1) * std::size_t(g.dims.s[1] + 1) * std::size_t(g.dims.s[2] + 1);
}

// Fixed-point cell value, as the kernels round it (shared/types.h).
std::uint64_t sat_fixed_point(double tau);

struct DeviceSat {
    std::vector<SatFrame> frames;      // one per CSAT; a light's tables are chained by SatFrame::next
    std::vector<int> light_frame;      // per light: its first table in `frames`, or −1
    std::vector<SatGridGpu> grids;     // light m's view of its first CSAT at m (dims.w = 0: none), of its others chained by `next`
    std::vector<int> grid_frame;       // per entry of `grids`: its table in `frames`, or −1
    std::vector<SsatGridGpu> spheres;  // light m's first at m (dims.w = 0: the light has no SSAT), its others chained by `next`
    std::vector<std::size_t> offsets;  // first entry of each CSAT in `data`
    double voxel_size = 0;             // the unit of the filter width
    int lanes = 0;                     // the resamples' packet width as requested (host::generation_lanes; 0: the device's)
    cl::Buffer data;                   // every table, cl_ulong entries
    std::size_t bytes = 0;
    std::map<std::string, double> stage_ms;
    std::vector<double> table_build_ms;  // per table: its kernels' time when this call built it, else 0
    std::vector<std::string> extinction;  // per volume: the extinction key the tables were built for (sat_update.h extinction_keys)
};

// The tables of a DeviceSat, numbered: first its CSAT frames, then the SSAT of each point or spot
// light in light order. A plan (below) has every table at offset 0 and no data; place each table
// (place_sat_table), allocate `data`, then build each table into it (build_sat_table).
std::size_t sat_table_count(const DeviceSat& sat);
// The tables light `light`'s lookups read: its CSAT frame, or its SSATs (none for a light without).
std::vector<std::size_t> light_sat_tables(const DeviceSat& sat, std::size_t light);
// The grid axes the lights of CSAT frame `frame` shine along (bit a: axis a); 0 for a table no
// light is aligned with (the volume-aligned SAT of the baselines). Its cells integrate σ along
// those axes (cl/sat_build.cl sat_resample).
cl_uint sat_frame_light_axes(const DeviceSat& sat, std::size_t frame);
std::size_t sat_table_entries(const DeviceSat& sat, std::size_t table);
// A table's cells per grid axis, and the volumes its cells hold (bit i: volume i of `volume_count`).
std::array<int, 3> sat_table_cells(const DeviceSat& sat, std::size_t table);
// A table's cell along each of its axes in units of the finest voxel (DeviceSat::voxel_size): a
// CSAT's or volume-aligned SAT's cell lengths; an SSAT's φ and θ extents at its farthest radius
// (φ on the equator) and its radial length.
std::array<double, 3> sat_table_cell_voxels(const DeviceSat& sat, std::size_t table);
cl_uint sat_table_volumes(const DeviceSat& sat, std::size_t table, std::size_t volume_count);
std::size_t sat_table_offset(const DeviceSat& sat, std::size_t table);
void place_sat_table(DeviceSat& sat, std::size_t table, std::size_t offset);
// Everything but the voxels that a table's cells depend on: its kind, frame or spherical grid
// (bit-exact), and its size. Two tables with equal keys built from equal volumes are equal.
std::string sat_table_geometry_key(const DeviceSat& sat, std::size_t table);
// Resamples and sums one table into sat.data at its offset (its entries are cleared first);
// adds the kernels' times to sat.stage_ms and sets sat.table_build_ms[table].
void build_sat_table(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
                     const packing::DeviceScene& device_scene, DeviceSat& sat, std::size_t table);

// The plan of Ament Alg. 1's tables for the lights: one CSAT per group of directional lights whose
// directions are ± the axes of one frame (orthodirectional lights, §4.2.2; the group's first
// light founds the shared frame; one table per group of overlapping volumes, plan_csat_tables), per
// point or spot light one SSAT per group of overlapping volumes (§4.2.3, plan_ssat_tables). Both are fitted to the occupied bricks (occupied_corners), as is the baselines' volume-aligned SAT
// (plan_volume_sat; a cone from outside it skips the cubes before it: cl/lowpass.h sat_cone_depth).
// coarsen_across: how much coarser than a voxel the cells across the light may be
// (sat_cell_coarsening; a CSAT frame with lights along two or three of its axes stays isotropic).
DeviceSat plan_light_sats(const packing::PackedScene& packed, std::size_t max_entries, double coarsen_across = 1);
// The plan of the baselines' one volume-aligned SAT (see build_volume_sat).
// coarsen: its cells' size in voxels at least (ambient occlusion's cube of W voxels; cone shadows: 1).
DeviceSat plan_volume_sat(const packing::PackedScene& packed, std::size_t max_entries, double coarsen = 1);

// A plan placed contiguously and built into a fresh buffer (plan_light_sats); lanes: the
// resamples' packet width (DeviceSat::lanes).
DeviceSat build_light_sats(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
                           const packing::DeviceScene& device_scene, std::size_t max_entries, int lanes = 0,
                           double coarsen_across = 1);

// The baselines' one volume-aligned SAT (SAT ambient occlusion and cone shadows, Schlegel et al.
// 2011): frames[0], described by grids[0] for every light.
DeviceSat build_volume_sat(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
                           const packing::DeviceScene& device_scene, std::size_t max_entries, int lanes = 0);

// The per-light grids with the box width for a filter of `filter_voxels` voxels, on the device
// (the tables do not depend on it: changing the filter rebuilds nothing).
struct SatGridBuffers {
    cl::Buffer cartesian, spherical;
};
// `cone_deg`: the cone shadows' half angle.
SatGridBuffers upload_sat_grids(host::Runtime& runtime, const DeviceSat& sat, float filter_voxels, float cone_deg = 0.f);

// `entries` entries from `offset` of the tables, read back to the host (tests, bench).
std::vector<std::uint64_t> read_sat(host::Runtime& runtime, const DeviceSat& sat, std::size_t offset, std::size_t entries);

}  // namespace sombra::shadows
