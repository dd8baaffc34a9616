// The mesh reader: the input is the whole file, named SOMBRA_FUZZ_FILE (m.ply or m.obj).
#include "fuzz_support.h"
#include "sombra/mesh.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string path = sombra::fuzz::input_file(SOMBRA_FUZZ_FILE, data, size);
    sombra::fuzz::expect_clean([&] {
        const sombra::Mesh mesh = sombra::load_mesh(path);
        sombra::check_closed(mesh, path);  // also walks every triangle
    });
    return 0;
}
