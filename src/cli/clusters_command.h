// sombra clusters — the object clusters of every light and their focused views (Knecht §3.4),
// printed as text and, with --json, written as JSON. No OpenCL: geometry only.
#pragma once
#include <string>

#include <CLI/CLI.hpp>

#include "sombra/scene.h"

namespace sombra::cli {

struct ClustersCommand {
    CLI::App* app = nullptr;
    std::string scene_path, json_path;
    int max_clusters = 4;
    double distance = 0;
};

// Declares `sombra clusters SCENE.json [--clusters M] [--cluster-distance D0] [--json FILE]`,
// its values bound to `command`.
void add_clusters_command(CLI::App& app, ClustersCommand& command);

// Runs it on the loaded scene; throws sombra::Error naming the flag for impossible values.
int run_clusters_command(const ClustersCommand& command, const Scene& scene);

}  // namespace sombra::cli
