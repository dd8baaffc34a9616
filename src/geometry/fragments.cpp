#include "geometry/fragments.h"
#include "host/kernel_args.h"

#include <algorithm>

#include "sombra/error.h"

namespace sombra::raster {

DeviceFragments sort_fragments(host::Runtime& rt, const DeviceTiles& tiles) {
    DeviceFragments d;
    const RasterScreenGpu& s = tiles.screen;
    const std::size_t pixels = std::size_t(s.width) * s.height;
    auto& q = rt.queue();
    cl::Program& program = rt.program("segments.cl", {});
    const cl::NDRange grid(s.width, s.height);
    std::vector<cl_uint> first(pixels + 1, 0);
    cl::Buffer counts = host::make_buffer(rt, CL_MEM_READ_WRITE, pixels * sizeof(cl_uint), nullptr, "fragment counts");
    {  // pass 1: fragments per pixel
        cl::Kernel k(program, "segments_count");
        host::KernelArgs{k}("s", tiles.screen_buffer)("count", tiles.count)("first_chunk", tiles.first_chunk)("masks", tiles.masks)(
            "pixel_count", counts).done();
        cl::Event e;
        q.enqueueNDRangeKernel(k, cl::NullRange, grid, cl::NullRange, nullptr, &e);
        q.enqueueReadBuffer(counts, CL_TRUE, 0, pixels * sizeof(cl_uint), first.data() + 1);
        d.stats.count_ms = host::Runtime::event_ms(e);
    }
    for (std::size_t p = 0; p < pixels; ++p) {  // exclusive prefix sum
        d.stats.max_per_pixel = std::max<std::size_t>(d.stats.max_per_pixel, first[p + 1]);
        if (first[p] + std::size_t(first[p + 1]) > 0xFFFFFFFFull) throw Error("fragments: more than 2^32 fragments");
        first[p + 1] += first[p];
    }
    d.stats.fragments = first[pixels];
    d.first = host::make_buffer(rt, CL_MEM_READ_ONLY, first.size() * sizeof(cl_uint), first.data(), "fragment offsets");
    d.fragments = host::make_buffer(rt, CL_MEM_READ_WRITE, d.stats.fragments * sizeof(FragmentGpu), nullptr, "fragments");
    if (d.stats.fragments > 0) {  // pass 2: gather and sort
        cl::Kernel k(program, "segments_write");
        host::KernelArgs{k}("s", tiles.screen_buffer)("tris", tiles.triangles)("count", tiles.count)("first_chunk", tiles.first_chunk)(
            "masks", tiles.masks)("ids", tiles.ids)("pixel_first", d.first)("fragments", d.fragments).done();
        cl::Event e;
        q.enqueueNDRangeKernel(k, cl::NullRange, grid, cl::NullRange, nullptr, &e);
        e.wait();
        d.stats.write_ms = host::Runtime::event_ms(e);
    }
    return d;
}

HostFragments read_back(host::Runtime& rt, const DeviceFragments& d, const RasterScreenGpu& s) {
    HostFragments h;
    h.stats = d.stats;
    h.first.resize(std::size_t(s.width) * s.height + 1);
    h.fragments.resize(d.stats.fragments);
    rt.queue().enqueueReadBuffer(d.first, CL_TRUE, 0, h.first.size() * sizeof(cl_uint), h.first.data());
    if (!h.fragments.empty())
        rt.queue().enqueueReadBuffer(d.fragments, CL_TRUE, 0, h.fragments.size() * sizeof(FragmentGpu), h.fragments.data());
    return h;
}

}  // namespace sombra::raster
