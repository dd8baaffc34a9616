// CLI arguments (issue 25 item 5): the input is the argument list after `sombra`, NUL-separated;
// the arguments scene.json, v.npy, m.obj and points.csv stand for a small scene, volume, mesh and
// points file in this process's private folder (the seeds in fuzz/corpus/cli name them). src/cli/main.cpp is built with
// SOMBRA_FUZZ_CLI: the command parses its arguments, checks them and loads its inputs, and returns
// before it opens a device or writes a file; `devices` and `clusters` stop after parsing.
#include <string>
#include <vector>

#include "fuzz_support.h"

int sombra_cli_run(int argc, char** argv);

namespace {

// The files the arguments may name, written once into the private folder; returns the folder.
// (No chdir: libFuzzer keeps relative corpus paths.)
const std::string& prepare_folder() {
    static std::string folder;
    if (!folder.empty()) return folder;
    auto put = [](const char* name, const std::string& text) {
        return sombra::fuzz::input_file(name, reinterpret_cast<const std::uint8_t*>(text.data()), text.size());
    };
    put("points.csv", "0,0,0\n0.1,0.2,0.3\n");
    put("m.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    std::string npy = "\x93NUMPY\x01";  // v.npy: 4 × 3 × 2 float32, the values 0 … 23
    npy += '\0';
    std::string header = "{'descr': '<f4', 'fortran_order': False, 'shape': (4, 3, 2), }";
    header.resize(117, ' ');
    header += '\n';
    npy += char(header.size() & 0xFF), npy += char(header.size() >> 8), npy += header;
    for (int i = 0; i < 24; ++i) {
        const float value = float(i);
        npy.append(reinterpret_cast<const char*>(&value), sizeof value);
    }
    put("v.npy", npy);
    const std::string scene = put("scene.json", R"({
  "camera": {"position": [0, 0, 3], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov_y_deg": 40},
  "image": {"width": 16, "height": 16},
  "volumes": [{"generator": {"type": "blobs", "size": 12, "count": 2, "seed": 1}, "spacing": [0.1, 0.1, 0.1],
               "transfer_function": {"rgb_points": [0, 1, 1, 1], "opacity_points": [0, 0, 1, 0.5]}}],
  "meshes": [{"file": "m.obj", "material": {"color": [1, 0.5, 0.2], "opacity": 0.5}}],
  "lights": [{"type": "directional", "direction": [0, -1, -1]}, {"type": "point", "position": [1, 1, 1]}]
})");
    folder = scene.substr(0, scene.rfind('/'));
    return folder;
}

// An argument naming one of the folder's files, as its path there.
std::string in_folder(const std::string& arg) {
    for (const char* name : {"scene.json", "v.npy", "m.obj", "points.csv"})
        if (arg == name) return prepare_folder() + "/" + name;
    return arg;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    std::vector<std::string> args{"sombra"};
    std::string current;
    for (std::size_t i = 0; i < size && args.size() < 64; ++i) {
        if (data[i] != 0) {
            current += char(data[i]);
            continue;
        }
        args.push_back(in_folder(current));
        current.clear();
    }
    if (!current.empty() && args.size() < 64) args.push_back(in_folder(current));
    std::vector<char*> argv;
    for (std::string& arg : args) argv.push_back(arg.data());
    argv.push_back(nullptr);
    sombra::fuzz::expect_clean([&] { sombra_cli_run(int(args.size()), argv.data()); });
    return 0;
}
