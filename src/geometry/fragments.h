// sombra — the fragment stage after the raster stage (docs/architecture.md "Data flow"; Knecht §3.1.2): per
// pixel, the triangles crossing its ray sorted by depth — the boundaries of its homogeneous
// segments. Runs cl/segments.cl on the tile lists of geometry/rasterizer.h. Standalone for now.
#pragma once
#include <vector>

#include "geometry/rasterizer.h"

namespace sombra::raster {

struct FragmentStats {
    std::size_t fragments = 0, max_per_pixel = 0;
    double count_ms = 0, write_ms = 0;
};

// Pixel p = y·width + x owns fragments [first[p], first[p + 1]) of `fragments`, sorted by
// (depth, triangle); depths follow the DsmViewGpu convention (raster::View).
struct DeviceFragments {
    cl::Buffer first, fragments;
    FragmentStats stats;
};

DeviceFragments sort_fragments(host::Runtime& runtime, const DeviceTiles& tiles);

struct HostFragments {
    std::vector<cl_uint> first;  // width·height + 1
    std::vector<FragmentGpu> fragments;
    FragmentStats stats;
};
HostFragments read_back(host::Runtime& runtime, const DeviceFragments& fragments, const RasterScreenGpu& screen);

}  // namespace sombra::raster
