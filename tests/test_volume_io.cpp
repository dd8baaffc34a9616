// Volume readers, the NIfTI writer and the procedural generators.
//
// Expected voxel values of the real files were read independently with Python's struct, gzip
// and zipfile modules (x fastest: index = x + nx * (y + ny * z)).
#include "sombra/error.h"
#include "sombra/volume.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <unistd.h>

#include "test_support.h"

namespace fs = std::filesystem;
using sombra::load_volume;
using sombra::Volume;
using Bytes = std::vector<unsigned char>;

namespace {

std::string data_file(const std::string& name) { return std::string(SOMBRA_DATA_DIR) + "/volumes/" + name; }

Bytes read_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return Bytes(std::istreambuf_iterator<char>(in), {});
}

void write_bytes(const std::string& path, const Bytes& bytes) {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

Bytes text_bytes(const std::string& s) { return Bytes(s.begin(), s.end()); }
Bytes operator+(Bytes a, const Bytes& b) { a.insert(a.end(), b.begin(), b.end()); return a; }
Bytes head(const Bytes& b, std::size_t n) { return Bytes(b.begin(), b.begin() + std::ptrdiff_t(n)); }

// Values as bytes of type T in little or big byte order.
template <typename T>
Bytes encode(const std::vector<double>& values, bool big_endian = false) {
    Bytes out;
    for (double v : values) {
        const T t = static_cast<T>(v);
        unsigned char b[sizeof(T)];
        std::memcpy(b, &t, sizeof(T));  // the test host is little-endian (x86-64 / arm64)
        if (big_endian) std::reverse(b, b + sizeof(T));
        out.insert(out.end(), b, b + sizeof(T));
    }
    return out;
}

// 2 x 3 x 4 test values, x fastest.
std::vector<double> ramp() {
    std::vector<double> v;
    for (int i = 0; i < 24; ++i) v.push_back(i * 3 - 20);
    return v;
}

// A fresh temporary folder, removed with its contents at the end of the test.
struct TempDir {
    fs::path dir;
    TempDir() {
        static int counter = 0;
        dir = fs::temp_directory_path() /
              ("sombra_volume_io_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
        fs::remove_all(dir);
        fs::create_directories(dir);
    }
    ~TempDir() { fs::remove_all(dir); }
    std::string file(const std::string& name, const Bytes& bytes) const {
        const std::string path = (dir / name).string();
        write_bytes(path, bytes);
        return path;
    }
    std::string path(const std::string& name) const { return (dir / name).string(); }
};

using sombra::test::error_of;

// The load must fail with one line "FILE: ... FIELD: what" naming the file and the field.
// named_file: the file the message starts with, when not `path` itself (an archive member).
void require_load_error(const std::string& path, const std::string& field, const std::string& what = "",
                        const std::string& named_file = "") {
    const std::string message = error_of([&] { load_volume(path); });
    INFO(message);
    CHECK(message.rfind((named_file.empty() ? path : named_file) + ": ", 0) == 0);
    CHECK(message.find(field + ": ") != std::string::npos);
    CHECK(message.find(what) != std::string::npos);
    CHECK(message.find('\n') == std::string::npos);
}

// .npy bytes, version 1, for a dict with the given parts.
Bytes npy(const std::string& descr, const std::string& shape, const Bytes& payload,
          const std::string& fortran = "False") {
    std::string dict = "{'descr': '" + descr + "', 'fortran_order': " + fortran + ", 'shape': " + shape + ", }";
    while ((10 + dict.size() + 1) % 64 != 0) dict += ' ';
    dict += '\n';
    Bytes out = {0x93, 'N', 'U', 'M', 'P', 'Y', 1, 0, static_cast<unsigned char>(dict.size() & 0xff),
                 static_cast<unsigned char>(dict.size() >> 8)};
    return out + text_bytes(dict) + payload;
}

// A zip archive with stored (uncompressed) members.
Bytes stored_zip(const std::vector<std::pair<std::string, Bytes>>& members) {
    const auto crc32 = [](const Bytes& b) {
        std::uint32_t c = 0xffffffffU;
        for (unsigned char byte : b) {
            c ^= byte;
            for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320U & (0U - (c & 1U)));
        }
        return ~c;
    };
    Bytes out, central;
    for (const auto& [name, data] : members) {
        const std::uint32_t offset = std::uint32_t(out.size()), size = std::uint32_t(data.size());
        const Bytes common = encode<std::uint16_t>({20, 0, 0, 0, 0}) + encode<std::uint32_t>({double(crc32(data)), double(size), double(size)}) +
                             encode<std::uint16_t>({double(name.size()), 0});
        out = out + encode<std::uint32_t>({0x04034b50}) + common + text_bytes(name) + data;
        central = central + encode<std::uint32_t>({0x02014b50}) + encode<std::uint16_t>({20}) + common +
                  encode<std::uint16_t>({0, 0, 0}) + encode<std::uint32_t>({0, double(offset)}) + text_bytes(name);
    }
    const double n = double(members.size());
    const Bytes end = encode<std::uint32_t>({0x06054b50}) + encode<std::uint16_t>({0, 0, n, n}) +
                      encode<std::uint32_t>({double(central.size()), double(out.size())}) + encode<std::uint16_t>({0});
    return out + central + end;
}

std::string raw_json(const std::string& body) { return "{\"raw\": \"v.raw\", " + body + "}"; }

void check_ramp(const Volume& v) {
    REQUIRE(v.dims == std::array<int, 3>{2, 3, 4});
    CHECK(v.at(0, 0, 0) == -20.f);
    CHECK(v.at(1, 0, 0) == -17.f);
    CHECK(v.at(0, 1, 0) == -14.f);
    CHECK(v.at(1, 2, 3) == 49.f);
    CHECK(v.value_min == -20.f);
    CHECK(v.value_max == 49.f);
}

}  // namespace

TEST_CASE("real volumes load with the right dims, spacing, range and voxels", "[volume_io]") {
    sombra::VolumeLoadReport report;
    SECTION("stent.npz (int16 CT)") {
        const Volume v = load_volume(data_file("stent.npz"), {}, &report);
        CHECK(report.format == "npz");
        CHECK(v.dims == std::array<int, 3>{128, 128, 256});
        CHECK(v.value_min == 0.f);
        CHECK(v.value_max == 2000.f);
        CHECK(v.at(40, 80, 50) == 312.f);
        CHECK(v.at(76, 67, 46) == 2000.f);
        CHECK(v.at(33, 92, 42) == 250.f);
        CHECK(v.source == data_file("stent.npz"));
    }
    SECTION("brainsmall.den (uint8 MRI)") {
        const Volume v = load_volume(data_file("brainsmall.den"), {}, &report);
        CHECK(report.format == "den");
        CHECK(v.dims == std::array<int, 3>{128, 128, 84});
        CHECK(v.value_min == 0.f);
        CHECK(v.value_max == 202.f);
        CHECK(v.at(0, 0, 0) == 2.f);
        CHECK(v.at(64, 64, 42) == 65.f);
    }
    SECTION("skull_2.9.inr (float32 CT)") {
        const Volume v = load_volume(data_file("skull_2.9.inr"), {}, &report);
        CHECK(report.format == "inr");
        CHECK(v.dims == std::array<int, 3>{64, 64, 64});
        CHECK(v.spacing[0] == Approx(3.94305f));
        CHECK(v.spacing[1] == Approx(3.94305f));
        CHECK(v.spacing[2] == Approx(3.65079f));
        CHECK(v.value_max == 5.428802490234375f);
        CHECK(v.value_min == Approx(0.f).margin(1e-9));
        CHECK(v.at(32, 32, 32) == 1.360255479812622f);
        CHECK(v.at(10, 40, 50) == 0.4570293128490448f);
    }
    SECTION("heart.vtk (ASCII float)") {
        const Volume v = load_volume(data_file("heart.vtk"), {}, &report);
        CHECK(report.format == "vtk");
        CHECK(v.dims == std::array<int, 3>{32, 32, 12});
        CHECK(v.spacing == std::array<float, 3>{1.f, 1.f, 4.f});
        CHECK(v.value_min == 0.f);
        CHECK(v.value_max == 255.f);
        CHECK(v.at(0, 0, 0) == 16.f);
        CHECK(v.at(16, 16, 6) == 85.f);
        CHECK(v.at(5, 20, 3) == 105.f);
        CHECK(v.at(31, 31, 11) == 18.f);
    }
    SECTION("ch2.nii.gz (uint8 MRI, gzipped NIfTI-1)") {
        const Volume v = load_volume(data_file("ch2.nii.gz"), {}, &report);
        CHECK(report.format == "nifti");
        CHECK(v.dims == std::array<int, 3>{181, 217, 181});
        CHECK(v.spacing == std::array<float, 3>{1.f, 1.f, 1.f});
        CHECK(v.value_min == 0.f);
        CHECK(v.value_max == 254.f);
        CHECK(v.at(90, 108, 90) == 33.f);
        CHECK(v.at(50, 150, 120) == 80.f);
    }
    SECTION("cloud_shape_128.json (raw uint8)") {
        const Volume v = load_volume(data_file("cloud_shape_128.json"), {}, &report);
        CHECK(report.format == "raw");
        CHECK(v.dims == std::array<int, 3>{128, 128, 128});
        CHECK(v.value_min == 112.f);
        CHECK(v.value_max == 253.f);
        CHECK(v.at(0, 0, 0) == 154.f);
        CHECK(v.at(64, 64, 64) == 238.f);
        CHECK(v.at(127, 0, 5) == 181.f);
    }
    CHECK(report.non_finite_replaced == 0);
}

TEST_CASE("extensions are matched case-insensitively — unknown or missing files fail cleanly", "[volume_io]") {
    TempDir tmp;
    const std::string upper = tmp.file("HEART.VTK", read_bytes(data_file("heart.vtk")));
    CHECK(load_volume(upper).dims == std::array<int, 3>{32, 32, 12});

    const std::string unknown = tmp.file("volume.xyz", Bytes(16, 0));
    const std::string message = error_of([&] { load_volume(unknown); });
    CHECK(message.rfind(unknown + ": ", 0) == 0);
    CHECK(message.find("unknown volume format") != std::string::npos);

    for (const char* name : {"missing.nii", "missing.nii.gz", "missing.npy", "missing.npz", "missing.den",
                             "missing.inr", "missing.vtk", "missing.json"}) {
        const std::string m = error_of([&] { load_volume(tmp.path(name)); });
        INFO(m);
        CHECK(m.rfind(tmp.path(name) + ": ", 0) == 0);
        CHECK(m.find('\n') == std::string::npos);
    }
}

TEST_CASE("parts: npy and raw files read a box of voxels alone, other formats crop, and a box outside is an error", "[volume_io]") {
    TempDir tmp;
    std::vector<double> values;  // v(x, y, z) = x + 10 y + 100 z on 5 × 4 × 3
    for (int z = 0; z < 3; ++z)
        for (int y = 0; y < 4; ++y)
            for (int x = 0; x < 5; ++x) values.push_back(x + 10 * y + 100 * z);
    const std::string npy_path = tmp.file("v.npy", npy(">i2", "(3, 4, 5)", encode<std::int16_t>(values, true)));
    tmp.file("v.raw", Bytes(7, 0xee) + encode<std::uint16_t>(values));
    const std::string raw_path = tmp.file("v.json", text_bytes(raw_json(R"("dims": [5, 4, 3], "type": "uint16", "header_bytes": 7, "spacing": [1, 2, 3])")));
    const sombra::VoxelBox box{{1, 1, 0}, {3, 2, 2}};
    for (const std::string& path : {npy_path, raw_path, data_file("heart.vtk")}) {
        INFO(path);
        const Volume whole = load_volume(path);
        sombra::VolumeLoadOptions header;
        header.header_only = true;
        const Volume h = load_volume(path, header);
        const bool parted = path != data_file("heart.vtk");  // legacy VTK has no parts: read whole
        CHECK(h.header_only == parted);
        CHECK(h.dims == whole.dims);
        CHECK(h.spacing == whole.spacing);
        CHECK(h.voxels.size() == (parted ? 0 : whole.voxel_count()));
        sombra::VolumeLoadOptions part;
        part.read_part = true;
        part.part = box;
        const Volume p = load_volume(path, part);
        REQUIRE(p.dims == std::array<int, 3>{3, 2, 3});
        for (int z = 0; z < 3; ++z)
            for (int y = 0; y < 2; ++y)
                for (int x = 0; x < 3; ++x) CHECK(p.at(x, y, z) == whole.at(x + 1, y + 1, z));
        part.part.last[0] = whole.dims[0];  // one past the end
        CHECK_THAT(error_of([&] { load_volume(path, part); }), Catch::Contains(path) && Catch::Contains("part: "));
    }
    // the header's size check still holds: a truncated .npy fails before any part is read
    const Bytes full = read_bytes(npy_path);
    const std::string cut = tmp.file("cut.npy", head(full, full.size() - 2));
    sombra::VolumeLoadOptions header;
    header.header_only = true;
    CHECK_THAT(error_of([&] { load_volume(cut, header); }), Catch::Contains("cut.npy: data: "));
}

TEST_CASE("npy: dtypes and byte orders — npz with one stored member", "[volume_io]") {
    TempDir tmp;
    check_ramp(load_volume(tmp.file("a.npy", npy("<i2", "(4, 3, 2)", encode<std::int16_t>(ramp())))));
    check_ramp(load_volume(tmp.file("b.npy", npy(">f8", "(4, 3, 2)", encode<double>(ramp(), true)))));
    check_ramp(load_volume(tmp.file("c.npy", npy("<i4", "(4, 3, 2)", encode<std::int32_t>(ramp())))));
    check_ramp(load_volume(tmp.file("d.npz", stored_zip({{"arr_0.npy", npy("<f4", "(4, 3, 2)", encode<float>(ramp()))}}))));
    const Volume u8 = load_volume(tmp.file("e.npy", npy("|u1", "(4, 3, 2)", Bytes(24, 200))));
    CHECK(u8.value_min == 200.f);
    CHECK(u8.value_max == 200.f);
}

TEST_CASE("npy / npz: corrupt files name the file and the field", "[volume_io]") {
    TempDir tmp;
    const Bytes good = encode<std::int16_t>(ramp());
    require_load_error(tmp.file("short.npy", npy("<i2", "(4, 3, 2)", head(good, 40))), "data", "truncated");
    require_load_error(tmp.file("long.npy", npy("<i2", "(4, 3, 2)", good + Bytes(6, 0))), "data", "has 6 extra bytes");
    require_load_error(tmp.file("fortran.npy", npy("<i2", "(4, 3, 2)", good, "True")), "fortran_order");
    require_load_error(tmp.file("complex.npy", npy("<c8", "(4, 3, 2)", good)), "descr");
    require_load_error(tmp.file("flat.npy", npy("<i2", "(24,)", good)), "shape");
    require_load_error(tmp.file("zero.npy", npy("<i2", "(0, 3, 2)", {})), "dims");
    require_load_error(tmp.file("magic.npy", text_bytes("NUMPY but not really")), "magic");
    require_load_error(tmp.file("hdr.npy", head(npy("<i2", "(4, 3, 2)", good), 40)), "header");

    const Bytes member = npy("<i2", "(4, 3, 2)", good);
    require_load_error(tmp.file("two.npz", stored_zip({{"a.npy", member}, {"b.npy", member}})), "members",
                       "found 2");
    require_load_error(tmp.file("none.npz", stored_zip({{"a.txt", member}})), "members");
    const std::string inner = tmp.file("inner.npz", stored_zip({{"arr_0.npy", npy("<i2", "(4, 3, 2)", head(good, 10))}}));
    require_load_error(inner, "data", "truncated", inner + ":arr_0.npy");  // the member is named after the archive
    const Bytes stent = read_bytes(data_file("stent.npz"));
    require_load_error(tmp.file("cut.npz", head(stent, stent.size() / 2)), "archive");
}

TEST_CASE("den: corrupt headers and payloads", "[volume_io]") {
    TempDir tmp;
    const Bytes real = read_bytes(data_file("brainsmall.den"));
    require_load_error(tmp.file("cut.den", head(real, real.size() - 1000)), "data", "truncated");
    require_load_error(tmp.file("long.den", real + Bytes(3, 0)), "data", "has 3 extra bytes");
    require_load_error(tmp.file("header.den", head(real, 30)), "header", "truncated");

    Bytes wrong_dims = real;
    wrong_dims[50] = 129;  // map x size 129 no longer matches the map length
    require_load_error(tmp.file("dims.den", wrong_dims), "map_length");

    Bytes zero = real;
    for (std::size_t i = 50; i < 62; ++i) zero[i] = 0;  // dims 0 x 0 x 0, map length 0
    require_load_error(tmp.file("zero.den", head(zero, 62)), "dims", "empty volume");

    Bytes version = real;
    version[0] = 7;
    require_load_error(tmp.file("version.den", version), "version");
}

namespace {
Bytes inr(const std::string& keys, const Bytes& payload) {
    std::string header = "#INRIMAGE-4#{\n" + keys;
    header.resize(252, '\n');
    return text_bytes(header + "##}\n") + payload;
}
}  // namespace

TEST_CASE("inr: types, byte orders and corrupt files", "[volume_io]") {
    TempDir tmp;
    const std::string dims = "XDIM=2\nYDIM=3\nZDIM=4\nVDIM=1\n";
    const Volume big = load_volume(tmp.file("big.inr", inr(dims + "TYPE=signed fixed\nPIXSIZE=16 bits\nCPU=sun\nVX=0.5\n",
                                                            encode<std::int16_t>(ramp(), true))));
    check_ramp(big);
    CHECK(big.spacing == std::array<float, 3>{0.5f, 1.f, 1.f});

    const Bytes good = encode<float>(ramp());
    const std::string f32 = dims + "TYPE=float\nPIXSIZE=32 bits\nCPU=decm\n";
    check_ramp(load_volume(tmp.file("ok.inr", inr(f32, good))));
    require_load_error(tmp.file("cut.inr", inr(f32, head(good, 90))), "data", "truncated");
    require_load_error(tmp.file("zero.inr", inr("XDIM=0\nYDIM=3\nZDIM=4\nTYPE=float\nPIXSIZE=32 bits\nCPU=decm\n", {})),
                       "dims");
    require_load_error(tmp.file("nox.inr", inr("YDIM=3\nZDIM=4\nTYPE=float\nPIXSIZE=32 bits\nCPU=decm\n", good)), "XDIM");
    require_load_error(tmp.file("type.inr", inr(dims + "TYPE=complex\nPIXSIZE=32 bits\nCPU=decm\n", good)), "TYPE");
    require_load_error(tmp.file("cpu.inr", inr(dims + "TYPE=float\nPIXSIZE=32 bits\nCPU=vax\n", good)), "CPU");
    Bytes unpadded = inr(f32, good);
    unpadded.erase(unpadded.begin() + 100);  // header now 255 bytes
    require_load_error(tmp.file("pad.inr", unpadded), "header", "multiple of 256");
    const Bytes real = read_bytes(data_file("skull_2.9.inr"));
    require_load_error(tmp.file("skull_cut.inr", head(real, real.size() - 4)), "data", "truncated");
}

TEST_CASE("vtk: ASCII and big-endian BINARY, corrupt files", "[volume_io]") {
    TempDir tmp;
    const auto vtk = [](const std::string& mode, const std::string& dims, const std::string& points,
                        const std::string& type) {
        return "# vtk DataFile Version 3.0\ntest\n" + mode + "\nDATASET STRUCTURED_POINTS\nDIMENSIONS " + dims +
               "\nASPECT_RATIO 1 2 3\nORIGIN 0 0 0\nPOINT_DATA " + points + "\nSCALARS v " + type +
               " 1\nLOOKUP_TABLE default\n";
    };
    const Volume binary = load_volume(tmp.file("b.vtk", text_bytes(vtk("BINARY", "2 3 4", "24", "short")) +
                                                            encode<std::int16_t>(ramp(), true) + text_bytes("\n")));
    check_ramp(binary);
    CHECK(binary.spacing == std::array<float, 3>{1.f, 2.f, 3.f});
    std::string values;
    for (double v : ramp()) values += std::to_string(v) + (v > 0 ? "\n" : " ");
    check_ramp(load_volume(tmp.file("a.vtk", text_bytes(vtk("ASCII", "2 3 4", "24", "double") + values))));

    require_load_error(tmp.file("bcut.vtk", text_bytes(vtk("BINARY", "2 3 4", "24", "short")) +
                                                encode<std::int16_t>({1, 2, 3}, true)),
                       "data", "truncated");
    require_load_error(tmp.file("acut.vtk", text_bytes(vtk("ASCII", "2 3 4", "24", "float") + "1 2 3\n")), "data",
                       "truncated: 24 ASCII values need at least 47 bytes, found 6");
    require_load_error(tmp.file("acut2.vtk", text_bytes(vtk("ASCII", "2 3 4", "24", "float") + values.substr(0, 70))),
                       "data", "expected 24 values, found 7");
    require_load_error(tmp.file("nan_text.vtk", text_bytes(vtk("ASCII", "2 3 4", "24", "float") + "1 x " + values)),
                       "data", "not a number");
    require_load_error(tmp.file("points.vtk", text_bytes(vtk("ASCII", "2 3 4", "23", "float") + values)), "POINT_DATA");
    require_load_error(tmp.file("zero.vtk", text_bytes(vtk("ASCII", "2 0 4", "0", "float"))), "dims");
    require_load_error(tmp.file("type.vtk", text_bytes(vtk("ASCII", "2 3 4", "24", "bit") + values)), "SCALARS");
    require_load_error(tmp.file("dimtext.vtk", text_bytes(vtk("ASCII", "2 three 4", "24", "float") + values)),
                       "DIMENSIONS");
    const Bytes real = read_bytes(data_file("heart.vtk"));
    require_load_error(tmp.file("heart_cut.vtk", head(real, real.size() / 2)), "data", "expected 12288 values");
}

TEST_CASE("raw + JSON header: types, endianness, header_bytes and corrupt headers", "[volume_io]") {
    TempDir tmp;
    tmp.file("v.raw", Bytes(3, 0xee) + encode<std::int16_t>(ramp(), true));  // 3 bytes to skip, then data
    const Volume loaded = load_volume(tmp.file("u.json", text_bytes(raw_json(
        "\"dims\": [2, 3, 4], \"type\": \"int16\", \"endian\": \"big\", \"header_bytes\": 3, \"spacing\": [1, 2, 0.5]"))));
    check_ramp(loaded);
    CHECK(loaded.spacing == std::array<float, 3>{1.f, 2.f, 0.5f});

    const std::string ok = "\"dims\": [2, 3, 4], \"type\": \"int16\", \"endian\": \"big\", \"header_bytes\": 3";
    require_load_error(tmp.file("k.json", text_bytes(raw_json(ok + ", \"colour\": 1"))), "colour", "unknown key");
    require_load_error(tmp.file("d.json", text_bytes(raw_json("\"dims\": \"2x3x4\", \"type\": \"int16\""))), "dims");
    require_load_error(tmp.file("d2.json", text_bytes(raw_json("\"dims\": [2, 3.5, 4], \"type\": \"int16\""))), "dims");
    require_load_error(tmp.file("t.json", text_bytes(raw_json("\"dims\": [2, 3, 4], \"type\": 16"))), "type");
    require_load_error(tmp.file("t2.json", text_bytes(raw_json("\"dims\": [2, 3, 4], \"type\": \"int12\""))), "type");
    require_load_error(tmp.file("e.json", text_bytes(raw_json(ok + ", \"endian\": \"middle\""))), "endian");
    require_load_error(tmp.file("h.json", text_bytes(raw_json("\"dims\": [2, 3, 4], \"type\": \"int16\", \"header_bytes\": -1"))),
                       "header_bytes");
    require_load_error(tmp.file("s.json", text_bytes(raw_json(ok + ", \"spacing\": [1, 0, 1]"))), "spacing");
    require_load_error(tmp.file("z.json", text_bytes(raw_json("\"dims\": [2, 0, 4], \"type\": \"int16\""))), "dims");
    require_load_error(tmp.file("m.json", text_bytes("{\"dims\": [2, 3, 4], \"type\": \"int16\"}")), "raw", "missing");
    require_load_error(tmp.file("j.json", text_bytes("{\"raw\": \"v.raw\", ")), "json");
    require_load_error(tmp.file("short.json", text_bytes(raw_json("\"dims\": [2, 3, 5], \"type\": \"int16\", \"header_bytes\": 3"))),
                       "raw", "truncated");
    require_load_error(tmp.file("long.json", text_bytes(raw_json("\"dims\": [2, 3, 4], \"type\": \"uint8\""))), "raw",
                       "has 27 extra bytes");
    require_load_error(tmp.file("nofile.json", text_bytes("{\"raw\": \"nothing.raw\", \"dims\": [1, 1, 1], \"type\": \"uint8\"}")),
                       "raw", "nothing.raw");
}

TEST_CASE("NaN / Inf voxels: rejected by default, replaced by 0 when asked", "[volume_io]") {
    TempDir tmp;
    std::vector<double> values = ramp();
    values[1] = std::numeric_limits<double>::quiet_NaN();
    values[5] = std::numeric_limits<double>::infinity();
    values[23] = -std::numeric_limits<double>::infinity();
    tmp.file("v.raw", encode<float>(values));
    const std::string path = tmp.file("nan.json", text_bytes(raw_json("\"dims\": [2, 3, 4], \"type\": \"float32\"")));

    require_load_error(path, "voxels", "3 non-finite voxels (NaN/Inf)");

    sombra::VolumeLoadOptions sanitize;
    sanitize.non_finite = sombra::NonFinitePolicy::Sanitize;
    sombra::VolumeLoadReport report;
    const Volume v = load_volume(path, sanitize, &report);
    CHECK(report.non_finite_replaced == 3);
    CHECK(v.voxels[1] == 0.f);
    CHECK(v.voxels[5] == 0.f);
    CHECK(v.voxels[23] == 0.f);
    CHECK(v.at(0, 0, 0) == -20.f);
    CHECK(v.value_min == -20.f);
    CHECK(v.value_max == 46.f);

    tmp.file("n.npy", npy("<f8", "(4, 3, 2)", encode<double>(values)));  // the same policy for every reader
    require_load_error(tmp.path("n.npy"), "voxels", "3 non-finite");

    // NIfTI too (niftiio's own loader would silently turn NaN into 0).
    Volume nan_volume = sombra::make_sphere(4);
    nan_volume.voxels[7] = std::numeric_limits<float>::quiet_NaN();
    sombra::save_volume_nifti(nan_volume, tmp.path("nan.nii.gz"));
    require_load_error(tmp.path("nan.nii.gz"), "voxels", "1 non-finite");
    CHECK(load_volume(tmp.path("nan.nii.gz"), sanitize, &report).voxels[7] == 0.f);
    CHECK(report.non_finite_replaced == 1);
}

TEST_CASE("save_volume_nifti round-trips through load_volume", "[volume_io]") {
    TempDir tmp;
    Volume v;
    v.dims = {5, 6, 7};
    v.spacing = {0.5f, 2.f, 3.25f};
    for (std::size_t i = 0; i < v.voxel_count(); ++i) v.voxels.push_back(std::sin(float(i)) * 100.f);
    v.update_range();
    for (const char* name : {"round.nii", "round.nii.gz"}) {
        sombra::save_volume_nifti(v, tmp.path(name));
        sombra::VolumeLoadReport report;
        const Volume back = load_volume(tmp.path(name), {}, &report);
        CHECK(report.format == "nifti");
        CHECK(back.dims == v.dims);
        CHECK(back.spacing == v.spacing);
        CHECK(back.voxels == v.voxels);
        CHECK(back.value_min == v.value_min);
        CHECK(back.value_max == v.value_max);
    }

    Volume bad = v;
    bad.voxels.pop_back();
    const std::string message = error_of([&] { sombra::save_volume_nifti(bad, tmp.path("bad.nii")); });
    CHECK(message.rfind(tmp.path("bad.nii") + ": voxels: ", 0) == 0);
    CHECK_FALSE(fs::exists(tmp.path("bad.nii")));
}

TEST_CASE("nifti: truncated and malformed files", "[volume_io]") {
    TempDir tmp;
    const Volume blobs = sombra::make_gaussian_blobs(16, 3, 1);
    sombra::save_volume_nifti(blobs, tmp.path("full.nii"));
    const Bytes full = read_bytes(tmp.path("full.nii"));
    REQUIRE(full.size() == 352 + 16 * 16 * 16 * 4);
    require_load_error(tmp.file("cut.nii", head(full, full.size() - 100)), "data", "truncated");
    require_load_error(tmp.file("header.nii", head(full, 200)), "header");
    require_load_error(tmp.file("junk.nii", Bytes(1000, 7)), "magic");

    Bytes zero = full;  // dim[2] = 0
    zero[44] = zero[45] = 0;
    require_load_error(tmp.file("zero.nii", zero), "dims", "empty volume");  // niftiio alone would read 16 x 1 x 16

    Bytes four_d = full;  // dim[0] = 4, dim[4] = 2: two frames
    four_d[40] = 4;
    four_d[48] = 2;
    require_load_error(tmp.file("4d.nii", four_d), "dim");

    const Bytes real = read_bytes(data_file("ch2.nii.gz"));
    require_load_error(tmp.file("ch2_cut.nii.gz", head(real, real.size() / 2)), "data", "truncated");
}

TEST_CASE("procedural generators: dims, ranges, determinism", "[volume_io]") {
    const auto in_unit_range = [](const Volume& v) {
        for (float x : v.voxels)
            if (!(x >= 0.f && x <= 1.f)) return false;
        return v.value_min >= 0.f && v.value_max <= 1.f;
    };

    const Volume sphere = sombra::make_sphere(32);
    CHECK(sphere.dims == std::array<int, 3>{32, 32, 32});
    CHECK(sphere.source == "make_sphere");
    CHECK(sphere.spacing == std::array<float, 3>{1.f, 1.f, 1.f});
    CHECK(in_unit_range(sphere));
    CHECK(sphere.at(16, 16, 16) == 1.f);
    CHECK(sphere.at(0, 0, 0) == 0.f);
    double filled = 0;
    for (float x : sphere.voxels) filled += x;
    CHECK(filled / sphere.voxel_count() == Approx(4.0 / 3.0 * 3.14159265358979 * 0.4 * 0.4 * 0.4).epsilon(0.05));

    const Volume slab = sombra::make_slab(8, 2, 0.25f, 0.5f, 0.5f);
    CHECK(slab.source == "make_slab");
    for (int z = 0; z < 8; ++z) CHECK(slab.at(3, 4, z) == (z == 2 || z == 3 ? 0.5f : 0.f));
    CHECK(slab.value_max == 0.5f);
    CHECK_THROWS_AS(sombra::make_slab(8, 3, 0.f, 1.f), sombra::Error);
    CHECK_THROWS_AS(sombra::make_sphere(0), sombra::Error);

    const Volume blobs = sombra::make_gaussian_blobs(24, 5, 42);
    CHECK(blobs.source == "make_gaussian_blobs");
    CHECK(in_unit_range(blobs));
    CHECK(blobs.value_max > 0.5f);
    CHECK(sombra::make_gaussian_blobs(24, 5, 42).voxels == blobs.voxels);
    CHECK(sombra::make_gaussian_blobs(24, 5, 43).voxels != blobs.voxels);

    const Volume cloud = sombra::make_cloud_noise(32, 7);
    CHECK(cloud.source == "make_cloud_noise");
    CHECK(cloud.dims == std::array<int, 3>{32, 32, 32});
    CHECK(in_unit_range(cloud));
    CHECK(cloud.value_max > 0.3f);
    CHECK(cloud.at(0, 0, 0) == 0.f);  // the soft ball leaves the corners empty
    CHECK(sombra::make_cloud_noise(32, 7).voxels == cloud.voxels);
    CHECK(sombra::make_cloud_noise(32, 8).voxels != cloud.voxels);

    const Volume steam = sombra::make_steam_plume(32, 5);
    CHECK(steam.source == "make_steam_plume");
    CHECK(in_unit_range(steam));
    CHECK(steam.value_max > 0.3f);
    CHECK(sombra::make_steam_plume(32, 5).voxels == steam.voxels);
    CHECK(sombra::make_steam_plume(32, 6).voxels != steam.voxels);
    // a plume: narrow at the bottom, wider higher up, faded out at the top, no mass in the corners
    const auto slice = [&](int z, bool outer) {  // mass of slice z off the axis (r > 0.2) or near it
        double sum = 0;
        for (int y = 0; y < 32; ++y)
            for (int x = 0; x < 32; ++x) {
                double dx = (x + 0.5) / 32 - 0.5, dy = (y + 0.5) / 32 - 0.5;
                if ((dx * dx + dy * dy > 0.04) == outer) sum += steam.at(x, y, z);
            }
        return sum;
    };
    CHECK(slice(4, false) > 0.);
    CHECK(slice(4, true) < 0.05 * slice(4, false));
    CHECK(slice(22, true) > 4 * slice(4, true));
    CHECK(slice(31, false) + slice(31, true) < 0.02 * (slice(16, false) + slice(16, true)));
    CHECK(steam.at(0, 0, 16) == 0.f);
}
