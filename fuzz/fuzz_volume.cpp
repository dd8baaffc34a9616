// One volume reader: the input is the whole file, named SOMBRA_FUZZ_FILE (its extension picks the
// reader: v.nii, v.nii.gz, v.npy, v.npz, v.den, v.inr, v.vtk, v.vdb through OpenVDB, and through
// ITK v.nrrd, v.mha, v.tif, v.dcm).
#include "fuzz_support.h"
#include "sombra/volume.h"

#include <algorithm>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string path = sombra::fuzz::input_file(SOMBRA_FUZZ_FILE, data, size);
    // Volumes are held to 2^24 voxels (64 MiB as floats), under the fuzzer's 1 GiB allocation limit:
    // a sparse .vdb may rightly ask for up to 2^30 (the check is the same code for any limit).
    sombra::VolumeLoadOptions options;
    options.max_voxels = std::uint64_t(1) << 24;
    sombra::fuzz::expect_clean([&] { sombra::load_volume(path, options); });
    // as a rank of a distributed render reads it: the header, then a corner box and the last box;
    // only the formats that read parts (.npy, NRRD; raw .json has its own harness): the others
    // would read the whole file three more times for no new code
    const std::string name = SOMBRA_FUZZ_FILE;
    if (name != "v.npy" && name != "v.nrrd") return 0;
    sombra::VolumeLoadOptions header = options;
    header.header_only = true;
    sombra::fuzz::expect_clean([&] {
        const sombra::Volume h = sombra::load_volume(path, header);
        sombra::VolumeLoadOptions part = options;
        part.read_part = true;
        for (int corner = 0; corner < 2; ++corner) {
            for (std::size_t a = 0; a < 3; ++a) {
                part.part.first[a] = corner == 0 ? 0 : std::max(0, h.dims[a] - 3);
                part.part.last[a] = std::min(h.dims[a] - 1, part.part.first[a] + 2);
            }
            sombra::load_volume(path, part);
        }
    });
    return 0;
}
