// sombra bench — the camera pass of cl/render.cl in native C++. Compiled with -ffast-math (see
// CMakeLists.txt) so that `omp simd` loops may call glibc's vector expf/powf (libmvec); the ray
// traversal lives in native_traversal.cpp, compiled without it.
#include "native_camera_pass.h"

#include <algorithm>
#include <atomic>
#include <memory>
#include <thread>

#include "native_shading.h"
#include "shared/hash.h"
#include "sombra/error.h"

namespace sombra::bench {
namespace {

// ---------------------------------------------------------------------------------------------
// Shared by both variants

// The scene as the per-sample code reads it: views into a NativeScene.
struct SceneView {
    TraversalScene traversal;
    std::vector<VolumeView> volumes;
    std::vector<LightView> lights;
    CameraGpu camera;
};

SceneView make_view(const NativeScene& scene) {
    SceneView s;
    s.camera = scene.camera;
    s.traversal = {scene.packed.volumes.data(), unsigned(scene.packed.volumes.size()), scene.packed.occupancy.data(),
                   scene.skip_empty};
    for (const VolumeGpu& g : scene.packed.volumes) {
        s.volumes.push_back({scene.voxels.data() + g.data_offset, g.dims.s[0], g.dims.s[1], g.dims.s[2],
                             scene.tf.data() + 4 * std::size_t(g.tf_offset), scene.tf.data() + g.tf_integral_offset,
                             int(g.tf_size), g.tf_domain_min,
                             g.tf_domain_scale, xyz(g.world_to_voxel[0]), xyz(g.world_to_voxel[1]),
                             xyz(g.world_to_voxel[2]), g.ambient, g.diffuse, g.specular, g.shininess});
    }
    for (const LightGpu& l : scene.packed.lights) {
        s.lights.push_back({int(l.type), xyz(l.position), xyz(l.direction), xyz(l.color), l.cos_outer, l.cos_inner,
                            l.att_constant, l.att_linear, l.att_quadratic});
    }
    return s;
}

// Pixels handed out in chunks of consecutive pixels (rows, top first) through one atomic counter,
// so that threads balance themselves.
class PixelQueue {
public:
    struct Cursor {
        unsigned next = 0, end = 0;
    };
    explicit PixelQueue(unsigned total) : total_(total) {}
    bool pop(Cursor& c, unsigned& pixel) {
        if (c.next == c.end) {
            unsigned begin = next_.fetch_add(kChunk, std::memory_order_relaxed);
            if (begin >= total_) return false;
            c.next = begin, c.end = std::min(begin + kChunk, total_);
        }
        pixel = c.next++;
        return true;
    }

private:
    static constexpr unsigned kChunk = 64;
    std::atomic<unsigned> next_{0};
    unsigned total_;
};

// render_camera(): the ray of a pixel, its jitter from cl/shared/hash.h.
void start_ray(const SceneView& s, unsigned pixel, RayTraversal& ray) {
    unsigned x = pixel % s.camera.width, y = pixel / s.camera.width;
    ray.begin(s.traversal, xyz(s.camera.position), camera_ray_dir(s.camera, x, y),
              sombra_pixel_jitter(x, y, s.camera.jitter_seed));
}

// Final colour: I_acc + t_acc · background; alpha = 1 − t_acc.
void write_pixel(const SceneView& s, unsigned pixel, V3 radiance, float transmittance, float* rgba) {
    V3 c = radiance + transmittance * xyz(s.camera.background);
    float* out = rgba + 4 * std::size_t(pixel);
    out[0] = c.x, out[1] = c.y, out[2] = c.z, out[3] = 1.0f - transmittance;
}

// Front-to-back compositing of the interval a point closes (Knecht Eq. 3.10–3.11, shade_sample()
// of cl/render.cl): α = 1 − exp(−Σσ̄·delta) with σ̄ each volume's pre-integrated extinction,
// I_acc += I_p α t_acc with I_p the σ̄-weighted blend of the colours shaded at the point,
// t_acc *= 1 − α.
struct Composited {
    V3 radiance;
    float transmittance;
};
inline Composited composite(float sigma_sum, V3 color_sum, float delta, V3 radiance, float transmittance) {
    bool hit = sigma_sum > 0.0f;  // no volume has σ̄ > 0 on the interval: nothing changes
    float alpha = hit ? 1.0f - std::exp(-sigma_sum * delta) : 0.0f;
    float weight = hit ? (alpha * transmittance) / sigma_sum : 0.0f;
    return {radiance + weight * color_sum, transmittance * (1.0f - alpha)};
}

template <class Body>
void run_threads(unsigned threads, Body body) {
    std::vector<std::thread> pool;
    for (unsigned i = 0; i < threads; ++i) pool.emplace_back(body);
    for (auto& t : pool) t.join();
}

// ---------------------------------------------------------------------------------------------
// Scalar: one ray at a time, the kernel's control flow verbatim

struct RayAccum {
    V3 radiance{0, 0, 0};
    float transmittance = 1.0f;
    unsigned samples = 0;
    float front[SOMBRA_MAX_VOLUMES] = {};  // each volume's density at the previous point
};

// shade_sample() of cl/render.cl for the point the traversal is at. Returns false when the ray
// terminates (t_acc ≤ threshold).
bool visit_point(const SceneView& s, const RayTraversal& ray, RayAccum& acc) {
    // the light term at the interval's midpoint, as shade_sample() takes it
    V3 p_light = ray.origin + (ray.t - 0.5f * ray.delta) * ray.dir, to_viewer = -ray.dir;
    float sigma_sum = 0.0f;
    V3 color_sum{0, 0, 0};
    for (unsigned i = 0; i < SOMBRA_MAX_VOLUMES; ++i) {
        if (!(ray.active & (1u << i))) continue;
        const VolumeView& v = s.volumes[i];
        V3 pv = ray.vox_origin[i] + ray.t * ray.vox_dir[i];
        float density = sample_density(v, pv);
        acc.samples += 1;
        float sigma = preintegrated_sigma(v, acc.front[i], density);
        acc.front[i] = density;
        if (!(sigma > 0.0f) || !ray.closes_medium()) continue;
        V3 normal = s.lights.empty() ? V3{0, 0, 0} : normal_from_gradient(v, gradient_voxel(v, pv));
        V3 shaded = phong_shade(s.lights.data(), unsigned(s.lights.size()), s.camera.ambient_intensity, v,
                                classify_color(v, density), p_light, normal, to_viewer);
        sigma_sum += sigma;
        color_sum = color_sum + sigma * shaded;
    }
    Composited c = composite(sigma_sum, color_sum, ray.delta, acc.radiance, acc.transmittance);
    acc.radiance = c.radiance, acc.transmittance = c.transmittance;
    return acc.transmittance > s.camera.termination_transmittance;
}

unsigned march_pixel(const SceneView& s, unsigned pixel, float* rgba) {
    RayTraversal ray;
    start_ray(s, pixel, ray);
    RayAccum acc;
    while (ray.next_point(s.traversal))
        if (!visit_point(s, ray, acc)) break;
    write_pixel(s, pixel, acc.radiance, acc.transmittance, rgba);
    return acc.samples;
}

unsigned long long render_scalar_thread(const SceneView& s, PixelQueue& queue, float* rgba) {
    PixelQueue::Cursor cursor;
    unsigned pixel;
    unsigned long long samples = 0;
    while (queue.pop(cursor, pixel)) samples += march_pixel(s, pixel, rgba);
    return samples;
}

// ---------------------------------------------------------------------------------------------
// SIMD: per thread a wavefront of kLanes rays in flight. Each round every ray advances to its next
// point (scalar traversal); the points' densities and pre-integrated σ̄ are then computed, and the
// visible ones classified and shaded, as struct-of-arrays batches in `omp simd` loops (8 lanes per
// AVX2 instruction, gathers for the voxels and tables). Points whose interval has σ̄ = 0 (or is a
// start point or a run of empty bricks) are compacted away before the gradient and Phong, as the
// kernel skips them. A ray that terminates or leaves the volumes hands its lane to the next pixel,
// which keeps the batches full.

constexpr int kLanes = 128;

// The points of one volume in this round, one entry per ray whose segment contains the volume.
struct SampleBatch {
    int count = 0;
    int lane[kLanes];
    float vx[kLanes], vy[kLanes], vz[kLanes];  // voxel position
    float wx[kLanes], wy[kLanes], wz[kLanes];  // world position of the light term: the interval's midpoint
    float ex[kLanes], ey[kLanes], ez[kLanes];  // unit vector to the viewer
    float front[kLanes], density[kLanes];      // density at the previous point and at this one
    float r[kLanes], g[kLanes], b[kLanes], sigma[kLanes];
    float nx[kLanes], ny[kLanes], nz[kLanes];  // normal, facing the viewer
    float sr[kLanes], sg[kLanes], sb[kLanes];  // shaded colour I_p
};

struct Wavefront {
    RayTraversal ray[kLanes];
    int pixel[kLanes];  // -1: idle
    float delta[kLanes];
    float front[kLanes][SOMBRA_MAX_VOLUMES];  // each volume's density at the lane's previous point
    float rad_r[kLanes], rad_g[kLanes], rad_b[kLanes], transmittance[kLanes];
    float sigma_sum[kLanes], col_r[kLanes], col_g[kLanes], col_b[kLanes];
    unsigned samples[kLanes];
    SampleBatch batch;
    unsigned long long finished_samples = 0;
};

void finish_lane(const SceneView& s, Wavefront& w, int l, float* rgba) {
    write_pixel(s, unsigned(w.pixel[l]), {w.rad_r[l], w.rad_g[l], w.rad_b[l]}, w.transmittance[l], rgba);
    w.finished_samples += w.samples[l];
    w.pixel[l] = -1;
}

// Moves every lane to its next point, refilling finished lanes from the queue. False: all idle.
bool advance_lanes(const SceneView& s, PixelQueue& queue, PixelQueue::Cursor& cursor, Wavefront& w, float* rgba) {
    bool any = false;
    for (int l = 0; l < kLanes; ++l) {
        for (;;) {
            if (w.pixel[l] < 0) {
                unsigned pixel;
                if (!queue.pop(cursor, pixel)) break;
                start_ray(s, pixel, w.ray[l]);
                w.pixel[l] = int(pixel);
                w.rad_r[l] = w.rad_g[l] = w.rad_b[l] = 0.0f;
                w.transmittance[l] = 1.0f;
                w.samples[l] = 0;
                std::fill(w.front[l], w.front[l] + SOMBRA_MAX_VOLUMES, 0.0f);
            }
            if (w.ray[l].next_point(s.traversal)) {
                w.delta[l] = w.ray[l].delta;
                any = true;
                break;
            }
            finish_lane(s, w, l, rgba);
        }
    }
    return any;
}

// Fills the batch with this round's points of volume i (positions as in visit_point()).
void gather_samples(Wavefront& w, unsigned i) {
    SampleBatch& b = w.batch;
    b.count = 0;
    for (int l = 0; l < kLanes; ++l) {
        if (w.pixel[l] < 0 || !(w.ray[l].active & (1u << i))) continue;
        const RayTraversal& ray = w.ray[l];
        V3 pv = ray.vox_origin[i] + ray.t * ray.vox_dir[i], p_light = ray.origin + (ray.t - 0.5f * ray.delta) * ray.dir;
        int j = b.count++;
        b.lane[j] = l;
        b.vx[j] = pv.x, b.vy[j] = pv.y, b.vz[j] = pv.z;
        b.wx[j] = p_light.x, b.wy[j] = p_light.y, b.wz[j] = p_light.z;
        b.ex[j] = -ray.dir.x, b.ey[j] = -ray.dir.y, b.ez[j] = -ray.dir.z;
        b.front[j] = w.front[l][i];
        w.samples[l] += 1;  // one per volume per point, as the kernel counts
    }
}

// Density at each point and σ̄ over the interval from the previous point; the density becomes
// the lane's front for its next point.
void sample_batch(const VolumeView& volume, Wavefront& w, unsigned i) {
    const VolumeView v = volume;
    SampleBatch& b = w.batch;
    const int n = b.count;
#pragma omp simd
    for (int j = 0; j < n; ++j) {
        float density = sample_density(v, {b.vx[j], b.vy[j], b.vz[j]});
        b.density[j] = density;
        b.sigma[j] = preintegrated_sigma(v, b.front[j], density);
    }
    for (int j = 0; j < n; ++j) w.front[b.lane[j]][i] = b.density[j];
}

// Keeps the points with σ̄ > 0 on an interval of medium (in order) at the front of the batch;
// returns their count.
int keep_visible(Wavefront& w) {
    SampleBatch& b = w.batch;
    int n = 0;
    for (int j = 0; j < b.count; ++j) {
        if (!(b.sigma[j] > 0.0f) || !w.ray[b.lane[j]].closes_medium()) continue;
        b.lane[n] = b.lane[j];
        b.vx[n] = b.vx[j], b.vy[n] = b.vy[j], b.vz[n] = b.vz[j];
        b.wx[n] = b.wx[j], b.wy[n] = b.wy[j], b.wz[n] = b.wz[j];
        b.ex[n] = b.ex[j], b.ey[n] = b.ey[j], b.ez[n] = b.ez[j];
        b.density[n] = b.density[j], b.sigma[n] = b.sigma[j];
        ++n;
    }
    return n;
}

// The transfer function's colour at each visible point's density.
void classify_batch(const VolumeView& volume, SampleBatch& b, int n) {
    const VolumeView v = volume;
#pragma omp simd
    for (int j = 0; j < n; ++j) {
        V3 c = classify_color(v, b.density[j]);
        b.r[j] = c.x, b.g[j] = c.y, b.b[j] = c.z;
    }
}

// The ambient term of Knecht Eq. 3.9, and (with lights) the normal: gradient → Jᵀ, facing the viewer.
void normals_and_ambient(const VolumeView& volume, float ambient_intensity, bool has_lights, SampleBatch& b, int n) {
    const VolumeView v = volume;
#pragma omp simd
    for (int j = 0; j < n; ++j) {
        V3 ambient = ambient_term(v, ambient_intensity, {b.r[j], b.g[j], b.b[j]});
        b.sr[j] = ambient.x, b.sg[j] = ambient.y, b.sb[j] = ambient.z;
    }
    if (!has_lights) return;
#pragma omp simd
    for (int j = 0; j < n; ++j) {
        V3 gradient = gradient_voxel(v, {b.vx[j], b.vy[j], b.vz[j]});
        b.nx[j] = gradient.x, b.ny[j] = gradient.y, b.nz[j] = gradient.z;
    }
#pragma omp simd
    for (int j = 0; j < n; ++j) {
        V3 normal = face_viewer(normal_from_gradient(v, {b.nx[j], b.ny[j], b.nz[j]}), {b.ex[j], b.ey[j], b.ez[j]});
        b.nx[j] = normal.x, b.ny[j] = normal.y, b.nz[j] = normal.z;
    }
}

// Adds light m's term of Knecht Eq. 3.9 to every sample (the light's type is the same for all).
template <int Type>
void add_light(const LightView& light_in, const VolumeView& volume, SampleBatch& b, int n) {
    const LightView light = light_in;
    const VolumeView v = volume;
#pragma omp simd
    for (int j = 0; j < n; ++j) {
        V3 term = light_term<Type>(light, v, {b.r[j], b.g[j], b.b[j]}, {b.wx[j], b.wy[j], b.wz[j]},
                                   {b.nx[j], b.ny[j], b.nz[j]}, {b.ex[j], b.ey[j], b.ez[j]});
        b.sr[j] += term.x, b.sg[j] += term.y, b.sb[j] += term.z;
    }
}

void shade_batch(const SceneView& s, const VolumeView& v, SampleBatch& b, int n) {
    normals_and_ambient(v, s.camera.ambient_intensity, !s.lights.empty(), b, n);
    for (const LightView& light : s.lights) {
        if (light.type == SOMBRA_LIGHT_DIRECTIONAL) add_light<SOMBRA_LIGHT_DIRECTIONAL>(light, v, b, n);
        else if (light.type == SOMBRA_LIGHT_SPOT) add_light<SOMBRA_LIGHT_SPOT>(light, v, b, n);
        else add_light<SOMBRA_LIGHT_POINT>(light, v, b, n);
    }
}

// visit_point()'s sums over volumes: Σσ̄ and Σσ̄·I_p per lane.
void accumulate(Wavefront& w, int n) {
    const SampleBatch& b = w.batch;
    for (int j = 0; j < n; ++j) {
        int l = b.lane[j];
        w.sigma_sum[l] += b.sigma[j];
        w.col_r[l] += b.sigma[j] * b.sr[j], w.col_g[l] += b.sigma[j] * b.sg[j], w.col_b[l] += b.sigma[j] * b.sb[j];
    }
}

void composite_lanes(Wavefront& w) {
#pragma omp simd
    for (int l = 0; l < kLanes; ++l) {
        Composited c = composite(w.sigma_sum[l], {w.col_r[l], w.col_g[l], w.col_b[l]}, w.delta[l],
                                 {w.rad_r[l], w.rad_g[l], w.rad_b[l]}, w.transmittance[l]);
        w.rad_r[l] = c.radiance.x, w.rad_g[l] = c.radiance.y, w.rad_b[l] = c.radiance.z;
        w.transmittance[l] = c.transmittance;
    }
}

unsigned long long render_simd_thread(const SceneView& s, PixelQueue& queue, float* rgba) {
    auto w = std::make_unique<Wavefront>();
    std::fill(w->pixel, w->pixel + kLanes, -1);
    PixelQueue::Cursor cursor;
    while (advance_lanes(s, queue, cursor, *w, rgba)) {
        std::fill(w->sigma_sum, w->sigma_sum + kLanes, 0.0f);
        std::fill(w->col_r, w->col_r + kLanes, 0.0f);
        std::fill(w->col_g, w->col_g + kLanes, 0.0f);
        std::fill(w->col_b, w->col_b + kLanes, 0.0f);
        for (unsigned i = 0; i < s.volumes.size(); ++i) {
            gather_samples(*w, i);
            sample_batch(s.volumes[i], *w, i);
            int visible = keep_visible(*w);
            classify_batch(s.volumes[i], w->batch, visible);
            shade_batch(s, s.volumes[i], w->batch, visible);
            accumulate(*w, visible);
        }
        composite_lanes(*w);
        for (int l = 0; l < kLanes; ++l)  // early ray termination
            if (w->pixel[l] >= 0 && !(w->transmittance[l] > s.camera.termination_transmittance))
                finish_lane(s, *w, l, rgba);
    }
    return w->finished_samples;
}

}  // namespace

NativeScene make_native_scene(const Scene& scene, const RenderOptions& options) {
    bool bounded = std::any_of(scene.volumes.begin(), scene.volumes.end(),
                               [](const VolumeInstance& vi) { return vi.bound.mesh != nullptr; });
    if (!scene.meshes.empty() || bounded || options.shadows != ShadowTechnique::None ||
        options.shading != ShadingModel::Phong || options.gradient != GradientMethod::CentralDifferences)
        throw Error("native camera pass: only volumes in their boxes, no shadows, Phong with central differences");
    NativeScene n;
    int width = options.width > 0 ? options.width : scene.width;
    int height = options.height > 0 ? options.height : scene.height;
    n.packed = packing::pack_scene(scene);
    n.camera = packing::pack_camera(scene, width, height);
    n.camera.termination_transmittance = options.termination_transmittance;
    n.camera.jitter_seed = options.jitter_seed;
    n.skip_empty = options.empty_space_skipping;
    for (const VolumeInstance& vi : scene.volumes)
        n.voxels.insert(n.voxels.end(), vi.volume->voxels.begin(), vi.volume->voxels.end());
    if (n.voxels.size() >= (1ull << 31)) throw Error("native camera pass: more than 2^31 voxels (32-bit indices)");
    for (const cl_float4& e : n.packed.tf_tables) n.tf.insert(n.tf.end(), e.s, e.s + 4);
    return n;
}

NativeImage render_native(const NativeScene& scene, NativeVariant variant, unsigned threads) {
    SceneView view = make_view(scene);
    unsigned pixels = scene.camera.width * scene.camera.height;
    NativeImage image;
    image.rgba.assign(4 * std::size_t(pixels), 0.0f);
    PixelQueue queue(pixels);
    std::atomic<unsigned long long> samples{0};
    run_threads(std::max(threads, 1u), [&] {
        unsigned long long n = variant == NativeVariant::Simd ? render_simd_thread(view, queue, image.rgba.data())
                                                               : render_scalar_thread(view, queue, image.rgba.data());
        samples += n;
    });
    image.samples = samples;
    return image;
}

}  // namespace sombra::bench
