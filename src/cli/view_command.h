// sombra view — the interactive viewer (docs/viewer.md): a local HTTP server whose page renders the
// scene as the user drags the camera and the lights, switches techniques and changes their options.
#pragma once
#include <string>

#include <CLI/CLI.hpp>

namespace sombra::cli {

struct ViewCommand {
    CLI::App* app = nullptr;
    std::string path, host = "127.0.0.1", device = "auto", preset = "auto";
    int port = 8080;
    bool quiet = false;
};

// Declares `sombra view SCENE_OR_VOLUME [--port P] [--host H] [--device D] [--preset P] [-q]`.
void add_view_command(CLI::App& app, ViewCommand& command);

// Loads the scene, binds the address (one error line and exit 1 when either fails), prints the
// page's URL on stdout and serves until SIGINT or SIGTERM.
int run_view_command(const ViewCommand& command);

}  // namespace sombra::cli
