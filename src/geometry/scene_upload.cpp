#include "geometry/scene_upload.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <glm/glm.hpp>

#include "geometry/surfaces.h"
#include "math_constants.h"
#include "sombra/error.h"

namespace sombra::packing {
namespace {

glm::mat4 from_row_major(const std::array<float, 16>& m) {
    glm::mat4 out;
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) out[c][r] = m[std::size_t(r * 4 + c)];
    return out;
}

cl_float4 f4(float x, float y, float z, float w = 0.f) {
    cl_float4 v;
    v.s[0] = x, v.s[1] = y, v.s[2] = z, v.s[3] = w;
    return v;
}
cl_float4 f4(const Vec3& v, float w = 0.f) { return f4(v[0], v[1], v[2], w); }

// The prefix integrals F[i] = ∫₀ⁱ σ du of a transfer-function table (σ linear between entries,
// trapezoids summed in double) for pre-integration (cl/volume_sample.h preintegrated_sigma),
// appended to the buffer as (hi, lo) float pairs, F = hi + lo; g.tf_integral_offset in floats.
void append_sigma_prefix(const std::vector<std::array<float, 4>>& table, VolumeGpu& g, std::vector<cl_float4>& tables) {
    std::vector<float> pairs;
    double prefix = 0;
    for (std::size_t i = 0; i < table.size(); ++i) {
        if (i > 0) prefix += 0.5 * (double(table[i - 1][3]) + double(table[i][3]));
        float hi = float(prefix);
        pairs.push_back(hi);
        pairs.push_back(float(prefix - double(hi)));
    }
    pairs.resize((pairs.size() + 3) / 4 * 4, 0.f);
    g.tf_integral_offset = cl_uint(4 * tables.size());
    for (std::size_t i = 0; i < pairs.size(); i += 4) tables.push_back(f4(pairs[i], pairs[i + 1], pairs[i + 2], pairs[i + 3]));
}

Vec3 normalized(Vec3 v) {
    float len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    return {v[0] / len, v[1] / len, v[2] / len};
}
Vec3 cross(const Vec3& a, const Vec3& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

}  // namespace

BrickRanges compute_brick_ranges(const Volume& volume) {
    BrickRanges r;
    for (int a = 0; a < 3; ++a) r.brick_dims[a] = (volume.dims[a] + SOMBRA_BRICK_SIZE - 1) / SOMBRA_BRICK_SIZE;
    std::size_t count = std::size_t(r.brick_dims[0]) * r.brick_dims[1] * r.brick_dims[2];
    r.min.assign(count, INFINITY);
    r.max.assign(count, -INFINITY);
    // A voxel on a brick boundary (index a multiple of SOMBRA_BRICK_SIZE) also belongs to the brick before it.
    auto bricks_of = [](int i, int n_bricks, int out[2]) {
        int b = std::min(i / SOMBRA_BRICK_SIZE, n_bricks - 1), k = 0;
        out[k++] = b;
        if (i % SOMBRA_BRICK_SIZE == 0 && b > 0) out[k++] = b - 1;
        return k;
    };
    for (int z = 0; z < volume.dims[2]; ++z) {
        int bz[2], nz = bricks_of(z, r.brick_dims[2], bz);
        for (int y = 0; y < volume.dims[1]; ++y) {
            int by[2], ny = bricks_of(y, r.brick_dims[1], by);
            for (int x = 0; x < volume.dims[0]; ++x) {
                int bx[2], nx = bricks_of(x, r.brick_dims[0], bx);
                float v = volume.at(x, y, z);
                for (int k = 0; k < nz; ++k)
                    for (int j = 0; j < ny; ++j)
                        for (int i = 0; i < nx; ++i) {
                            std::size_t b = std::size_t(bx[i]) + std::size_t(r.brick_dims[0]) * (by[j] + std::size_t(r.brick_dims[1]) * bz[k]);
                            r.min[b] = std::min(r.min[b], v);
                            r.max[b] = std::max(r.max[b], v);
                        }
            }
        }
    }
    return r;
}

std::vector<cl_uchar> brick_distances(const std::vector<cl_uchar>& occupied, const std::array<int, 3>& brick_dims) {
    constexpr int kFar = 127;
    const int nx = brick_dims[0], ny = brick_dims[1], nz = brick_dims[2];
    // Chebyshev distance to the nearest brick whose flag is `kind`: two chamfer passes over the
    // 26 neighbours at distance 1, exact for this metric (forward: the 13 neighbours before a
    // brick in x-fastest order; backward: the 13 after it)
    auto distance_to = [&](cl_uchar kind) {
        std::vector<int> d(occupied.size());
        for (std::size_t b = 0; b < occupied.size(); ++b) d[b] = (occupied[b] != 0) == (kind != 0) ? 0 : kFar;
        auto at = [&](int x, int y, int z) -> int& { return d[std::size_t(x) + std::size_t(nx) * (std::size_t(y) + std::size_t(ny) * std::size_t(z))]; };
        for (int sign : {-1, 1})
            for (int zi = 0; zi < nz; ++zi)
                for (int yi = 0; yi < ny; ++yi)
                    for (int xi = 0; xi < nx; ++xi) {
                        const int x = sign < 0 ? xi : nx - 1 - xi, y = sign < 0 ? yi : ny - 1 - yi, z = sign < 0 ? zi : nz - 1 - zi;
                        int& here = at(x, y, z);
                        for (int dz = -1; dz <= 1; ++dz)
                            for (int dy = -1; dy <= 1; ++dy)
                                for (int dx = -1; dx <= 1; ++dx) {
                                    if ((dx + 3 * (dy + 3 * dz)) * sign <= 0) continue;  // not visited yet in this pass
                                    const int qx = x + dx, qy = y + dy, qz = z + dz;
                                    if (qx < 0 || qy < 0 || qz < 0 || qx >= nx || qy >= ny || qz >= nz) continue;
                                    here = std::min(here, at(qx, qy, qz) + 1);
                                }
                    }
        return d;
    };
    const std::vector<int> to_occupied = distance_to(1), to_empty = distance_to(0);
    std::vector<cl_uchar> bytes(occupied.size());
    for (std::size_t b = 0; b < occupied.size(); ++b)
        bytes[b] = occupied[b] ? cl_uchar(128 + std::min(to_empty[b], kFar)) : cl_uchar(std::min(to_occupied[b], kFar));
    return bytes;
}

std::vector<LightGpu> pack_lights(const Scene& scene) {
    std::vector<LightGpu> lights;
    for (const Light& l : scene.lights) {
        LightGpu g{};
        g.type = l.type == LightType::Directional ? SOMBRA_LIGHT_DIRECTIONAL
                 : l.type == LightType::Spot      ? SOMBRA_LIGHT_SPOT
                                                  : SOMBRA_LIGHT_POINT;
        g.position = f4(l.position);
        g.direction = f4(normalized(l.direction));
        g.color = f4(l.color[0] * l.intensity, l.color[1] * l.intensity, l.color[2] * l.intensity);
        float half = l.cone_angle_deg * float(kPi) / 180.f;
        g.cos_outer = std::cos(half);
        g.cos_inner = std::cos(half * (1.f - l.cone_softness));
        if (g.cos_inner <= g.cos_outer) g.cos_inner = g.cos_outer + 1e-6f;  // smoothstep needs edge0 < edge1
        g.att_constant = l.att_constant, g.att_linear = l.att_linear, g.att_quadratic = l.att_quadratic;
        lights.push_back(g);
    }
    return lights;
}

std::array<float, 16> voxel_to_world_matrix(const VolumeInstance& vi) {
    const Volume& vol = *vi.volume;
    // voxel → object: centred grid scaled by the spacing; then object → world
    std::array<float, 16> grid{vi.spacing[0], 0, 0, -0.5f * (vol.dims[0] - 1) * vi.spacing[0],
                               0, vi.spacing[1], 0, -0.5f * (vol.dims[1] - 1) * vi.spacing[1],
                               0, 0, vi.spacing[2], -0.5f * (vol.dims[2] - 1) * vi.spacing[2],
                               0, 0, 0, 1};
    glm::mat4 voxel_to_world = from_row_major(vi.transform) * from_row_major(grid);
    std::array<float, 16> m{};
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) m[std::size_t(r * 4 + c)] = voxel_to_world[c][r];
    return m;
}

std::array<float, 16> world_to_voxel_matrix(const VolumeInstance& vi) {
    glm::mat4 world_to_voxel = glm::inverse(from_row_major(voxel_to_world_matrix(vi)));
    std::array<float, 16> m{};
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) m[std::size_t(r * 4 + c)] = world_to_voxel[c][r];
    return m;
}

PackedScene pack_scene(const Scene& scene) {
    PackedScene packed;
    std::size_t data_offset = 0, image_z = 0;
    for (const VolumeInstance& vi : scene.volumes) {
        const Volume& vol = *vi.volume;
        VolumeGpu g{};
        const std::array<float, 16> v2w = voxel_to_world_matrix(vi);
        glm::mat4 voxel_to_world = from_row_major(v2w);
        glm::mat4 world_to_voxel = glm::inverse(voxel_to_world);
        for (int r = 0; r < 3; ++r)
            g.world_to_voxel[r] = f4(world_to_voxel[0][r], world_to_voxel[1][r], world_to_voxel[2][r], world_to_voxel[3][r]);
        packed.voxel_to_world.push_back(v2w);
        float voxel_size = INFINITY;  // smallest world length of one voxel step
        for (int c = 0; c < 3; ++c) voxel_size = std::min(voxel_size, glm::length(glm::vec3(voxel_to_world[c])));
        if (!(voxel_size > 0.f) || !std::isfinite(voxel_size))
            throw Error(scene.source + ": " + vi.name + ".transform: maps the volume to zero size");

        BrickRanges bricks = compute_brick_ranges(vol);
        g.dims = {{vol.dims[0], vol.dims[1], vol.dims[2], 0}};
        // ±FLT_MAX for an unclipped axis: OpenCL's fast-math builds may assume no infinities
        auto finite = [](float f) { return std::clamp(f, -FLT_MAX, FLT_MAX); };
        g.clip_min = f4(finite(vi.clip_min[0]), finite(vi.clip_min[1]), finite(vi.clip_min[2]));
        g.clip_max = f4(finite(vi.clip_max[0]), finite(vi.clip_max[1]), finite(vi.clip_max[2]));
        g.brick_dims = {{bricks.brick_dims[0], bricks.brick_dims[1], bricks.brick_dims[2], 0}};
        g.data_offset = cl_uint(data_offset);
        g.image_z_offset = float(image_z);
        data_offset += vol.voxel_count();
        image_z += std::size_t(vol.dims[2]);
        if (data_offset > 0xffffffffull) throw Error(scene.source + ": volumes: more than 2^32 voxels in all");

        const TransferFunction& tf = vi.transfer_function;
        float opacity_unit = vi.opacity_unit > 0.f ? vi.opacity_unit : voxel_size;
        auto table = tf.table(kTransferTableSize, opacity_unit);
        g.tf_offset = cl_uint(packed.tf_tables.size());
        g.tf_size = cl_uint(table.size());
        g.tf_domain_min = tf.domain_min();
        const double range = double(tf.domain_max()) - tf.domain_min();  // in float it overflows near ±3.4e38
        g.tf_domain_scale = range > 0 ? float(double(table.size() - 1) / range) : 0.f;
        for (auto& e : table) packed.tf_tables.push_back(f4(e[0], e[1], e[2], e[3]));
        append_sigma_prefix(table, g, packed.tf_tables);
        float max_sigma = 0.f;
        for (auto& e : table) max_sigma = std::max(max_sigma, e[3]);
        g.step = vi.step_voxels * voxel_size;
        g.stiff = max_sigma * g.step >= 2.f ? 1u : 0u;  // one step can absorb 86 %: see VolumeGpu.stiff

        // A brick is visible when any table entry its value range touches has σ > 0.
        g.brick_offset = cl_uint(packed.occupancy.size());
        std::vector<cl_uchar> occupied;
        occupied.reserve(bricks.min.size());
        for (std::size_t b = 0; b < bricks.min.size(); ++b) {
            auto index = [&](float value) {
                float u = std::clamp((value - g.tf_domain_min) * g.tf_domain_scale, 0.f, float(table.size() - 1));
                return std::size_t(u);
            };
            std::size_t lo = index(bricks.min[b]), hi = std::min(index(bricks.max[b]) + 1, table.size() - 1);
            bool visible = false;
            for (std::size_t i = lo; i <= hi && !visible; ++i) visible = table[i][3] > 0.f;
            occupied.push_back(visible ? 1 : 0);
        }
        const std::vector<cl_uchar> distances = brick_distances(occupied, bricks.brick_dims);
        packed.occupancy.insert(packed.occupancy.end(), occupied.begin(), occupied.end());
        packed.occupancy.insert(packed.occupancy.end(), distances.begin(), distances.end());

        g.ambient = vi.material.ambient, g.diffuse = vi.material.diffuse;
        g.specular = vi.material.specular, g.shininess = vi.material.shininess;
        packed.volumes.push_back(g);
    }
    packed.lights = pack_lights(scene);
    packed.bound_triangles = surfaces::pack_bounds(scene, packed.volumes);
    return packed;
}

CameraGpu pack_camera(const Scene& scene, int width, int height) {
    const Camera& c = scene.camera;
    Vec3 forward = normalized({c.look_at[0] - c.position[0], c.look_at[1] - c.position[1], c.look_at[2] - c.position[2]});
    Vec3 right = normalized(cross(forward, c.up));
    Vec3 up = cross(right, forward);
    float tan_half = std::tan(0.5f * c.fov_y_deg * float(kPi) / 180.f);
    float aspect = float(width) / float(height);
    CameraGpu g{};
    g.position = f4(c.position);
    g.forward = f4(forward);
    g.right = f4(right[0] * tan_half * aspect, right[1] * tan_half * aspect, right[2] * tan_half * aspect);
    g.up = f4(up[0] * tan_half, up[1] * tan_half, up[2] * tan_half);
    g.background = f4(scene.background);
    g.width = cl_uint(width), g.height = cl_uint(height);
    g.first_row = 0, g.row_stride = 1;
    g.first_packet = 0, g.packet_stride = 1;
    g.volume_count = cl_uint(scene.volumes.size());
    g.light_count = cl_uint(scene.lights.size());
    g.ambient_intensity = scene.ambient_intensity;
    return g;
}

DeviceScene upload_scene(host::Runtime& runtime, const Scene& scene, const PackedScene& packed, bool use_images) {
    DeviceScene d;
    d.uses_images = use_images;
    auto ro = CL_MEM_READ_ONLY;
    d.occupancy = host::make_buffer(runtime, ro, packed.occupancy.size(), packed.occupancy.data(), "brick occupancy");
    d.tf_tables = host::make_buffer(runtime, ro, packed.tf_tables.size() * sizeof(cl_float4), packed.tf_tables.data(), "transfer-function tables");
    d.volumes = host::make_buffer(runtime, ro, packed.volumes.size() * sizeof(VolumeGpu), packed.volumes.data(), "volume descriptors");
    d.lights = host::make_buffer(runtime, ro, packed.lights.size() * sizeof(LightGpu), packed.lights.data(), "lights");

    std::size_t total = 0, max_x = 1, max_y = 1, sum_z = 0;
    for (auto& vi : scene.volumes) {
        total += vi.volume->voxel_count();
        max_x = std::max<std::size_t>(max_x, std::size_t(vi.volume->dims[0]));
        max_y = std::max<std::size_t>(max_y, std::size_t(vi.volume->dims[1]));
        sum_z += std::size_t(vi.volume->dims[2]);
    }
    cl::Event event;
    if (!use_images) {
        d.voxel_buffer = host::make_buffer(runtime, ro, total * sizeof(float), nullptr, scene.source + ": volumes: voxels");
        std::size_t offset = 0;
        for (auto& vi : scene.volumes) {
            runtime.queue().enqueueWriteBuffer(d.voxel_buffer, CL_TRUE, offset * sizeof(float),
                                               vi.volume->voxel_count() * sizeof(float), vi.volume->voxels.data(), nullptr, &event);
            d.upload_ms += host::Runtime::event_ms(event);
            offset += vi.volume->voxel_count();
        }
        return d;
    }
    auto& dev = runtime.device();
    if (!dev.getInfo<CL_DEVICE_IMAGE_SUPPORT>())
        throw Error("--volume-storage image: " + runtime.info().name + " has no image support");
    if (max_x > dev.getInfo<CL_DEVICE_IMAGE3D_MAX_WIDTH>() || max_y > dev.getInfo<CL_DEVICE_IMAGE3D_MAX_HEIGHT>() ||
        sum_z > dev.getInfo<CL_DEVICE_IMAGE3D_MAX_DEPTH>())
        throw Error("--volume-storage image: volumes (" + std::to_string(max_x) + "×" + std::to_string(max_y) + "×" +
                    std::to_string(sum_z) + " stacked) exceed the device's 3D image limits; use buffer storage");
    host::check_allocation(runtime, std::uint64_t(max_x) * max_y * sum_z * sizeof(float), "volume voxels (3D image)");
    try {
        d.voxel_image = cl::Image3D(runtime.context(), ro, cl::ImageFormat(CL_R, CL_FLOAT), max_x, max_y, sum_z);
    } catch (const cl::Error& e) {
        throw Error("volume voxels: cannot allocate a " + std::to_string(max_x) + "×" + std::to_string(max_y) + "×" +
                    std::to_string(sum_z) + " float image on " + runtime.info().name + " (error " + std::to_string(e.err()) + ")");
    }
    // Zero the padding: the linear filter reads one texel past a volume's edge with weight 0,
    // and 0 · NaN from uninitialised memory would still be NaN.
    runtime.queue().enqueueFillImage(d.voxel_image, cl_float4{{0.f, 0.f, 0.f, 0.f}}, {0, 0, 0}, {max_x, max_y, sum_z},
                                     nullptr, &event);
    event.wait();
    d.upload_ms += host::Runtime::event_ms(event);
    std::size_t z = 0;
    for (auto& vi : scene.volumes) {
        const Volume& v = *vi.volume;
        runtime.queue().enqueueWriteImage(d.voxel_image, CL_TRUE, {0, 0, z},
                                          {std::size_t(v.dims[0]), std::size_t(v.dims[1]), std::size_t(v.dims[2])},
                                          std::size_t(v.dims[0]) * sizeof(float),
                                          std::size_t(v.dims[0]) * std::size_t(v.dims[1]) * sizeof(float),
                                          v.voxels.data(), nullptr, &event);
        d.upload_ms += host::Runtime::event_ms(event);
        z += std::size_t(v.dims[2]);
    }
    return d;
}

}  // namespace sombra::packing
