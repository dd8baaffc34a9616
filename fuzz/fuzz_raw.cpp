// Raw volumes: the input is the JSON header, a NUL byte, then the bytes of "v.raw" written beside
// it (the seeds' headers name "raw": "v.raw"); without a NUL, the header alone.
#include <algorithm>

#include "fuzz_support.h"
#include "sombra/volume.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::uint8_t* nul = std::find(data, data + size, std::uint8_t(0));
    const std::size_t header = std::size_t(nul - data), rest = nul == data + size ? 0 : size - header - 1;
    sombra::fuzz::input_file("v.raw", nul + (rest ? 1 : 0), rest);
    const std::string path = sombra::fuzz::input_file("v.json", data, header);
    sombra::fuzz::expect_clean([&] { sombra::load_volume(path); });
    return 0;
}
