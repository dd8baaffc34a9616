// The technique modules and the host/kernel argument contract (src/techniques/, src/host/kernel_args.h).
#include <algorithm>
#include <cctype>

#include "host/kernel_args.h"
#include "host/runtime.h"
#include "sombra/error.h"
#include "test_support.h"
#include "techniques/technique.h"

using Catch::Contains;

namespace {

std::string upper(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::toupper(c)); });
    return s;
}

}  // namespace

TEST_CASE("kernel arguments: binding a name the kernel does not declare at that position throws, naming both", "[modules]") {
    sombra::Context& context = sombra::test::context();
    cl::Kernel scan(context.runtime().program("sat_build.cl", {"SOMBRA_LANES=1", "SOMBRA_VOLUME_SLOTS=1"}), "sat_scan");
    cl::Buffer data = sombra::host::make_buffer(context.runtime(), CL_MEM_READ_WRITE, 64, nullptr, "test");
    sombra::host::KernelArgs args(scan);
    args("sat", data);
    REQUIRE_THROWS_WITH(args("n", cl_int4{}), Contains("sat_scan") && Contains("argument 1 is 'data_offset'") &&
                                                  Contains("binds 'n'"));
    args("data_offset", cl_uint(0));
    REQUIRE_THROWS_WITH(args.done(), Contains("binds 2 arguments, the kernel declares 4") && Contains("next: 'n'"));
    args("n", cl_int4{})("axis", cl_uint(0));
    REQUIRE_NOTHROW(args.done());
    REQUIRE_THROWS_WITH(args("extra", cl_uint(0)), Contains("declares 4 arguments"));
}

TEST_CASE("technique registry: names round-trip, a near miss gets a suggestion, every module has its kernel header", "[modules]") {
    std::vector<std::string> names = sombra::shadow_technique_names();
    REQUIRE(names.size() == sombra::techniques::registry().size());
    std::string selector = sombra::host::expand_kernel_source("techniques/technique.h");
    for (const std::string& name : names) {
        sombra::ShadowTechnique t = sombra::parse_shadow_technique(name);
        CHECK(sombra::shadow_technique_name(t) == name);
        CHECK(std::string(sombra::shadow_technique_summary(t)).size() > 10);
        if (name != "none") CHECK_THAT(selector, Contains("defined(SOMBRA_TECHNIQUE_" + upper(name) + ")"));
        // the module's own define selects its header
        sombra::Scene scene = sombra::test::sphere_scene(12);
        std::vector<std::string> defines;
        sombra::RenderOptions o;
        o.shadows = t;
        sombra::techniques::make_module(scene, t)->add_defines(scene, o, defines);
        if (name != "none") CHECK(std::count(defines.begin(), defines.end(), "SOMBRA_TECHNIQUE_" + upper(name)) == 1);
    }
    REQUIRE_THROWS_WITH(sombra::parse_shadow_technique("dms"), Contains("did you mean dsm?"));
    REQUIRE_THROWS_WITH(sombra::parse_shadow_technique("xyzzy"), Contains("expected one of: none rays dsm"));
}

TEST_CASE("every registered technique renders and answers shadow queries with its arguments checked by name", "[modules]") {
    sombra::Context& context = sombra::test::context();
    for (bool with_mesh : {false, true}) {
        sombra::Scene scene = sombra::test::overlapping_scene();  // directional, point and spot lights
        if (with_mesh) scene.meshes.push_back(sombra::test::quad(0.4f, 0.1f, 0.5f));
        for (const std::string& name : sombra::shadow_technique_names()) {
            CAPTURE(name, with_mesh);
            sombra::RenderOptions o;
            o.shadows = sombra::parse_shadow_technique(name);
            o.width = o.height = 16;
            o.dsm.resolution = 32;
            sombra::RenderResult r = sombra::render(context, scene, o);  // KernelArgs::done() throws on any mismatch
            CHECK(r.stats.samples > 0);
            if (name == "none") continue;
            sombra::ShadowQuery q = sombra::shadow_transmittance(context, scene, 0, {{0.f, 0.f, 0.f}, {0.3f, -0.2f, 0.1f}}, o);
            REQUIRE(q.transmittance.size() == 2);
            for (double t : q.transmittance) CHECK((t >= 0.0 && t <= 1.0));
        }
    }
}

TEST_CASE("options with a fixed set of values: one list each, checked before any work", "[modules]") {
    CHECK(sombra::render_option_values("dsm_storage") == sombra::dsm_storage_names());
    CHECK(sombra::render_option_values("shadows") == sombra::shadow_technique_names());
    sombra::RenderOptions o;
    sombra::set_render_option(o, "dsm_prefilter", "tent");
    CHECK(o.dsm.prefilter == "tent");
    CHECK(sombra::render_option_value(o, "dsm_prefilter") == "tent");
    REQUIRE_THROWS_WITH(sombra::set_render_option(o, "lowpass_filter_kernel", "tent"), Contains("unknown value 'tent'"));
    o.dsm.storage = "atlass";
    REQUIRE_THROWS_WITH(sombra::check_render_options(o), Contains("--storage: unknown value 'atlass'") && Contains("chunked-ondemand"));
    o.dsm.storage = "atlas";
    o.shadows = sombra::ShadowTechnique(42);
    REQUIRE_THROWS_WITH(sombra::check_render_options(o), Contains("--shadows: unknown value 42"));
    o.shadows = sombra::ShadowTechnique::Dsm;
    REQUIRE_NOTHROW(sombra::check_render_options(o));
    o.sat.filter_kernel = "";
    REQUIRE_THROWS_WITH(sombra::render(sombra::test::context(), sombra::test::sphere_scene(8), o), Contains("--filter-kernel"));
}
