// sombra tests — plain C++ reference of the camera pass (render.cl), in double precision.
// Written from the papers and the README's conventions, not from the kernel: it evaluates the
// transfer function directly (no table), inverts transforms itself and never skips bricks.
#pragma once
#include "sombra/render.h"
#include "sombra/scene.h"

#include <vector>

namespace sombra::reference {

struct ReferenceOptions {
    bool sobel = false;
    double termination_transmittance = 1e-3;
    unsigned jitter_seed = 1;
    bool shadow_rays = false;  // shadow term by marching to each light (else 1)
};

Image render_reference(const Scene& scene, int width, int height, const ReferenceOptions& options = {});

// The visibility function sampled along a ray as the DSM build kernel samples it (same segments,
// steps and jitter): (t, accumulated opacity α, Knecht Eq. 3.2) per sample, in double, until
// the transmittance falls below `stop_transmittance`.
struct VisibilitySample {
    double t, alpha;
};
std::vector<VisibilitySample> visibility_samples(const Scene& scene, const Vec3& origin, const Vec3& dir, double jitter,
                                                 double stop_transmittance = 1e-4);

// Extinction σ (per world unit) at world point p: the sum over the volumes whose box
// [−0.5, dims − 0.5] (voxel space) holds p, the transfer function evaluated directly.
double extinction_at_point(const Scene& scene, const Vec3& p);

// Optical depth ∫σ of the segment from a to b (world points) as cl/sat_build.cl integrates a cell:
// each volume's part inside its box in equal steps of at most its ray step, each pre-integrated
// between the values at its ends, split first at the voxel-centre planes when the volume is stiff
// (as the shadow rays integrate), in double.
double segment_optical_depth(const Scene& scene, const Vec3& a, const Vec3& b);

// Trilinear density at a continuous voxel position, clamped to the edge (for unit tests).
double sample_trilinear(const Volume& volume, double x, double y, double z);

}  // namespace sombra::reference
