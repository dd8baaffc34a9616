// The technique modules and the host/kernel argument contract (src/techniques/, src/host/kernel_args.h).
#include <algorithm>
#include <cctype>
#include <iterator>
#include <variant>

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
    REQUIRE_THROWS_WITH(sombra::check_render_options(o), Contains("dsm_storage: unknown value 'atlass'") && Contains("chunked-ondemand"));
    o.dsm.storage = "atlas";
    o.shadows = sombra::ShadowTechnique(42);
    REQUIRE_THROWS_WITH(sombra::check_render_options(o), Contains("shadows: unknown value '42' (none, rays"));
    o.shadows = sombra::ShadowTechnique::Dsm;
    REQUIRE_NOTHROW(sombra::check_render_options(o));
    o.sat.filter_kernel = "";
    REQUIRE_THROWS_WITH(sombra::render(sombra::test::context(), sombra::test::sphere_scene(8), o), Contains("lowpass_filter_kernel"));
}

namespace {
// Another valid value of an option (its declaration's kind and range), near the current one.
sombra::OptionValue other_value(const sombra::OptionSpec& spec, const sombra::OptionValue& current) {
    using sombra::OptionKind;
    if (spec.kind == OptionKind::Flag) return !std::get<bool>(current);
    if (spec.kind == OptionKind::Choice) {
        for (auto it = spec.choices.rbegin(); it != spec.choices.rend(); ++it)
            if (*it != std::get<std::string>(current)) return *it;
    }
    if (spec.kind == OptionKind::Integer) {
        if (!spec.choices.empty()) return std::stoll(spec.choices[1]);  // lanes: 1 (auto is 8 or 16 here)
        return std::get<long long>(current) + 1;
    }
    const double v = std::get<double>(current), doubled = 2 * v;
    if (v != 0 && doubled < spec.max) return doubled;
    return spec.min + (spec.max - spec.min) / 4;
}
}  // namespace

TEST_CASE("every option that keys prepared data rebuilds it when changed, and no other option does", "[modules][options]") {
    sombra::Scene scene = sombra::test::sphere_scene(12);
    sombra::Context& context = sombra::test::context();
    int checked = 0;
    for (const sombra::OptionSpec& spec : sombra::render_option_specs()) {
        if (spec.key == "shadows") continue;  // selects the module itself (dsm and shadowmap share their maps)
        sombra::RenderOptions base;
        base.shadows = spec.techniques.empty() ? sombra::ShadowTechnique::Dsm : spec.techniques.front();
        base.width = base.height = 8;
        base.dsm.resolution = 16;
        sombra::RenderOptions changed = base;
        sombra::OptionValue value = other_value(spec, spec.get(base));
        // auto volume storage is image on a GPU, buffer on a CPU: the other value must be the other storage
        if (spec.key == "volume_storage" && context.runtime().info().is_gpu) value = std::string("buffer");
        // auto lanes is 1 on a GPU (8 or 16 on a CPU): the other value must be a packet
        if (spec.key == "lanes" && context.runtime().info().is_gpu) value = 4LL;
        sombra::set_option(changed, spec, value, spec.key);
        INFO(spec.key << ": " << sombra::option_value_text(spec.get(base)) << " → " << sombra::option_value_text(value) << " under "
                      << sombra::shadow_technique_name(base.shadows));
        REQUIRE(sombra::option_value_text(spec.get(changed)) != sombra::option_value_text(spec.get(base)));
        sombra::render(context, scene, base);
        const sombra::RenderStats stats = sombra::render(context, scene, changed).stats;
        CHECK(stats.reused_preparation == !spec.keys_data);
        ++checked;
    }
    CHECK(checked + 1 == int(sombra::render_option_specs().size()));
}

TEST_CASE("render options: the scene file's \"render\" block, checked like the flags and named by its key", "[modules][options]") {
    sombra::Scene scene = sombra::test::sphere_scene(8);
    scene.source = "block.json";
    scene.render_settings = {{"shadows", "\"lowpass\""}, {"lowpass_filter_width", "5"}, {"dsm_precompression", "true"}};
    const sombra::RenderOptions o = sombra::scene_render_options(scene);
    CHECK(o.shadows == sombra::ShadowTechnique::Lowpass);
    CHECK(o.sat.filter_width == 5.f);
    CHECK(o.dsm.precompression);
    const std::vector<std::pair<std::string, std::string>> refused[] = {
        {{"dsm_resolution", "0"}}, {{"dsm_resolution", "1.5"}}, {{"dsm_epsilon", "\"small\""}}, {{"shadows", "[1]"}},
        {{"dsm_precompression", "1"}}, {{"shadow", "\"dsm\""}}, {{"--dsm-res", "16"}}};
    const char* messages[] = {"block.json: render.dsm_resolution: must lie in [1, 8192], got 0",
                              "block.json: render.dsm_resolution: expected an integer, got 1.5",
                              "block.json: render.dsm_epsilon: expected a number, got 'small'",
                              "block.json: render.shadows: expected a name, got array",
                              "block.json: render.dsm_precompression: expected true or false, got 1",
                              "block.json: render: unknown key 'shadow' (did you mean 'shadows'?)",
                              "block.json: render: unknown key '--dsm-res'"};
    for (std::size_t i = 0; i < std::size(refused); ++i) {
        scene.render_settings = refused[i];
        CHECK(sombra::test::error_of([&] { sombra::scene_render_options(scene); }) == messages[i]);
    }
}
