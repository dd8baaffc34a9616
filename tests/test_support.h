// sombra tests — shared helpers: one OpenCL context per process, small scenes, image metrics.
#pragma once
#include <array>
#include <catch2/catch.hpp>
#include <memory>
#include <string>

#include "sombra/sombra.h"

namespace sombra::test {

std::string device_selector();  // the suite's device: SOMBRA_DEVICE, else "cpu" (a --device value)
Context& context();  // one per test process (docs/architecture.md: tests share one context)

struct ImageDifference {
    double max_abs = 0, mean_abs = 0;
    std::size_t non_finite = 0;
};
ImageDifference compare(const Image& a, const Image& b);  // over RGB

// Small procedural scenes for kernel-vs-reference comparisons.
// The camera pass alone, as the references without shadow rays compute it: RenderOptions{} with
// no shadow technique (RenderOptions' own default is deep shadow maps).
RenderOptions unshadowed();
Scene sphere_scene(int size = 24);                 // one sphere, one directional light
Scene overlapping_scene();                          // two rotated/scaled overlapping volumes, 3 light types
TransferFunction ramp_tf(float lo, float hi, float max_alpha);
// A mesh of data/ scaled to unit size, centred at the origin, then rotated (degrees about x, y, z).
MeshInstance centred_mesh(const std::string& data_file, const Vec3& rotate_deg);
// A square of side 2·half in the plane z = z0, facing +z, of the given opacity and colour.
MeshInstance quad(float half, float z0, float opacity, Vec3 color = {0.8f, 0.8f, 0.8f});
Camera mesh_camera();  // looks at the origin from about 1.9 away; a unit-size mesh fills much of it
std::shared_ptr<const Volume> constant_volume(std::array<int, 3> dims, float value);  // every voxel `value`
TransferFunction constant_tf(float alpha);  // the same opacity α for every value

std::string temp_dir();  // a fresh folder under /tmp of this process alone, removed when it exits

// The message of the sombra::Error `f` throws; a Catch2 failure when it throws nothing or
// anything else.
template <typename F>
std::string error_of(F&& f) {
    try {
        f();
    } catch (const Error& e) {
        return e.what();
    } catch (const std::exception& e) {
        FAIL("not a sombra::Error: " << e.what());
    }
    FAIL("no sombra::Error thrown");
    return {};
}
std::string data_path(const std::string& relative);  // data/… of the source tree

// `sombra ARGS` (the built CLI, through the shell): its exit code (−1: killed), stdout and stderr.
struct CliOutput {
    int exit_code;
    std::string out, err;
};
CliOutput run_cli_output(const std::string& args);

}  // namespace sombra::test
