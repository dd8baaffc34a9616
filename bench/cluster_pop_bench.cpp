// sombra_bench_cluster_pop — popping of clustered deep shadow maps (issue 14 item 7): the camera
// trucks sideways in small steps over a scene, every frame re-rendered through the API on one
// Context per variant (the clusters follow the camera), with and without cluster hysteresis
// (RenderOptions::dsm_cluster_hysteresis). Per variant: how often a light's cluster membership
// changed, the views regenerated, and how much the shadows jump between consecutive frames: the
// largest per-pixel change of (clustered image − unclustered image of the same pose), so that what
// the camera move itself changes cancels — on all frames, and on the frames where the membership
// changed (a pop shows as a spike there). The unclustered maps (one per light view, fitted to the
// scene) do not depend on the camera.
#include <cmath>
#include <iostream>

#include <CLI/CLI.hpp>

#include "bench_util.h"

namespace {

using sombra::bench::sci;

// Each light's clusters as their member names, in order.
std::vector<std::vector<std::string>> memberships(const sombra::RenderStats& stats) {
    std::vector<std::vector<std::string>> m;
    for (const auto& c : stats.dsm_clusters) {
        std::string names = "light " + std::to_string(c.light) + ":";
        for (const std::string& n : c.members) names += " " + n;
        if (m.size() <= std::size_t(c.light)) m.resize(std::size_t(c.light) + 1);
        m[std::size_t(c.light)].push_back(names);
    }
    return m;
}

// The largest and mean change, between two frames, of any channel of any pixel of the difference
// clustered − unclustered (all four images of one size).
std::pair<double, double> shadow_jump(const sombra::Image& clustered_before, const sombra::Image& plain_before,
                                      const sombra::Image& clustered_after, const sombra::Image& plain_after) {
    double largest = 0, sum = 0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < clustered_before.rgba.size(); ++i) {
        if (i % 4 == 3) continue;
        double before = double(clustered_before.rgba[i]) - double(plain_before.rgba[i]);
        double after = double(clustered_after.rgba[i]) - double(plain_after.rgba[i]);
        largest = std::max(largest, std::fabs(after - before)), sum += std::fabs(after - before), ++n;
    }
    return {largest, n ? sum / double(n) : 0.0};
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"sombra_bench_cluster_pop: shadow popping of clustered deep shadow maps along a camera path"};
    std::string scene_path = std::string(SOMBRA_DATA_DIR) + "/scenes/cup_array.json", device = "auto";
    int frames = 60, width = 240, height = 160, resolution = 256, clusters = 4;
    float step = 2.f, hysteresis = 0.25f;
    app.add_option("--scene", scene_path, "scene file");
    app.add_option("--frames", frames, "camera steps (frames after the first)");
    app.add_option("--step", step, "sideways step of the camera and its look-at point per frame, world units");
    app.add_option("--width", width);
    app.add_option("--height", height);
    app.add_option("--dsm-res", resolution, "texels per side of every cluster's map");
    app.add_option("--clusters", clusters, "clusters per light");
    app.add_option("--hysteresis", hysteresis, "the variant with hysteresis (the other has 0)");
    app.add_option("--device", device);
    CLI11_PARSE(app, argc, argv);
    try {
        const sombra::Scene base = sombra::load_scene(scene_path);
        std::cout << "# Cluster popping: " << scene_path << ", " << frames << " steps of " << step << " sideways, " << width << "×"
                  << height << ", " << clusters << " clusters of " << resolution << "² per light\n\n";
        // the unclustered images of every pose (the reference the clustered ones are compared with)
        sombra::Context plain_context(device);
        sombra::RenderOptions plain;
        plain.shadows = sombra::ShadowTechnique::Dsm;
        plain.dsm.resolution = 2 * resolution;  // as many texels per light view as 4 clusters
        plain.dsm.epsilon = 0.01f;
        plain.shadow_cache = sombra::ShadowCacheMode::Off;
        plain.width = width, plain.height = height;
        std::vector<sombra::Image> plain_images;
        sombra::Scene moving = base;
        for (int f = 0; f <= frames; ++f) {
            plain_images.push_back(sombra::render(plain_context, moving, plain).image);
            moving.camera.position[0] += step, moving.camera.look_at[0] += step;
        }
        std::cout << "| hysteresis | membership changes (objects entering or leaving B) | views regenerated | largest shadow jump: all frames | "
                     "at membership changes | elsewhere | mean jump per frame |\n|---|---|---|---|---|---|---|\n";
        for (float h : {0.f, hysteresis, 4 * hysteresis}) {
            sombra::Context context(device);
            sombra::RenderOptions o;
            o.shadows = sombra::ShadowTechnique::Dsm;
            o.dsm.resolution = resolution;
            o.dsm.epsilon = 0.01f;
            o.dsm.clusters = clusters;
            o.dsm.cluster_hysteresis = h;
            o.shadow_cache = sombra::ShadowCacheMode::Off;
            o.width = width, o.height = height;
            sombra::Scene scene = base;  // moves as `moving` did
            sombra::RenderResult previous = sombra::render(context, scene, o);
            auto previous_members = memberships(previous.stats);
            int changes = 0, regenerated = 0, entered_or_left = 0;  // frames where objects entered or left B
            double largest = 0, at_changes = 0, elsewhere = 0, mean = 0;
            for (int f = 1; f <= frames; ++f) {
                scene.camera.position[0] += step, scene.camera.look_at[0] += step;
                sombra::RenderResult frame = sombra::render(context, scene, o);
                auto members = memberships(frame.stats);
                bool changed = members != previous_members;
                changes += changed ? 1 : 0;
                entered_or_left += frame.stats.dsm_ignored_objects != previous.stats.dsm_ignored_objects ? 1 : 0;
                regenerated += frame.stats.dsm_views_generated;
                auto [frame_largest, frame_mean] =
                    shadow_jump(previous.image, plain_images[std::size_t(f - 1)], frame.image, plain_images[std::size_t(f)]);
                largest = std::max(largest, frame_largest);
                (changed ? at_changes : elsewhere) = std::max(changed ? at_changes : elsewhere, frame_largest);
                mean += frame_mean / frames;
                previous = std::move(frame);
                previous_members = members;
            }
            std::cout << "| " << h << " | " << changes << " (" << entered_or_left << ") | " << regenerated << " | " << sci(largest) << " | "
                      << (changes ? sci(at_changes) : std::string("–")) << " | " << sci(elsewhere) << " | " << sci(mean) << " |\n";
        }
    } catch (const std::exception& e) {
        std::cerr << "sombra_bench_cluster_pop: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
