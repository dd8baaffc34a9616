// Progress reports of the long stages (sombra/progress.h) and the bands long kernels run in
// (host/tiled_launch.h): reports are monotone and end at 1, the text reporter prints one line per
// stage, and a kernel run in bands writes the image it writes in one launch, bit for bit.
#include <catch2/catch.hpp>

#include <cstring>
#include <map>
#include <sstream>
#include <stdexcept>

#include "host/runtime.h"
#include "host/tiled_launch.h"
#include "test_support.h"

namespace sombra {
namespace {

// The shared context's bands for the scope of a test.
struct LaunchTiles {
    explicit LaunchTiles(int tiles) { test::context().runtime().set_launch_tiles(tiles); }
    ~LaunchTiles() { test::context().runtime().set_launch_tiles(0); }
};

// Every report of a call, by stage, in order.
std::map<std::string, std::vector<ProgressReport>> reports_of(const Scene& scene, RenderOptions options) {
    std::map<std::string, std::vector<ProgressReport>> reports;
    options.progress = [&](const ProgressReport& r) { reports[r.stage].push_back(r); };
    test::context().release_prepared_scenes();  // every stage runs
    render(test::context(), scene, options);
    return reports;
}

bool same_bits(const Image& a, const Image& b) {
    return a.rgba.size() == b.rgba.size() && std::memcmp(a.rgba.data(), b.rgba.data(), a.rgba.size() * sizeof(float)) == 0;
}

}  // namespace

TEST_CASE("progress: format_ms rounds and groups thousands", "[progress]") {
    CHECK(format_ms(0.4) == "0");
    CHECK(format_ms(999.5) == "1,000");
    CHECK(format_ms(16966.6) == "16,967");
    CHECK(format_ms(1234567) == "1,234,567");
}

TEST_CASE("progress: bands cover the rows once, in multiples of the group side", "[progress]") {
    for (int tiles : {0, 1, 3, 7, 1000})
        for (std::size_t rows : {1, 4, 33, 36, 512}) {
            std::size_t quantum = rows % 4 == 0 ? 4 : 1, first = 0, launches = 0;
            while (first < rows) {
                std::size_t band = host::next_band(rows, rows - first, first, double(first) * 0.01, quantum, tiles);
                REQUIRE(band > 0);
                CHECK((band % quantum == 0 || first + band == rows));
                first += band, ++launches;
            }
            CHECK(first == rows);
            if (tiles > 0) CHECK(launches <= std::size_t(tiles));
            if (tiles == 1) CHECK(launches == 1);
        }
    // time-sized bands: 200 ms at 1 row per ms, at most 1/16 of the rows
    CHECK(host::next_band(100000, 99000, 1000, 1000, 1, 0) == 200);
    CHECK(host::next_band(1600, 1500, 100, 1, 1, 0) == 100);
    CHECK(host::next_band(1600, 1200, 400, 1, 1, 0) == 1200);  // a quarter ran, the rest looks short
    CHECK(host::next_band(1600, 1600, 0, 0, 4, 0) == 28);      // 1/64, rounded up to the group side
}

TEST_CASE("progress: stages report monotone fractions from 0 to 1, nested and empty stages are silent", "[progress]") {
    host::Progress progress;
    std::vector<ProgressReport> reports;
    progress.callback = [&](const ProgressReport& r) { reports.push_back(r); };
    progress.advance(1);  // outside a stage: nothing
    progress.begin("outer", 2);
    progress.begin("inner", 5);  // silent: its work is the outer stage's
    progress.advance(1);
    progress.end(false);
    progress.extend(2);  // 3 units left after 1 of 2: the rest of the bar is shared out anew
    for (int i = 0; i < 3; ++i) progress.advance(1);
    progress.end(false);
    { host::ProgressStage empty(progress, "nothing to do", 0); }
    REQUIRE(reports.size() == 6);
    CHECK(reports.front().fraction == 0);
    CHECK(reports[1].fraction == Approx(0.5));
    CHECK(reports[2].fraction == Approx(0.5 + 0.5 / 3));
    for (std::size_t i = 1; i < reports.size(); ++i) CHECK(reports[i].fraction >= reports[i - 1].fraction);
    for (const ProgressReport& r : reports) CHECK(r.stage == "outer");
    CHECK(reports.back().done);
    CHECK(reports.back().fraction == 1);

    reports.clear();
    CHECK_THROWS_AS(([&] {
        host::ProgressStage stage(progress, "cut short", 4);
        progress.advance(1);
        throw std::runtime_error("stop");
    }()), std::runtime_error);
    REQUIRE(reports.size() == 3);
    CHECK(reports.back().done);
    CHECK(reports.back().failed);
    CHECK(reports.back().fraction == Approx(0.25));
}

TEST_CASE("progress: the text reporter draws a bar on a terminal, else one line per finished stage", "[progress]") {
    ProgressReport start{"shadow cache", 0, 0, false, false}, half{"shadow cache", 0.5, 900, false, false},
        done{"shadow cache", 1, 16966.6, true, false}, failed{"camera pass", 0.3, 10, true, true};
    std::ostringstream plain;
    ProgressCallback lines = text_progress(plain, false);
    for (const ProgressReport& r : {start, half, done, failed}) lines(r);
    CHECK(plain.str() == "sombra: shadow cache 16,967 ms\n");

    std::ostringstream terminal;
    ProgressCallback bar = text_progress(terminal, true);
    for (const ProgressReport& r : {start, half, done}) bar(r);
    CHECK_THAT(terminal.str(), Catch::StartsWith("\rsombra: shadow cache [") && Catch::Contains("] 0%") &&
                                   Catch::EndsWith("\r\033[Ksombra: shadow cache 16,967 ms\n"));
    terminal.str("");
    bar(ProgressReport{"camera pass", 0.5, 900, false, false});  // another stage: drawn at once
    CHECK_THAT(terminal.str(), Catch::Contains("] 50%  ETA 1 s"));
}

TEST_CASE("progress: every stage of a render reports from 0, never goes back, and ends at 1", "[progress]") {
    LaunchTiles tiles(5);
    Scene scene = test::overlapping_scene();
    RenderOptions options;
    options.width = 24, options.height = 20;
    options.dsm.resolution = 32;
    options.shadow_cache = ShadowCacheMode::On;  // the low-pass frame fills it (auto would measure and may not)
    for (ShadowTechnique t : {ShadowTechnique::Dsm, ShadowTechnique::Lowpass}) {
        options.shadows = t;
        auto reports = reports_of(scene, options);
        std::vector<std::string> expected = {"camera pass"};
        if (t == ShadowTechnique::Dsm) expected.push_back("deep shadow maps");
        else expected.insert(expected.end(), {"summed-area tables", "shadow cache"});
        for (const std::string& stage : expected) {
            INFO(stage);
            REQUIRE(reports.count(stage) == 1);
            const auto& r = reports[stage];
            CHECK(r.front().fraction == 0);
            CHECK_FALSE(r.front().done);
            bool between = false;  // progress within the stage, from the bands
            for (std::size_t i = 1; i < r.size(); ++i) {
                CHECK(r[i].fraction >= r[i - 1].fraction);
                CHECK(r[i].elapsed_ms >= r[i - 1].elapsed_ms);
                CHECK(r[i - 1].done == false);
                between = between || (r[i].fraction > 0 && r[i].fraction < 1);
            }
            CHECK(between);
            CHECK(r.back().done);
            CHECK_FALSE(r.back().failed);
            CHECK(r.back().fraction == 1);
        }
    }
}

TEST_CASE("progress: kernels run in bands write the image one launch writes, bit for bit, for every technique", "[progress]") {
    Scene scene = test::overlapping_scene();  // directional, point and spot lights
    RenderOptions options;
    options.width = 37, options.height = 29;  // bands end inside the padding of the 4×4 groups
    options.dsm.resolution = 30;
    const auto image_with = [&](int tiles) {
        LaunchTiles bands(tiles);
        test::context().release_prepared_scenes();  // maps, tables and shadow cache built again
        return render(test::context(), scene, options).image;
    };
    const std::pair<ShadowTechnique, const char*> cases[] = {
        {ShadowTechnique::None, "atlas"},      {ShadowTechnique::Rays, "atlas"},    {ShadowTechnique::Dsm, "atlas"},
        {ShadowTechnique::Dsm, "compact"},     {ShadowTechnique::ShadowMap, "atlas"}, {ShadowTechnique::Lowpass, "atlas"},
        {ShadowTechnique::Ao, "atlas"},        {ShadowTechnique::Cone, "atlas"}};
    // the cache off and on, not auto: auto decides on measured times, so two renders may differ
    for (ShadowCacheMode cache : {ShadowCacheMode::Off, ShadowCacheMode::On})
        for (const auto& [technique, storage] : cases) {
            options.shadows = technique;
            options.dsm.storage = storage;
            options.shadow_cache = cache;
            INFO("technique " << int(technique) << ", storage " << storage << ", shadow cache " << int(cache));
            Image one = image_with(1), banded = image_with(7);
            CHECK(same_bits(one, banded));
            CHECK(test::compare(one, banded).non_finite == 0);
        }
}

TEST_CASE("camera pass: rows of work-groups interleaved any number of ways render the image of the launch's order", "[progress]") {
    // render.cl interleaved_launch_row: each group row once, whatever the band and the ways
    Scene scene = test::overlapping_scene();
    RenderOptions options;
    options.dsm.resolution = 30;
    options.shadow_cache = ShadowCacheMode::Off;
    host::Runtime& runtime = test::context().runtime();
    const auto image_with = [&](int ways, int tiles) {
        runtime.set_camera_row_interleave(ways);
        LaunchTiles bands(tiles);
        Image image = render(test::context(), scene, options).image;
        runtime.set_camera_row_interleave(0);
        return image;
    };
    for (int size : {5, 37, 130}) {  // one group row, bands ending inside the padding, many groups
        options.width = options.height = size;
        for (ShadowTechnique technique : {ShadowTechnique::Rays, ShadowTechnique::Dsm}) {
            options.shadows = technique;
            const Image in_order = image_with(1, 1);
            for (int ways : {0, 2, 3, 7})
                for (int tiles : {1, 5}) {
                    INFO("size " << size << ", technique " << int(technique) << ", ways " << ways << ", bands " << tiles);
                    CHECK(same_bits(in_order, image_with(ways, tiles)));
                }
        }
    }
}

}  // namespace sombra
