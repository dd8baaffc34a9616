// sombra — long kernels as several launches over bands of their last NDRange dimension (rows of
// pixels or texels, points), so that a progress stage advances while they run. The kernels read
// get_global_id only, which includes the band's global offset: every work-item computes what it
// computes in one launch, and the output does not change.
#pragma once
#include <CL/opencl.hpp>

#include <cstddef>

#include "host/runtime.h"

namespace sombra::host {

// Rows of the next band, `left` rows of `rows` still to enqueue, a multiple of `quantum` (the
// work-group's side, or a multiple of a good one) except at the end. tiles > 0: `tiles` equal bands. tiles = 0: bands of 1/64
// of the rows until one finished, then bands of about kBandMs at the rate measured so far (`ms`
// for the `measured` rows), at most 1/16 of the rows each (rows differ in cost: an empty sky is
// quick); once a quarter of the rows ran, the rest in one launch when it looks shorter than kShortMs.
constexpr double kBandMs = 200, kShortMs = 1000;
std::size_t next_band(std::size_t rows, std::size_t left, std::size_t measured, double ms, std::size_t quantum, int tiles);

// Runs `kernel` over `global` (1D or 2D) with `local` (or cl::NullRange) band by band, two bands
// queued at a time, advancing the runtime's progress stage by each band's share of `units` as it
// finishes. Bands as runtime.launch_tiles() asks; when it is 0 and the stage's last launch took
// under kShortMs / 2 (a DSM view after a quick one), one band: the stage advances per launch
// then, and every band costs a wake-up of the device's threads. first > 0: the rows start there
// (a global offset along the last dimension). Returns the profiled kernel time in ms.
double run_tiled(Runtime& runtime, cl::Kernel& kernel, const cl::NDRange& global, const cl::NDRange& local,
                 double units = 1, std::size_t first = 0);

}  // namespace sombra::host
