// Scene JSON: the input is the scene file. Generators are held to 32³ voxels so that a run stays in
// milliseconds (the size check itself is the same code as for the limit in docs/hostile-input.md).
#include "fuzz_support.h"
#include "sombra/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string path = sombra::fuzz::input_file("scene.json", data, size);
    sombra::VolumeLoadOptions options;
    options.max_voxels = 32 * 32 * 32;
    sombra::fuzz::expect_clean([&] { sombra::load_scene(path, options); });
    return 0;
}
