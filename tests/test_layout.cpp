// Host/kernel struct layout: the kernel reports sizeof/offsetof of every shared struct.
#include <catch2/catch.hpp>

#include <cstddef>
#include <vector>

#include "host/runtime.h"
#include "shared/types.h"
#include "test_support.h"

TEST_CASE("shared structs have the same layout on the host and in kernels", "[layout]") {
    auto& rt = sombra::test::context().runtime();
    cl::Kernel kernel(rt.program("tests/layout_probe.cl", {}), "layout_probe");
    std::vector<cl_uint> device(256, 0);
    cl::Buffer out(rt.context(), CL_MEM_WRITE_ONLY, device.size() * sizeof(cl_uint));
    kernel.setArg(0, out);
    rt.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(1));
    rt.queue().enqueueReadBuffer(out, CL_TRUE, 0, device.size() * sizeof(cl_uint), device.data());
    std::vector<cl_uint> host = {
#define SOMBRA_LAYOUT_ENTRY(type, member) cl_uint(offsetof(type, member)),
#define SOMBRA_LAYOUT_SIZE(type) cl_uint(sizeof(type)),
#include "tests/layout_fields.h"
    };
    REQUIRE(host.size() < device.size());
    for (std::size_t i = 0; i < host.size(); ++i) {
        INFO("layout entry " << i);
        CHECK(device[i] == host[i]);
    }
}
