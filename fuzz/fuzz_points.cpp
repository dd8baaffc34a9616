// The points CSV of `sombra visibility`.
#include "fuzz_support.h"
#include "sombra/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string path = sombra::fuzz::input_file("points.csv", data, size);
    sombra::fuzz::expect_clean([&] { sombra::load_points_csv(path); });
    return 0;
}
