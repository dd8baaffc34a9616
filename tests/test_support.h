// sombra tests — shared helpers: one OpenCL context per process, small scenes, image metrics.
#pragma once
#include <array>
#include <memory>
#include <string>

#include "sombra/sombra.h"

namespace sombra::test {

Context& context();  // one per test process (DESIGN.md: tests share one context)

struct ImageDifference {
    double max_abs = 0, mean_abs = 0;
    std::size_t non_finite = 0;
};
ImageDifference compare(const Image& a, const Image& b);  // over RGB

// Small procedural scenes for kernel-vs-reference comparisons.
Scene sphere_scene(int size = 24);                 // one sphere, one directional light
Scene overlapping_scene();                          // two rotated/scaled overlapping volumes, 3 light types
TransferFunction ramp_tf(float lo, float hi, float max_alpha);
std::shared_ptr<const Volume> constant_volume(std::array<int, 3> dims, float value);  // every voxel `value`
TransferFunction constant_tf(float alpha);  // the same opacity α for every value

std::string temp_dir();  // fresh folder under /tmp for this process
std::string data_path(const std::string& relative);  // data/… of the source tree

}  // namespace sombra::test
