#include "host/tiled_launch.h"

#include <algorithm>
#include <cmath>

namespace sombra::host {

std::size_t next_band(std::size_t rows, std::size_t first, std::size_t quantum, double ms, int tiles) {
    std::size_t left = rows - std::min(first, rows), band = 0;
    if (tiles > 0) band = (rows + std::size_t(tiles) - 1) / std::size_t(tiles);
    else if (first == 0) band = (rows + 63) / 64;
    else {
        double rows_per_ms = double(first) / std::max(ms, 1e-3);
        bool short_rest = 4 * first >= rows && double(left) / rows_per_ms < kShortMs;
        band = short_rest ? left : std::min(std::size_t(rows_per_ms * kBandMs), (rows + 15) / 16);
    }
    band = std::max<std::size_t>((band + quantum - 1) / quantum * quantum, quantum);
    return std::min(band, left);
}

double run_tiled(Runtime& runtime, cl::Kernel& kernel, const cl::NDRange& global, const cl::NDRange& local, double units) {
    const std::size_t axis = global.dimensions() - 1, rows = global.get()[axis];
    const std::size_t quantum = local.dimensions() > 0 ? local.get()[axis] : 1;
    double ms = 0;
    for (std::size_t first = 0; first < rows;) {
        std::size_t band = next_band(rows, first, quantum, ms, runtime.launch_tiles());
        cl::NDRange offset = axis == 0 ? cl::NDRange(first) : cl::NDRange(0, first);
        cl::NDRange size = axis == 0 ? cl::NDRange(band) : cl::NDRange(global.get()[0], band);
        cl::Event event;
        runtime.queue().enqueueNDRangeKernel(kernel, offset, size, local, nullptr, &event);
        event.wait();
        ms += Runtime::event_ms(event);
        first += band;
        runtime.progress().advance(units * double(band) / double(rows));
    }
    return ms;
}

}  // namespace sombra::host
