// sombra clusters — the object clusters of every light and their focused views (Knecht §3.4),
// printed as text and, with --json, written as JSON; with --image, a render of the scene with each
// object tinted by its cluster.
#pragma once
#include <string>

#include <CLI/CLI.hpp>

#include "sombra/scene.h"

namespace sombra::cli {

struct ClustersCommand {
    CLI::App* app = nullptr;
    std::string scene_path, json_path, image_path, device = "auto";
    int max_clusters = 4, light = 0, width = 0, height = 0;
    double distance = 0;
};

// Declares `sombra clusters SCENE.json [--clusters M] [--cluster-distance D0] [--json FILE]
// [--image FILE --light I --width W --height H]` (the tinted image: Knecht Fig. 5.8),
// its values bound to `command`.
void add_clusters_command(CLI::App& app, ClustersCommand& command);

// Runs it on the loaded scene; throws sombra::Error naming the flag for impossible values.
int run_clusters_command(const ClustersCommand& command, const Scene& scene);

}  // namespace sombra::cli
