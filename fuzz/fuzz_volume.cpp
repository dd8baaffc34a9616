// One volume reader: the input is the whole file, named SOMBRA_FUZZ_FILE (its extension picks the
// reader: v.nii, v.nii.gz, v.npy, v.npz, v.den, v.inr, v.vtk, v.vdb through OpenVDB, and through
// ITK v.nrrd, v.mha, v.tif, v.dcm).
#include "fuzz_support.h"
#include "sombra/volume.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string path = sombra::fuzz::input_file(SOMBRA_FUZZ_FILE, data, size);
    // Volumes are held to 2^24 voxels (64 MiB as floats), under the fuzzer's 1 GiB allocation limit:
    // a sparse .vdb may rightly ask for up to 2^30 (the check is the same code for any limit).
    sombra::VolumeLoadOptions options;
    options.max_voxels = std::uint64_t(1) << 24;
    sombra::fuzz::expect_clean([&] { sombra::load_volume(path, options); });
    return 0;
}
