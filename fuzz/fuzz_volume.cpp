// One volume reader: the input is the whole file, named SOMBRA_FUZZ_FILE (its extension picks the
// reader: v.nii, v.nii.gz, v.npy, v.npz, v.den, v.inr, v.vtk, and through ITK v.nrrd, v.mha, v.tif).
#include "fuzz_support.h"
#include "sombra/volume.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string path = sombra::fuzz::input_file(SOMBRA_FUZZ_FILE, data, size);
    sombra::fuzz::expect_clean([&] { sombra::load_volume(path); });
    return 0;
}
