// sombra — the raster stage of the data flow (docs/architecture.md "Data flow"; Knecht §3.1.1, §4.1.1): meshes projected
// into a camera or light view, clipped, snapped to fixed point, then rasterized into 8×8 tiles by
// cl/raster.cl (coverage masks + triangle ids in chunks of 64 per tile). Standalone: the camera
// pass and DSM generation do not use it yet.
#pragma once
#include <array>
#include <cstddef>
#include <vector>

#include "host/runtime.h"
#include "shared/types.h"
#include "sombra/scene.h"

namespace sombra::raster {

// A pinhole or orthographic view. Pixel (i, j) looks through the image-plane point
// ndc = ((i + ½) / width · 2 − 1, (j + ½) / height · 2 − 1) along axis_x, axis_y; axis_z looks into
// the scene. Depth of a fragment: the distance from origin along the pixel's ray (perspective) or
// view z from the plane through origin (orthographic) — the DsmViewGpu convention.
struct View {
    std::array<double, 3> origin{0, 0, 0}, axis_x{1, 0, 0}, axis_y{0, 1, 0}, axis_z{0, 0, 1};
    bool perspective = true;
    double extent_x = 1, extent_y = 1;  // perspective: tan(half field of view); orthographic: half width, height
    double near_depth = 1e-3;           // view z below which geometry is clipped away
    int width = 512, height = 512;
    double pixel_shift = 0;             // pixels sample at (i + ½ + shift, j + ½ + shift) (DsmViewGpu.ray_shift)
};

// The scene camera's view at width × height (screen y down, as in the camera pass).
View camera_view(const Camera& camera, int width, int height, double near_depth = 1e-3);
// A deep shadow map view (texel (x, y) ↔ pixel (x, y)); its near_depth clamped to ≥ 1e-6.
View dsm_view(const DsmViewGpu& view);

struct Projection {
    std::vector<ScreenTriangleGpu> triangles;
    std::size_t source_triangles = 0;  // in the meshes
    std::size_t culled = 0;            // wholly behind the near plane or beyond the guard band
    std::size_t clipped = 0;           // crossing the near plane or the guard band: replaced by their pieces
    std::size_t non_finite = 0;        // with a non-finite corner after the transform: dropped
};

// Transforms every mesh instance's triangles to the view, clips them against the near plane and a
// guard band (twice the screen's half size around it; the fixed-point range stays exact), snaps
// the corners to 1/2^SOMBRA_SUBPIXEL_BITS pixel and sets each triangle's depth plane and facing.
// Triangles wholly inside are passed on unchanged (shared corners snap alike: watertight).
Projection project_meshes(const std::vector<MeshInstance>& meshes, const View& view);

RasterScreenGpu make_screen(const View& view);

struct Stats {
    std::size_t triangles = 0;     // screen triangles rasterized
    std::size_t entries = 0;       // (mask, triangle) pairs in all tiles
    std::size_t chunks = 0;        // chunks of SOMBRA_TILE_CHUNK entries allocated
    std::size_t wasted_slots = 0;  // unused entries of allocated chunks (Knecht Table 5.11)
    std::size_t max_tile_entries = 0;
    std::size_t overflow = 0;      // entries that found no slot: always 0 (checked)
    double count_ms = 0, write_ms = 0;  // kernel times (profiling events)
};

// Tile lists on the device: tile t = ty·tiles_x + tx holds count[t] entries at
// [first_chunk[t]·SOMBRA_TILE_CHUNK, +count[t]) of masks (bit 8y + x: pixel (8tx + x, 8ty + y)) and
// ids (index into the rasterized triangle list). Order inside a tile is not defined.
struct DeviceTiles {
    RasterScreenGpu screen{};
    cl::Buffer screen_buffer, triangles, count, first_chunk, masks, ids;
    Stats stats;
};

DeviceTiles rasterize(host::Runtime& runtime, const std::vector<ScreenTriangleGpu>& triangles, const RasterScreenGpu& screen);

struct HostTiles {
    RasterScreenGpu screen{};
    std::vector<cl_uint> count, first_chunk, ids;
    std::vector<cl_ulong> masks;
    Stats stats;
};
HostTiles read_back(host::Runtime& runtime, const DeviceTiles& tiles);

}  // namespace sombra::raster
