// Hostile input (issue 12): every class the fuzzers found, one test each. Each input must give one
// sombra::Error naming the file and the field, fast, without a crash or a large allocation.
#include <catch2/catch.hpp>

#include <chrono>
#include <cstring>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <sys/stat.h>

#include <nlohmann/json.hpp>

#include "host/runtime.h"
#include "render/staged_outputs.h"
#include "sombra/sombra.h"
#include "test_support.h"

using namespace sombra;

namespace {

std::string write_file(const std::string& name, const std::string& bytes) {
    std::string path = test::temp_dir() + "/" + name;
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
}

using test::error_of;

void require_error(const std::string& message, const std::string& file, const std::string& field) {
    INFO(message);
    CHECK(message.rfind(file + ": ", 0) == 0);
    CHECK(message.find(field) != std::string::npos);
    CHECK(message.find('\n') == std::string::npos);
}

const char* kTf = R"("transfer_function": {"rgb_points": [0, 1, 1, 1], "opacity_points": [0, 0, 1, 1]})";

// A scene whose one volume is `volume` (JSON members) and whose top level also holds `extra`.
std::string scene_with(const std::string& name, const std::string& volume, const std::string& extra = "") {
    return write_file(name, "{\"volumes\": [{" + volume + ", " + kTf + "}]" + extra + "}");
}

std::string npy_header(const std::string& shape) {
    std::string dict = "{'descr': '<f4', 'fortran_order': False, 'shape': " + shape + ", }";
    dict.resize(117, ' ');
    dict += '\n';
    return std::string("\x93NUMPY\x01\x00", 8) + char(dict.size() & 0xff) + char(dict.size() >> 8) + dict;
}

}  // namespace

TEST_CASE("hostile input: header sizes near 2^64 and transfer functions near ±FLT_MAX corrupt no memory",
          "[hostile]") {
    write_file("eight.raw", "abcdefgh");
    for (const char* skip : {"18446744073709551608", "9223372036854775807", "9"}) {
        std::string header = write_file("wrap.json", std::string(R"({"raw": "eight.raw", "dims": [2, 2, 2], "type": "uint8", "header_bytes": )") +
                                                         skip + "}");
        require_error(error_of([&] { load_volume(header); }), header, "header_bytes");
    }

    TransferFunction tf;
    tf.color_points = {{-3e38f, 0, 0, 0}, {3e38f, 1, 1, 1}};
    tf.opacity_points = {{-3e38f, 0}, {3e38f, 1}};
    for (const auto& entry : tf.table(256, 1.f))
        for (float v : entry) CHECK(std::isfinite(v));
    CHECK(tf.color(std::nanf(""))[0] == 1.f);  // NaN looks up the last point, never end()
    CHECK(tf.opacity(0.f) == Approx(0.5f));
}

TEST_CASE("hostile input: directories, FIFOs and devices are refused before any read", "[hostile]") {
    const std::string dir = test::temp_dir() + "/folder.vtk";
    std::filesystem::create_directories(dir);
    require_error(error_of([&] { load_volume(dir); }), dir, "not a regular file (a directory)");
    require_error(error_of([&] { load_mesh(test::temp_dir() + "/folder.vtk"); }), dir, "not a regular file");

    const std::string fifo = test::temp_dir() + "/pipe.npy";
    std::filesystem::remove(fifo);
    REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
    const auto start = std::chrono::steady_clock::now();
    require_error(error_of([&] { load_volume(fifo); }), fifo, "not a regular file (a FIFO)");
    require_error(error_of([&] { load_scene(fifo); }), fifo, "a FIFO");
    require_error(error_of([&] { load_points_csv(fifo); }), fifo, "a FIFO");
    require_error(error_of([&] { read_deep_exr(fifo); }), fifo, "a FIFO");  // OpenImageIO would block on it
    require_error(error_of([&] { read_image(fifo); }), fifo, "a FIFO");
    CHECK(std::chrono::steady_clock::now() - start < std::chrono::seconds(5));

    require_error(error_of([] { load_points_csv("/dev/zero"); }), "/dev/zero", "a character device");
    require_error(error_of([] { read_deep_exr("/dev/zero"); }), "/dev/zero", "a character device");
    require_error(error_of([&] { load_points_csv(test::temp_dir()); }), test::temp_dir(), "a directory");
}

TEST_CASE("hostile input: sizes in headers are checked against the file before allocating", "[hostile]") {
    SECTION("ASCII VTK declaring 1000³ points in 151 bytes") {
        std::string f = write_file("big.vtk", "# vtk DataFile Version 3.0\nx\nASCII\nDATASET STRUCTURED_POINTS\n"
                                              "DIMENSIONS 1000 1000 1000\nPOINT_DATA 1000000000\nSCALARS s float\n1 2 3\n");
        require_error(error_of([&] { load_volume(f); }), f, "data: truncated");
    }
    SECTION("NIfTI header of 1000³ floats without data") {
        std::string h(352, '\0');
        const auto put16 = [&](std::size_t at, int v) { h[at] = char(v & 0xff), h[at + 1] = char((v >> 8) & 0xff); };
        put16(0, 348);
        const int dims[8] = {3, 1000, 1000, 1000, 1, 1, 1, 1};
        for (int i = 0; i < 8; ++i) put16(40 + 2 * std::size_t(i), dims[i]);
        put16(70, 16), put16(72, 32);          // float32
        const float offset = 352.f;            // vox_offset
        std::memcpy(&h[108], &offset, 4);
        std::memcpy(&h[344], "n+1\0", 4);
        std::string f = write_file("header_only.nii", h);
        require_error(error_of([&] { load_volume(f); }), f, "data: truncated");
        put16(70, 1234);  // an unknown datatype: our message, before niftiio prints its own
        f = write_file("datatype.nii", h);
        require_error(error_of([&] { load_volume(f); }), f, "datatype");
    }
    SECTION("npz member with a forged size") {
        const std::string f = test::data_path("../tests/hostile/forged_size.npz");
        require_error(error_of([&] { load_volume(f); }), f + ":arr_0.npy", "declares 2200000000 bytes but holds 160");
    }
    SECTION("npy shapes that are not tuples") {
        for (const char* shape : {"''", "(", "(1, 2, 3, 4, 5, 6, 7, 8)", "(99999999999999999999, 1, 1)"}) {
            std::string f = write_file("shape.npy", npy_header(shape));
            require_error(error_of([&] { load_volume(f); }), f, "shape");
        }
    }
    SECTION("raw dims whose product passes the voxel limit") {
        write_file("one.raw", "x");
        std::string f = write_file("dims.json", R"({"raw": "one.raw", "dims": [4294967297, 1, 1], "type": "uint8"})");
        require_error(error_of([&] { load_volume(f); }), f, "dims");
        f = write_file("product.json", R"({"raw": "one.raw", "dims": [65536, 65536, 65536], "type": "uint8"})");
        require_error(error_of([&] { load_volume(f); }), f, "dims");
    }
}

TEST_CASE("hostile input: scene numbers are checked as the type they are used as", "[hostile]") {
    const std::string sphere = R"("generator": {"type": "sphere", "size": 8})";
    const std::vector<std::pair<std::string, std::string>> cases = {
        {scene_with("w.json", sphere, R"(, "image": {"width": 4294967328, "height": 8})"), "image.width"},
        {scene_with("size.json", R"("generator": {"type": "sphere", "size": 4294967304})"), "volumes[0].generator.size"},
        {scene_with("count.json", R"("generator": {"type": "blobs", "size": 8, "count": 100000000})"), "generator.count"},
        {scene_with("seed.json", R"("generator": {"type": "cloud", "size": 8, "seed": -1})"), "generator.seed"},
        {scene_with("density.json", R"("generator": {"type": "sphere", "size": 8, "density": 1e39})"), "generator.density"},
        {scene_with("light.json", sphere, R"(, "lights": [{"type": "directional", "direction": [1e39, 0, 0]}])"),
         "lights[0].direction"},
        {scene_with("spacing.json", sphere + R"(, "spacing": [1e39, 1, 1])"), "volumes[0].spacing"},
        {scene_with("extent.json", sphere + R"(, "spacing": [1e30, 1, 1])"), "volumes[0]"},
        {scene_with("scale.json", sphere + R"(, "transform": {"scale": 1e38})"), "volumes[0]"},
        {scene_with("matrix.json", sphere + R"(, "transform": {"matrix": [1e39, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]})"),
         "volumes[0].transform.matrix"},
        {scene_with("camera.json", sphere, R"(, "camera": {"position": [1e30, 0, 0]})"), "camera.position"},
        {scene_with("double.json", sphere, R"(, "ambient_intensity": 1e400)"), "json: [json.exception.out_of_range.406]"},
        {write_file("tf.json", std::string(R"({"volumes": [{)") + sphere +
                                   R"(, "transfer_function": {"rgb_points": [0, 1, 1, 1], "opacity_points": [0, 0, 4e38, 1]}}]})"),
         "volumes[0].transfer_function.opacity_points"},
    };
    for (const auto& c : cases) require_error(error_of([&] { load_scene(c.first); }), c.first, c.second);

    // the largest values that pass still give a finite, drawable scene
    Scene ok = load_scene(scene_with("edge.json", R"("generator": {"type": "blobs", "size": 8, "count": 256, "seed": 4294967295})"));
    CHECK(ok.volumes.at(0).volume->value_max <= 1.f);
}

TEST_CASE("hostile input: PLY files that crashed or hung Assimp give one line", "[hostile][mesh]") {
    const std::string vertex = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
    const std::vector<std::pair<std::string, std::string>> cases = {
        {"ply\nformat ascii 1.0\n", "no end_header"},
        {"ply\nformat ascii 1.0\n" + vertex + "property quaternion w\nend_header\n0 0 0 0\n", "unknown property type"},
        {"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\n"
         "property float z\nend_header\n\x01\x02\x03",
         "element vertex"},
        {"ply\nformat ascii 1.0\n" + vertex + "element face 1\nproperty list uint int vertex_indices\nend_header\n"
         "0 0 0\n1 0 0\n0 1 0\n4000000000 0 1 2\n",
         "element face 0: truncated: a list of 4000000000 items"},
        {"ply\nformat binary_little_endian 1.0\n" + vertex + "element face 1\nproperty list uchar int vertex_indices\n"
         "end_header\n" + std::string(36, '\xff'),
         "element face 0"},
        {"ply\nformat ascii 1.0\n" + vertex + "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
         "0 0 0\n1 0 0\n0 1 0\n3 0 1 -5\n",
         "vertex index"},
        {"ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\n" + vertex + "end_header\n3 0 1 2\n0 0 0\n1 0 0\n0 1 0\n",
         "before element vertex"},
    };
    int i = 0;
    for (const auto& [text, what] : cases) {
        const std::string f = write_file("hostile" + std::to_string(i++) + ".ply", text);
        require_error(error_of([&] { load_mesh(f); }), f, what);
    }
    // an element without properties takes no bytes: a huge count is read in no time (it hung)
    const std::string empty_element = write_file("empty_element.ply", "ply\nformat ascii 1.0\nelement comment_block 47777777776\n" +
                                                                          vertex + "element face 1\nproperty list uchar int vertex_indices\n"
                                                                          "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    CHECK(load_mesh(empty_element).triangles.size() == 1);  // before the fix: a loop of 4.8·10¹⁰ entries
    const std::string other = write_file("mesh.stl", "solid x\nendsolid x\n");  // only OBJ reaches Assimp
    require_error(error_of([&] { load_mesh(other); }), other, "unknown mesh format");
}

TEST_CASE("hostile input: OBJ files are parsed from memory, every index checked", "[hostile][mesh]") {
    const std::string fifo = test::temp_dir() + "/materials.fifo";
    std::filesystem::remove(fifo);
    REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
    const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    // mtllib is never opened (a FIFO would block); the mesh still loads
    Mesh m = load_mesh(write_file("mtllib.obj", "mtllib " + fifo + "\n" + tri + "f 1 2 3\n"));
    CHECK(m.triangles.size() == 1);
    std::string big_face = tri + "f";
    for (int i = 0; i < 300; ++i) big_face += " " + std::to_string(1 + i % 3);
    const std::vector<std::pair<std::string, std::string>> cases = {
        {tri + "f 1 2 3 9\n", "vertex index out of range"},     // a quad with a bad corner (skipped silently before)
        {tri + "f -7 1 2\n", "vertex index out of range"},
        {tri + "f 1 2 99999999999999999999\n", "line 4: face index does not fit"},  // atoi would make it -1
        {big_face + "\n", "more than 255 corners"},
        {tri, "no triangles"},
    };
    int i = 0;
    for (const auto& c : cases) {
        const std::string f = write_file("hostile" + std::to_string(i++) + ".obj", c.first);
        require_error(error_of([&] { load_mesh(f); }), f, c.second);
    }
}

TEST_CASE("hostile input: outputs are committed together or not at all", "[hostile]") {
    namespace fs = std::filesystem;
    const fs::path dir = fs::path(test::temp_dir()) / "outputs";
    fs::remove_all(dir);
    fs::create_directories(dir);
    const auto write = [](const std::string& path) { std::ofstream(path) << "data"; };
    {  // an error before the commit: nothing at the final names, no staged file
        detail::StagedOutputs outputs;
        outputs.write((dir / "a.png").string(), write);
        CHECK_THROWS_AS(outputs.write((dir / "b.json").string(), [](const std::string&) { throw Error("x: failed"); }), Error);
    }
    CHECK(fs::is_empty(dir));
    {  // a rename that fails in the commit takes back the ones before it
        detail::StagedOutputs outputs;
        outputs.write((dir / "a.png").string(), write);
        outputs.write((dir / "b.json").string(), write);
        fs::create_directories(dir / "b.json" / "child");  // b.json became a non-empty folder
        const std::string message = error_of([&] { outputs.commit(); });
        CHECK(message.rfind((dir / "b.json").string() + ": cannot write", 0) == 0);
    }
    CHECK_FALSE(fs::exists(dir / "a.png"));
    CHECK(std::distance(fs::directory_iterator(dir), fs::directory_iterator()) == 1);  // only the folder b.json
    fs::remove_all(dir / "b.json");
    {  // errors name the final path, not the staged one
        detail::StagedOutputs outputs;
        const std::string message =
            error_of([&] { outputs.write((dir / "c.exr").string(), [](const std::string& p) { throw Error(p + ": disk full"); }); });
        CHECK(message == (dir / "c.exr").string() + ": disk full");
        // ... also where a writer's own temporary (NAME.part.ext) or a library's bare file name is quoted
        const std::string quoted = error_of([&] {
            outputs.write((dir / "d.exr").string(), [](const std::string& p) {
                throw Error(p + ": cannot write image (Could not open \"" + p + ".part.exr\": \"" +
                            fs::path(p).filename().string() + "\" is read-only)");
            });
        });
        CHECK(quoted == (dir / "d.exr").string() + ": cannot write image (Could not open \"" + (dir / "d.exr").string() +
                            "\": \"d.exr\" is read-only)");
    }
    {
        detail::StagedOutputs outputs;
        outputs.write((dir / "c.exr").string(), write);
        outputs.commit();
    }
    CHECK(fs::exists(dir / "c.exr"));
}

// Issue 25 item 3: every buffer is checked against the device's largest allocation and its global
// memory before the implementation sees it (PoCL asserted, aborting the process, on oversized ones).
TEST_CASE("hostile input: a buffer over the device's limits is one line naming what needed it", "[hostile]") {
    host::Runtime& runtime = test::context().runtime();
    const DeviceInfo& device = runtime.info();
    REQUIRE(device.max_allocation_bytes > 0);
    REQUIRE(device.max_allocation_bytes <= device.global_memory_bytes);
    const std::size_t too_big = std::size_t(device.max_allocation_bytes) + 1;
    const std::string message = error_of([&] { host::make_buffer(runtime, CL_MEM_READ_WRITE, too_big, nullptr, "test nodes"); });
    INFO(message);
    CHECK(message.rfind("test nodes: needs ", 0) == 0);
    CHECK(message.find("the device allows") != std::string::npos);
    CHECK(message.find("CL_DEVICE_MAX_MEM_ALLOC_SIZE") != std::string::npos);
    const std::string over_memory =
        error_of([&] { host::check_allocation(runtime, device.global_memory_bytes + 1, "test volume"); });
    CHECK(over_memory.rfind("test volume: needs ", 0) == 0);
    CHECK_NOTHROW(host::make_buffer(runtime, CL_MEM_READ_WRITE, 1 << 20, nullptr, "test small"));
}

// Issue 25 item 4: scenes built in code obey the rules scene files do, checked at every render by
// the same functions the loader uses (sombra/scene.h volume_problem, light_problem); a step of 0
// used to hang the camera pass, a NaN intensity or a 90° cone rendered.
TEST_CASE("hostile input: scenes built in code are held to the scene file rules at render", "[hostile]") {
    Scene good;
    VolumeInstance vi;
    vi.volume = test::constant_volume({4, 4, 4}, 1.f);
    vi.transfer_function = test::constant_tf(0.1f);
    vi.transform = make_transform({0, 0, 0}, {0, 0, 0}, {0.1f, 0.1f, 0.1f});
    good.volumes.push_back(vi);
    good.lights.push_back(Light{});
    good.width = good.height = 8;
    CHECK_NOTHROW(render(test::context(), good));
    const auto render_error = [](const Scene& scene) { return error_of([&] { render(test::context(), scene); }); };
    Scene s = good;
    s.volumes[0].step_voxels = 0.f;
    CHECK_THAT(render_error(s), Catch::Contains("volumes[0].step_voxels: must lie in [0.01, 16]"));
    s = good;
    s.volumes[0].spacing[1] = std::nanf("");
    CHECK_THAT(render_error(s), Catch::Contains("volumes[0].spacing"));
    s = good;
    s.lights[0].intensity = std::nanf("");
    CHECK_THAT(render_error(s), Catch::Contains("lights[0].intensity: must be ≥ 0"));
    s = good;
    s.lights[0].type = LightType::Spot;
    s.lights[0].cone_angle_deg = 90.f;
    CHECK_THAT(render_error(s), Catch::Contains("lights[0].cone_angle_deg: must lie in (0, 90)"));
    s = good;
    s.lights[0].type = LightType::Point;
    s.lights[0].att_constant = 0.f;
    CHECK_THAT(render_error(s), Catch::Contains("lights[0].attenuation"));
}

// Issue 25 items 1 and 2: OpenVDB and DICOM files are walked by us before the library reads them.
// The inputs (fuzz/make_regressions.py) each crashed, aborted or allocated gigabytes before: a
// leaf chunk longer than the leaf (heap overflow, glibc abort), names and metadata strings of 512 MiB
// (3.2 GB and 1.7 GB resident), two active voxels densified to 2.2 GB, a DICOM length of 2 GiB
// (2.2 GB), compressed pixel data (GDCM's codecs assert), pixel data shorter than the image (loaded);
// a half-float grid whose "is_saved_as_half_float" metadata was renamed, so that OpenVDB reads full
// floats where the walk read halves and allocated a chunk of 96 GiB (found by CI's fuzzing).
TEST_CASE("hostile input: VDB and DICOM files are walked before OpenVDB and GDCM read them", "[hostile][vdb][dicom]") {
    const struct { const char* file; const char* field; } cases[] = {
        {"vdb/leaf-chunk-overflow.vdb", "grid 'density': chunk size: an uncompressed chunk of 4096 bytes where the node holds 2048"},
        {"vdb/name-512mib.vdb", "grid name: a length of 536870912 bytes"},
        {"vdb/metadata-512mib.vdb", "grid 'density': metadata 'class': needs 536870912 bytes"},
        {"vdb/sparse-two-voxels.vdb", "grid 'density': its active box holds 545338513 voxels for 2 active ones"},
        {"vdb/unaligned-root-child.vdb", "root child origin: not a multiple of 4096"},
        {"vdb/bool-grid.vdb", "type: 'Tree_bool_5_4_3'"},
        {"vdb/half-float-meta-renamed.vdb", "grid 'density': chunk: needs 103079215112 bytes"},
        {"dicom/length-2gib.dcm", "(0008,0060): a length of 2147483648 bytes"},
        {"dicom/jpeg-garbage.dcm", "(0002,0010) TransferSyntaxUID: '1.2.840.10008.1.2.4.50' (compressed"},
        {"dicom/jpeg2000-garbage.dcm", "sombra reads uncompressed DICOM only"},
        {"dicom/short-pixels.dcm", "(7FE0,0010) PixelData: 4 bytes, the image needs 24"},
    };
    for (const auto& c : cases) {
        const std::string f = test::data_path(std::string("../tests/fuzz-regressions/") + c.file);
        INFO(f);
        require_error(error_of([&] { load_volume(f); }), f, c.field);
    }
}
