// sombra info — what a volume file or a scene holds: for a volume its size, voxel type, spacing,
// world bounds and placement, value range, percentiles, a text histogram and non-finite count;
// for a scene each object's world bounds, the lights and the camera. --json: one JSON object.
#pragma once
#include <string>

#include <CLI/CLI.hpp>

namespace sombra::cli {

struct InfoCommand {
    CLI::App* app = nullptr;
    std::string path, grid;
    bool json = false;
};

// Declares `sombra info FILE [--json] [--grid NAME]`, its values bound to `command`.
void add_info_command(CLI::App& app, InfoCommand& command);

// Prints the file's description on stdout; throws sombra::Error "FILE: FIELD: what" for a file
// that cannot be read.
int run_info_command(const InfoCommand& command);

}  // namespace sombra::cli
