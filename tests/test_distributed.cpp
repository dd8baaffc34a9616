// sombra tests — distributed rendering (sombra/distributed.h): the k-d regions, each rank's part
// of the scene against the CPU reference, the map exchange, compositing, and whole renders whose
// ranks run as threads of this process (tests/distributed/ runs the CLI under mpirun).
#include <algorithm>
#include <catch2/catch.hpp>
#include <condition_variable>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <random>
#include <filesystem>
#include <fstream>
#include <thread>

#include "distributed/map_exchange.h"
#include "test_support.h"

using namespace sombra;

namespace {

bool inside(const Box& b, const Vec3& p) {  // half-open, as the regions meet
    for (std::size_t a = 0; a < 3; ++a)
        if (!(p[a] >= b.min[a] && p[a] < b.max[a])) return false;
    return true;
}

// The ranks as threads: each collective waits until every rank has brought its part.
class ThreadRanks {
public:
    explicit ThreadRanks(int count) : count_(count), slots_(std::size_t(count)) {}
    std::vector<std::vector<unsigned char>> meet(int rank, const std::vector<unsigned char>& mine) {
        std::unique_lock<std::mutex> lock(mutex_);
        const long round = round_;
        slots_[std::size_t(rank)] = mine;
        if (++arrived_ == count_) {
            met_ = slots_, arrived_ = 0, ++round_;
            wake_.notify_all();
        } else {
            wake_.wait(lock, [&] { return round_ != round; });
        }
        return met_;  // copied under the lock: the next round needs this rank again
    }
    int count() const { return count_; }

private:
    int count_, arrived_ = 0;
    long round_ = 0;
    std::vector<std::vector<unsigned char>> slots_, met_;
    std::mutex mutex_;
    std::condition_variable wake_;
};

class ThreadExchange final : public RankExchange {
public:
    ThreadExchange(ThreadRanks& ranks, int rank) : ranks_(ranks), rank_(rank) {}
    int rank() const override { return rank_; }
    int size() const override { return ranks_.count(); }
    std::vector<std::vector<unsigned char>> all_gather(const std::vector<unsigned char>& mine) override { return ranks_.meet(rank_, mine); }
    std::vector<std::vector<unsigned char>> gather_to_root(const std::vector<unsigned char>& mine) override {
        auto all = ranks_.meet(rank_, mine);
        return rank_ == 0 ? all : std::vector<std::vector<unsigned char>>{};
    }
    bool all_ok(bool ok) override {
        for (const auto& said : ranks_.meet(rank_, {ok ? (unsigned char)1 : (unsigned char)0}))
            if (said.at(0) == 0) return false;
        return true;
    }

private:
    ThreadRanks& ranks_;
    int rank_;
};

struct RankOutcome {
    RenderResult result;
    std::string error;  // what the rank threw, "" if nothing
    bool other_failed = false;
};

// Every rank of a distributed render as a thread with its own Context.
std::vector<RankOutcome> render_on_threads(const Scene& scene, const RenderOptions& options, int count, const VolumeLoadOptions& load = {}) {
    ThreadRanks ranks(count);
    std::vector<RankOutcome> outcomes(static_cast<std::size_t>(count));
    // the Contexts first, one at a time: OpenCL's first platform query is not safe from many
    // threads at once (in a fresh process three threads creating theirs waited forever)
    std::vector<std::unique_ptr<Context>> contexts;
    for (int r = 0; r < count; ++r) contexts.push_back(std::make_unique<Context>(test::device_selector()));
    std::vector<std::thread> threads;
    for (int r = 0; r < count; ++r)
        threads.emplace_back([&, r] {
            ThreadExchange exchange(ranks, r);
            RankOutcome& out = outcomes[std::size_t(r)];
            try {
                out.result = render_distributed(*contexts[std::size_t(r)], scene, options, exchange, load);
            } catch (const OtherRankFailed&) {
                out.other_failed = true;
            } catch (const std::exception& e) {
                out.error = e.what();
            }
        });
    for (std::thread& t : threads) t.join();
    return outcomes;
}

// A scene of meshes far apart and no volume: with 4 ranks the cut between them leaves a region empty.
Scene meshes_apart() {
    Scene s;
    s.meshes = {test::quad(0.2f, 0.f, 0.6f, {0.9f, 0.4f, 0.2f}), test::quad(0.2f, -0.5f, 0.8f)};
    s.meshes[1].transform[3] = 3.f;  // the second square 3 units along +x
    Light light;
    light.direction = {0.3f, -0.2f, -1.f};
    s.lights = {light};
    s.camera.position = {1.5f, 0.3f, 4.f};
    s.camera.look_at = {1.5f, 0.f, 0.f};
    s.camera.fov_y_deg = 55.f;
    s.width = 40, s.height = 24;
    return s;
}

}  // namespace

TEST_CASE("distributed: the regions cover the world once and every eye sees them in an order no region occludes an earlier one", "[distributed]") {
    const Scene scene = test::overlapping_scene();
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> coordinate(-3.f, 3.f);
    for (int count = 1; count <= 7; ++count) {
        const RegionSplit split = split_regions(scene, count);
        REQUIRE(split.regions.size() == std::size_t(count));
        for (int i = 0; i < 200; ++i) {  // every point of space in exactly one region
            const Vec3 p{coordinate(rng), coordinate(rng), coordinate(rng)};
            int holders = 0;
            for (const Box& b : split.regions) holders += inside(b, p) ? 1 : 0;
            REQUIRE(holders == 1);
        }
        for (int i = 0; i < 50; ++i) {
            const Vec3 eye{coordinate(rng), coordinate(rng), coordinate(rng)};
            const std::vector<int> order = split.front_to_back(eye);
            REQUIRE(order.size() == std::size_t(count));
            // a region earlier in the order is never behind a later one: some plane parts them
            // with the eye on the earlier one's side
            for (std::size_t x = 0; x < order.size(); ++x)
                for (std::size_t y = x + 1; y < order.size(); ++y) {
                    const Box& a = split.regions[std::size_t(order[x])];
                    const Box& b = split.regions[std::size_t(order[y])];
                    bool parted = false;
                    for (std::size_t ax = 0; ax < 3; ++ax)
                        parted = parted || (a.max[ax] <= b.min[ax] && eye[ax] <= b.min[ax]) || (b.max[ax] <= a.min[ax] && eye[ax] >= b.max[ax]);
                    INFO("ranks " << count << ", regions " << order[x] << " before " << order[y]);
                    REQUIRE(parted);
                }
        }
    }
}

TEST_CASE("distributed: the regions' transmittances multiply to the whole scene's (CPU reference, rotated volumes, three light types)", "[distributed]") {
    const Scene scene = test::overlapping_scene();
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> coordinate(-0.6f, 0.6f);
    for (int count : {2, 3, 5}) {
        const RegionSplit split = split_regions(scene, count);
        std::vector<Scene> parts;
        for (const Box& region : split.regions) parts.push_back(region_scene(scene, region));
        double worst = 0;
        for (int i = 0; i < 40; ++i) {
            const Vec3 p{coordinate(rng), coordinate(rng), coordinate(rng)};
            for (int light = 0; light < 3; ++light) {
                const double t = reference_transmittance(scene, light, p, 0.1);
                double product = 1;
                for (const Scene& part : parts) product *= reference_transmittance(part, light, p, 0.1);
                worst = std::max(worst, std::fabs(product - t));
            }
        }
        INFO("ranks " << count << ": worst |Π T_region − T| " << worst);
        CHECK(worst < 1e-4);  // measured ≤ 4.2e-6: the reference integrates the cut pieces alike
    }
    // an axis-aligned 48³ volume: each crop is its region's voxels and the ghost layers, 4 voxel
    // planes shared across each cut (⌊c⌋ − 1 … ⌊c⌋ + 2)
    const Scene sphere = test::sphere_scene(48);
    for (int count : {2, 4}) {
        std::size_t voxels = 0;
        for (const Box& region : split_regions(sphere, count).regions)
            for (const VolumeInstance& vi : region_scene(sphere, region).volumes) voxels += vi.volume->voxel_count();
        CHECK(voxels <= 48u * 48u * 48u + std::size_t(count - 1) * 4u * 48u * 48u);
        CHECK(voxels > 48u * 48u * 48u);
    }
}

TEST_CASE("distributed: no cut passes through a mesh and each mesh goes to one rank, and a mesh across every cut is an error", "[distributed]") {
    Scene scene = test::sphere_scene(24);
    scene.volumes[0].transform = {0.05f, 0, 0, 0, 0, 0.05f, 0, 0, 0, 0, 0.05f, 0, 0, 0, 0, 1};  // 1.2 units wide
    MeshInstance small = test::quad(0.1f, 0.f, 0.5f);
    scene.meshes = {small, small};
    scene.meshes[1].transform[3] = 0.35f;  // two small squares side by side in the fog
    for (int count : {2, 3, 4}) {
        const RegionSplit split = split_regions(scene, count);
        int held = 0;
        for (const Box& region : split.regions) held += int(region_scene(scene, region).meshes.size());
        CHECK(held == 2);
        for (const RegionSplit::Node& n : split.nodes) {
            if (n.axis < 0) continue;
            for (float centre : {0.f, 0.35f}) {  // the squares span x ∈ [c − 0.1, c + 0.1], y ∈ [−0.1, 0.1], z = 0
                const float lo = n.axis == 0 ? centre - 0.1f : n.axis == 1 ? -0.1f : 0.f;
                const float hi = n.axis == 0 ? centre + 0.1f : n.axis == 1 ? 0.1f : 0.f;
                CHECK_FALSE((n.position > lo && n.position < hi));
            }
        }
    }
    scene.meshes = {test::quad(2.f, 0.f, 0.5f)};  // wider than the volume: every x and y cut crosses it
    scene.meshes[0].transform = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    MeshInstance tall = test::quad(2.f, 0.f, 0.5f);  // the same square turned to stand in x = 0: z cuts cross it
    tall.transform = {0, 0, 1, 0, 0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 0, 1};
    scene.meshes.push_back(tall);
    CHECK_THAT(test::error_of([&] { split_regions(scene, 2); }), Catch::Contains("--distributed") && Catch::Contains("mesh"));
}

TEST_CASE("distributed: merged maps keep every rank's nodes, one cluster per rank and light, and bad bytes are refused", "[distributed]") {
    // rank r: light 0 with 1 view (2×2 texels), light 1 with 2 views of one cluster; texel t of view v holds t + 1 nodes
    auto rank_maps = [](int r) {
        distributed::MapSet m;
        m.nodes.texel_first = {0};
        for (int v = 0; v < 3; ++v) {
            DsmViewGpu view{};
            view.resolution = 2;
            view.first_texel = cl_uint(4 * v);
            view.cluster = 0;
            m.views.push_back(view);
            for (int t = 0; t < 4; ++t) {
                for (int k = 0; k <= t; ++k) m.nodes.nodes.insert(m.nodes.nodes.end(), {float(100 * r + 10 * v + k), 0.1f * float(k)});
                m.nodes.texel_first.push_back(m.nodes.texel_first.back() + cl_uint(t + 1));
            }
        }
        m.light_views = {{0, 1}, {1, 2}};
        return m;
    };
    std::vector<distributed::MapSet> ranks;
    for (int r = 0; r < 3; ++r)
        ranks.push_back(distributed::deserialize(distributed::serialize(rank_maps(r)), "rank " + std::to_string(r)));
    const distributed::MapSet merged = distributed::merge_map_sets(ranks);
    REQUIRE(merged.views.size() == 9);
    REQUIRE(merged.light_views.size() == 2);
    CHECK(merged.light_views[0].first == 0);
    CHECK(merged.light_views[0].count == 3);
    CHECK(merged.light_views[1].first == 3);
    CHECK(merged.light_views[1].count == 6);
    for (cl_uint v = 0; v < 3; ++v) CHECK(merged.views[v].cluster == v);                    // light 0: rank r is cluster r
    for (cl_uint v = 0; v < 6; ++v) CHECK(merged.views[3 + v].cluster == v / 2);            // light 1: each rank's two views one cluster
    CHECK(merged.nodes.nodes.size() == 2 * 9 * (1 + 2 + 3 + 4));
    for (std::size_t v = 0; v < merged.views.size(); ++v) {  // texel t's first node depth names its rank and view
        const int rank = v < 3 ? int(v) : int(v - 3) / 2, view = v < 3 ? 0 : 1 + int(v - 3) % 2;
        for (cl_uint t = 0; t < 4; ++t) {
            const cl_uint first = merged.nodes.texel_first[merged.views[v].first_texel + t];
            CHECK(merged.nodes.texel_first[merged.views[v].first_texel + t + 1] - first == t + 1);
            CHECK(merged.nodes.nodes[2 * first] == float(100 * rank + 10 * view));
        }
    }
    std::vector<unsigned char> bytes = distributed::serialize(rank_maps(1));
    bytes.resize(bytes.size() - 3);
    CHECK_THAT(test::error_of([&] { distributed::deserialize(bytes, "rank 1"); }), Catch::Contains("rank 1"));
    bytes = distributed::serialize(rank_maps(1));
    bytes[8 + 1 + 5] ^= 0x40;  // the view count (after the magic and the optical-depth flag): 2^40 more
    CHECK_THAT(test::error_of([&] { distributed::deserialize(bytes, "rank 1"); }), Catch::Contains("rank 1"));
    ranks[1].light_views.pop_back();
    CHECK_THAT(test::error_of([&] { distributed::merge_map_sets(ranks); }), Catch::Contains("lights"));
}

TEST_CASE("distributed: compositing regions front to back is compositing their samples in one pass", "[distributed]") {
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> unit(0.f, 1.f);
    const Vec3 background{0.2f, 0.3f, 0.4f};
    std::vector<Image> parts(4);
    for (Image& part : parts) {
        part.width = 5, part.height = 3;
        for (int p = 0; p < 15; ++p) {
            const float alpha = unit(rng);
            for (int c = 0; c < 3; ++c) part.rgba.push_back(alpha * unit(rng));  // premultiplied
            part.rgba.push_back(alpha);
        }
    }
    const Image out = composite_front_to_back({&parts[0], &parts[1], &parts[2], &parts[3]}, background);
    for (int p = 0; p < 15; ++p) {
        double transmittance = 1, red = 0;
        for (const Image& part : parts) {
            red += transmittance * part.rgba[std::size_t(4 * p)];
            transmittance *= 1 - part.rgba[std::size_t(4 * p + 3)];
        }
        CHECK(out.rgba[std::size_t(4 * p)] == Approx(red + transmittance * background[0]).margin(1e-6));
        CHECK(out.rgba[std::size_t(4 * p + 3)] == Approx(1 - transmittance).margin(1e-6));
    }
}

TEST_CASE("distributed: ranks as threads render the image of one process, also with an empty region and a mesh", "[distributed]") {
    RenderOptions options;
    options.shadows = ShadowTechnique::Dsm;
    options.dsm.resolution = 128;
    const Scene scenes[] = {test::overlapping_scene(), meshes_apart()};
    for (const Scene& scene : scenes) {
        const RenderResult one = render(test::context(), scene, options);
        for (int count : {2, 4}) {
            std::vector<RankOutcome> ranks = render_on_threads(scene, options, count);
            for (const RankOutcome& r : ranks) REQUIRE(r.error == "");
            const RenderStats& stats = ranks[0].result.stats;
            REQUIRE(stats.rank_stats.size() == std::size_t(count));
            int empty = 0;
            for (const RankOutcome& r : ranks) empty += r.result.stats.region_volumes + r.result.stats.region_meshes == 0 ? 1 : 0;
            if (scene.volumes.empty() && count == 4) CHECK(empty >= 1);  // the cut between the squares leaves space alone
            CHECK(stats.map_bytes_received > 0);
            const test::ImageDifference d = test::compare(ranks[0].result.image, one.image);
            INFO((scene.volumes.empty() ? "meshes apart" : "overlapping volumes") << ", ranks " << count << ": max |Δ| " << d.max_abs
                                                                                 << ", mean " << d.mean_abs);
            CHECK(d.non_finite == 0);
            CHECK(d.max_abs < 0.04);  // measured 0.019 (4 ranks): each rank's maps have their own texel grid
            CHECK(d.mean_abs < 0.001);  // measured 1.7e-4
            for (std::size_t r = 1; r < ranks.size(); ++r) CHECK(ranks[r].result.image.rgba.empty());
        }
    }
}

TEST_CASE("distributed: ranks that read only their box of an npy file render the image of one process", "[distributed]") {
    // the sphere scene's volume as a float32 .npy, and a scene file that places it alike
    const Scene whole = test::sphere_scene(32);
    const Volume& v = *whole.volumes[0].volume;
    std::string dict = "{'descr': '<f4', 'fortran_order': False, 'shape': (" + std::to_string(v.dims[2]) + ", " +
                       std::to_string(v.dims[1]) + ", " + std::to_string(v.dims[0]) + "), }";
    while ((10 + dict.size() + 1) % 64 != 0) dict += ' ';
    dict += '\n';
    const std::string dir = test::temp_dir(), npy = dir + "/sphere32.npy", scene_path = dir + "/sphere32.json";
    {
        std::ofstream out(npy, std::ios::binary);
        const unsigned char head[10] = {0x93, 'N', 'U', 'M', 'P', 'Y', 1, 0, (unsigned char)(dict.size() & 0xff), (unsigned char)(dict.size() >> 8)};
        out.write(reinterpret_cast<const char*>(head), 10);
        out << dict;
        out.write(reinterpret_cast<const char*>(v.voxels.data()), std::streamsize(v.voxels.size() * sizeof(float)));
    }
    Scene from_file = whole;
    VolumeLoadOptions header;
    header.header_only = true;
    from_file.volumes[0].volume = std::make_shared<const Volume>(load_volume(npy, header));
    REQUIRE(from_file.volumes[0].volume->header_only);
    RenderOptions options;
    options.dsm.resolution = 96;
    std::vector<RankOutcome> parted = render_on_threads(from_file, options, 3);
    for (const RankOutcome& r : parted) REQUIRE(r.error == "");
    unsigned long long voxels = 0;
    for (const RankOutcome& r : parted) {
        CHECK(r.result.stats.region_voxels < v.voxel_count());  // no rank read the whole volume
        voxels += r.result.stats.region_voxels;
    }
    CHECK(voxels >= v.voxel_count());
    // a header has no voxels to tell occupied bricks: the split weighs every brick, so the
    // regions differ from those of the whole volume; the image is one process's within the maps' grids
    const test::ImageDifference d = test::compare(parted[0].result.image, render(test::context(), whole, options).image);
    INFO("max |Δ| " << d.max_abs << ", mean " << d.mean_abs);
    CHECK(d.max_abs < 0.04);
    CHECK(d.mean_abs < 0.001);
}

TEST_CASE("distributed: a rank that fails stops every rank with its error, none waits", "[distributed]") {
    RenderOptions options;
    options.dsm.resolution = 64;
    setenv("SOMBRA_TEST_FAIL_RANK", "1", 1);
    std::vector<RankOutcome> ranks = render_on_threads(test::sphere_scene(16), options, 3);
    unsetenv("SOMBRA_TEST_FAIL_RANK");
    CHECK(ranks[0].other_failed);
    CHECK_THAT(ranks[1].error, Catch::Contains("rank 1"));
    CHECK(ranks[2].other_failed);
    options.shadows = ShadowTechnique::Rays;
    ranks = render_on_threads(test::sphere_scene(16), options, 2);
    for (const RankOutcome& r : ranks) CHECK_THAT(r.error, Catch::Contains("--shadows rays") && Catch::Contains("distributed"));
}
