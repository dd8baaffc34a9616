// sombra — procedural volumes for tests and small scenes. Deterministic on every platform: the
// random numbers come from a fixed integer hash, not from <random>'s distributions.
#include "sombra/error.h"
#include "sombra/limits.h"
#include "sombra/volume.h"

#include <algorithm>
#include <cmath>

namespace sombra {
namespace {

Volume empty_cube(const char* name, int n) {
    if (n < 1 || n > limits::kMaxGeneratorSize)
        throw file_error(name, "n", "grid size must lie in [1, " + std::to_string(limits::kMaxGeneratorSize) + "], got " +
                                        std::to_string(n));
    Volume v;
    v.dims = {n, n, n};
    v.voxels.assign(std::size_t(n) * n * n, 0.f);
    v.source = name;
    v.stored_type = "float32";
    return v;
}

// Calls f(x, y, z, position) for every voxel; position is the voxel centre in [0, 1]³.
template <typename F>
void for_each_voxel(Volume& v, F f) {
    const int n = v.dims[0];
    std::size_t i = 0;
    for (int z = 0; z < n; ++z)
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x, ++i)
                v.voxels[i] = f((x + 0.5f) / n, (y + 0.5f) / n, (z + 0.5f) / n);
}

std::uint32_t hash(std::uint32_t a) {  // integer finaliser (lowbias32)
    a ^= a >> 16; a *= 0x7feb352dU; a ^= a >> 15; a *= 0x846ca68bU; a ^= a >> 16;
    return a;
}
float unit(std::uint32_t h) { return float(h >> 8) * (1.f / 16777216.f); }  // [0, 1)

float lattice(int x, int y, int z, std::uint32_t seed) {
    return unit(hash(std::uint32_t(x) * 0x8da6b343U ^ hash(std::uint32_t(y) * 0xd8163841U ^
                                                           hash(std::uint32_t(z) * 0xcb1ab31fU ^ seed))));
}

float value_noise(float x, float y, float z, std::uint32_t seed) {  // trilinear, smoothstep-weighted
    const int ix = int(std::floor(x)), iy = int(std::floor(y)), iz = int(std::floor(z));
    const auto smooth = [](float t) { return t * t * (3.f - 2.f * t); };
    const float fx = smooth(x - ix), fy = smooth(y - iy), fz = smooth(z - iz);
    const auto lerp = [](float a, float b, float t) { return a + (b - a) * t; };
    float c[2][2];
    for (int dz = 0; dz < 2; ++dz)
        for (int dy = 0; dy < 2; ++dy)
            c[dz][dy] = lerp(lattice(ix, iy + dy, iz + dz, seed), lattice(ix + 1, iy + dy, iz + dz, seed), fx);
    return lerp(lerp(c[0][0], c[0][1], fy), lerp(c[1][0], c[1][1], fy), fz);
}

// Five octaves of value noise at (x, y, z) ∈ [0, 1]³ (base frequency 4), normalised to [0, 1].
float fractal_noise(float x, float y, float z, std::uint32_t seed) {
    constexpr int kOctaves = 5;
    float sum = 0.f, amplitude = 0.5f, norm = 0.f, frequency = 4.f;
    for (int o = 0; o < kOctaves; ++o, amplitude *= 0.5f, frequency *= 2.f) {
        sum += amplitude * value_noise(x * frequency, y * frequency, z * frequency, seed + 7919U * o);
        norm += amplitude;
    }
    return sum / norm;
}

// 0 at edge0, 1 at edge1, smooth (Hermite) in between; edge0 > edge1 gives a falling edge.
float smoothstep(float edge0, float edge1, float x) {
    const float t = std::clamp((x - edge0) / (edge1 - edge0), 0.f, 1.f);
    return t * t * (3.f - 2.f * t);
}

}  // namespace

Volume make_sphere(int n, float radius_fraction, float density) {
    Volume v = empty_cube("make_sphere", n);
    const float r2 = radius_fraction * radius_fraction;
    for_each_voxel(v, [&](float x, float y, float z) {
        const float dx = x - 0.5f, dy = y - 0.5f, dz = z - 0.5f;
        return dx * dx + dy * dy + dz * dz <= r2 ? density : 0.f;
    });
    v.update_range();
    return v;
}

Volume make_slab(int n, int axis, float lo_fraction, float hi_fraction, float density) {
    if (axis < 0 || axis > 2) throw file_error("make_slab", "axis", "must be 0, 1 or 2, got " + std::to_string(axis));
    Volume v = empty_cube("make_slab", n);
    for_each_voxel(v, [&](float x, float y, float z) {
        const float t = axis == 0 ? x : axis == 1 ? y : z;
        return t >= lo_fraction && t < hi_fraction ? density : 0.f;
    });
    v.update_range();
    return v;
}

Volume make_gaussian_blobs(int n, int blob_count, std::uint32_t seed) {
    if (blob_count < 1 || blob_count > limits::kMaxGeneratorBlobs)
        throw file_error("make_gaussian_blobs", "blob_count",
                         "must lie in [1, " + std::to_string(limits::kMaxGeneratorBlobs) + "]");
    Volume v = empty_cube("make_gaussian_blobs", n);
    struct Blob { float x, y, z, inv2s2, weight; };
    std::vector<Blob> blobs;
    std::uint32_t state = hash(seed ^ 0x9e3779b9U);
    const auto next = [&] { return unit(state = hash(state + 0x9e3779b9U)); };
    for (int b = 0; b < blob_count; ++b) {
        const float x = 0.2f + 0.6f * next(), y = 0.2f + 0.6f * next(), z = 0.2f + 0.6f * next();
        const float sigma = 0.05f + 0.1f * next();
        blobs.push_back({x, y, z, 1.f / (2.f * sigma * sigma), 0.5f + 0.5f * next()});
    }
    for_each_voxel(v, [&](float x, float y, float z) {
        float sum = 0.f;
        for (const Blob& b : blobs) {
            const float dx = x - b.x, dy = y - b.y, dz = z - b.z;
            sum += b.weight * std::exp(-(dx * dx + dy * dy + dz * dz) * b.inv2s2);
        }
        return sum;
    });
    v.update_range();
    if (v.value_max > 1.f)  // overlapping blobs: scale back into [0, 1]
        for (float& value : v.voxels) value /= v.value_max;
    v.update_range();
    return v;
}

Volume make_cloud_noise(int n, std::uint32_t seed) {
    Volume v = empty_cube("make_cloud_noise", n);
    for_each_voxel(v, [&](float x, float y, float z) {
        const float r = 2.f * std::sqrt((x - .5f) * (x - .5f) + (y - .5f) * (y - .5f) + (z - .5f) * (z - .5f));
        const float falloff = smoothstep(1.f, 0.5f, r);  // 1 inside r < 0.5, 0 at r >= 1
        return std::clamp((fractal_noise(x, y, z, seed) - 0.3f) / 0.7f, 0.f, 1.f) * falloff;
    });
    v.update_range();
    return v;
}

Volume make_steam_plume(int n, std::uint32_t seed) {
    Volume v = empty_cube("make_steam_plume", n);
    // the plume's axis drifts and sways with height h = z; its radius grows from 0.1 to 0.42
    const float phase = 6.2831853f * unit(hash(seed ^ 0x51ed270bU));
    for_each_voxel(v, [&](float x, float y, float h) {
        const float sway = 0.08f * h * h;
        const float cx = 0.5f + sway * std::sin(7.f * h + phase), cy = 0.5f + sway * std::cos(5.f * h + phase);
        const float radius = 0.1f + 0.32f * h;
        // the noise rises with the plume (stretched along z) and is warped sideways with height
        const float noise = fractal_noise(1.6f * x + 0.3f * h, 1.6f * y, 0.8f * h, seed);
        const float r = std::sqrt((x - cx) * (x - cx) + (y - cy) * (y - cy)) / radius;
        const float mask = smoothstep(1.f, 0.3f, r + 1.2f * (noise - 0.5f)) * smoothstep(0.f, 0.08f, h) *
                           smoothstep(1.f, 0.45f, h);  // wisps at the edge; a soft start, fading out at the top
        return std::clamp((noise - 0.3f) / 0.45f, 0.f, 1.f) * mask;
    });
    v.update_range();
    return v;
}

}  // namespace sombra
