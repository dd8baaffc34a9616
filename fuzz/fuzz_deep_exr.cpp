// Deep EXR (read_deep_exr, through OpenImageIO and OpenEXR): the input is the whole file. The reader
// calls no OpenCL, so the harness runs without a device.
#include "fuzz_support.h"
#include "sombra/shadows.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string path = sombra::fuzz::input_file(SOMBRA_FUZZ_FILE, data, size);
    sombra::fuzz::expect_clean([&] { sombra::read_deep_exr(path); });
    return 0;
}
