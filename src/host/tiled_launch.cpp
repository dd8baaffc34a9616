#include "host/tiled_launch.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <utility>

namespace sombra::host {

std::size_t next_band(std::size_t rows, std::size_t left, std::size_t measured, double ms, std::size_t quantum, int tiles) {
    std::size_t band = 0;
    if (tiles > 0) band = (rows + std::size_t(tiles) - 1) / std::size_t(tiles);
    else if (measured == 0) band = (rows + 63) / 64;
    else {
        double rows_per_ms = double(measured) / std::max(ms, 1e-3);
        bool short_rest = 4 * measured >= rows && double(left) / rows_per_ms < kShortMs;
        band = short_rest ? left : std::min(std::size_t(rows_per_ms * kBandMs), (rows + 15) / 16);
    }
    band = std::max<std::size_t>((band + quantum - 1) / quantum * quantum, quantum);
    return std::min(band, left);
}

double run_tiled(Runtime& runtime, cl::Kernel& kernel, const cl::NDRange& global, const cl::NDRange& local, double units,
                 std::size_t first) {
    const std::size_t axis = global.dimensions() - 1, rows = global.get()[axis];
    // without a group size PoCL picks a divisor of the band's size: bands of any size made small
    // groups and slowed the shadow cache down (bench/README.md, sombra_bench_tiles)
    const std::size_t quantum = local.dimensions() > 0 ? local.get()[axis] : axis == 0 ? 4096 : 16;
    std::deque<std::pair<cl::Event, std::size_t>> in_flight;  // (event, rows) of the bands enqueued
    std::size_t enqueued = 0, measured = 0;
    double ms = 0;
    Progress& progress = runtime.progress();
    int tiles = runtime.launch_tiles();
    if (tiles == 0 && progress.last_launch_ms >= 0 && progress.last_launch_ms < kShortMs / 2) tiles = 1;
    while (enqueued < rows || !in_flight.empty()) {
        // two bands queued: the device starts the next without waiting for the host
        while (in_flight.size() < 2 && enqueued < rows) {
            std::size_t band = next_band(rows, rows - enqueued, measured, ms, quantum, tiles);
            cl::NDRange offset = axis == 0 ? cl::NDRange(first + enqueued) : cl::NDRange(0, first + enqueued);
            cl::NDRange size = axis == 0 ? cl::NDRange(band) : cl::NDRange(global.get()[0], band);
            cl::Event event;
            runtime.queue().enqueueNDRangeKernel(kernel, offset, size, local, nullptr, &event);
            runtime.queue().flush();
            in_flight.emplace_back(event, band);
            enqueued += band;
        }
        auto [event, band] = in_flight.front();
        in_flight.pop_front();
        event.wait();
        ms += Runtime::event_ms(event);
        measured += band;
        progress.advance(units * double(band) / double(rows));
    }
    progress.last_launch_ms = ms;
    return ms;
}

}  // namespace sombra::host
