#include "shadows/sat_update.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <sstream>

#include "shadows/light_reach.h"
#include "sombra/error.h"

namespace sombra::shadows {
namespace {

// FNV-1a over bytes, as 16 hex digits: a short stand-in for bulky key parts (a σ column).
std::string hash_bytes(const void* data, std::size_t size, std::uint64_t h = 1469598103934665603ull) {
    const auto* bytes = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < size; ++i) h = (h ^ bytes[i]) * 1099511628211ull;
    std::ostringstream s;
    s << std::hex << h;
    return s.str();
}

template <typename T>
std::string hash_of(const T& value) {
    return hash_bytes(&value, sizeof(T));
}

// First offset in [0, capacity) where `entries` fit between the `taken` ranges, or capacity.
std::size_t first_fit(std::vector<std::pair<std::size_t, std::size_t>> taken, std::size_t capacity, std::size_t entries) {
    std::sort(taken.begin(), taken.end());
    std::size_t at = 0;
    for (const auto& [offset, size] : taken) {
        if (offset >= at + entries) return at;
        at = std::max(at, offset + size);
    }
    return at + entries <= capacity ? at : capacity;
}

}  // namespace

std::string volume_identity(const Volume& v) {
    std::ostringstream identity;
    identity << static_cast<const void*>(&v);
    return identity.str();
}

std::string volume_data_key(const Volume& v) { return volume_identity(v) + ' ' + volume_sample_key(v); }

double sampled_checksum(const float* values, std::size_t n) {
    double sum = 0;
    for (std::size_t i = 0, stride = std::max<std::size_t>(1, n / 4096); i < n; i += stride) sum += double(values[i]) * double(i % 7919 + 1);
    return sum;
}

std::string volume_sample_key(const Volume& v) {
    std::ostringstream key;
    key.precision(17);
    key << v.dims[0] << ' ' << v.dims[1] << ' ' << v.dims[2];
    key << ' ' << sampled_checksum(v.voxels.data(), v.voxels.size());
    return key.str();
}

std::vector<std::string> extinction_keys(const Scene& scene, const packing::PackedScene& packed, bool use_images) {
    std::vector<std::string> keys;
    for (std::size_t i = 0; i < packed.volumes.size(); ++i) {
        const VolumeGpu& g = packed.volumes[i];
        std::vector<float> sigma;
        for (cl_uint e = 0; e < g.tf_size; ++e) sigma.push_back(packed.tf_tables[g.tf_offset + e].s[3]);
        keys.push_back(volume_data_key(*scene.volumes[i].volume) + ' ' + hash_of(g.world_to_voxel) + ' ' + hash_of(g.dims) + ' ' +
                       hash_of(g.tf_domain_min) + hash_of(g.tf_domain_scale) + ' ' + hash_bytes(sigma.data(), sigma.size() * sizeof(float)) +
                       (use_images ? " image" : " buffer"));
    }
    return keys;
}

DeviceSat update_sats(host::Runtime& runtime, const Scene& scene, const packing::PackedScene& packed,
                      const packing::DeviceScene& device_scene, bool light_aligned, std::size_t max_entries, int lanes,
                      SatPool& pool, SatUpdateCounts& counts, double coarsen) {
    DeviceSat sat = light_aligned ? plan_light_sats(packed, max_entries, coarsen) : plan_volume_sat(packed, max_entries, coarsen);
    sat.lanes = lanes;
    sat.extinction = extinction_keys(scene, packed, device_scene.uses_images);
    const std::vector<std::string>& extinction = sat.extinction;
    std::size_t n = sat_table_count(sat), needed = 0;
    std::vector<std::string> keys(n);
    for (std::size_t t = 0; t < n; ++t) {  // a table depends on the volumes it holds only
        keys[t] = sat_table_geometry_key(sat, t) + " |";
        const cl_uint held = sat_table_volumes(sat, t, extinction.size());
        for (std::size_t v = 0; v < extinction.size(); ++v)
            if (held & (cl_uint(1) << v)) keys[t] += ' ' + std::to_string(v) + ' ' + extinction[v] + ';';
    }

    // the tables whose inputs did not change stay where they are
    std::vector<int> kept(n, -1);
    std::vector<bool> claimed(pool.slots.size(), false);
    std::vector<std::pair<std::size_t, std::size_t>> taken;
    for (std::size_t t = 0; t < n; ++t) {
        needed += sat_table_entries(sat, t);
        for (std::size_t s = 0; s < pool.slots.size() && kept[t] < 0; ++s)
            if (!claimed[s] && pool.slots[s].key == keys[t]) {
                kept[t] = int(s), claimed[s] = true;
                taken.emplace_back(pool.slots[s].offset, pool.slots[s].entries);
            }
    }
    // the others go into the gaps; when they do not fit (or half the buffer would lie idle), a
    // compact buffer takes every table and the kept ones are copied over
    std::vector<std::size_t> offsets(n);
    bool fits = 2 * needed >= pool.capacity;
    for (std::size_t t = 0; t < n && fits; ++t) {
        if (kept[t] >= 0) {
            offsets[t] = pool.slots[std::size_t(kept[t])].offset;
            continue;
        }
        offsets[t] = first_fit(taken, pool.capacity, sat_table_entries(sat, t));
        fits = offsets[t] < pool.capacity;
        taken.emplace_back(offsets[t], sat_table_entries(sat, t));
    }
    if (!fits) {
        if (needed > 0xffffffffull) throw Error("--shadows lowpass: summed-area tables exceed 2^32 entries");
        cl::Buffer old = pool.data;
        pool.data = host::make_buffer(runtime, CL_MEM_READ_WRITE, std::max<std::size_t>(needed, 1) * sizeof(cl_ulong), nullptr,
                                       "summed-area tables");
        pool.capacity = needed;
        std::size_t at = 0;
        for (std::size_t t = 0; t < n; ++t) {
            offsets[t] = at;
            if (kept[t] >= 0) {
                cl::Event event;
                runtime.queue().enqueueCopyBuffer(old, pool.data, pool.slots[std::size_t(kept[t])].offset * sizeof(cl_ulong),
                                                  at * sizeof(cl_ulong), sat_table_entries(sat, t) * sizeof(cl_ulong), nullptr, &event);
                event.wait();
                sat.stage_ms["sat_copy"] += host::Runtime::event_ms(event);
            }
            at += sat_table_entries(sat, t);
        }
    }
    sat.data = pool.data;
    sat.bytes = needed * sizeof(cl_ulong);  // the tables (the buffer may hold up to twice that, see above)
    std::vector<SatPool::Slot> slots;
    for (std::size_t t = 0; t < n; ++t) {
        place_sat_table(sat, t, offsets[t]);
        slots.push_back({keys[t], offsets[t], sat_table_entries(sat, t)});
    }
    pool.slots = slots;  // before building: a failed build leaves no stale key behind it
    host::ProgressStage stage(runtime.progress(), "summed-area tables", double(std::count(kept.begin(), kept.end(), -1)));
    for (std::size_t t = 0; t < n; ++t) {
        if (kept[t] >= 0) {
            ++counts.reused;
            continue;
        }
        pool.slots[t].key.clear();
        build_sat_table(runtime, scene, packed, device_scene, sat, t);
        pool.slots[t].key = keys[t];
        ++counts.built;
    }
    return sat;
}

bool influences(const packing::PackedScene& packed, const DeviceSat& sat, const RenderOptions& options, std::size_t i,
                std::size_t j, std::size_t m) {
    if (i == j) return true;
    if (options.shadows == ShadowTechnique::Cone) return true;  // cones widen towards the light
    std::vector<WorldBox> boxes = volume_boxes(packed);
    double width = std::max(double(options.sat.filter_width), 1.0) * sat.voxel_size;  // the whole patch (≥ its half diagonal)
    double cell = 0;
    if (options.shadows == ShadowTechnique::Ao || sat.light_frame[m] >= 0) {
        const SatFrame& f = sat.frames[std::size_t(std::max(sat.light_frame[m], 0))];
        cell = std::max({f.cell(0), f.cell(1), f.cell(2)});
    } else {  // an SSAT cell at its farthest, over the light's tables
        for (std::size_t t = m;; t = sat.spheres[t].next) {
            const SsatGridGpu& g = sat.spheres[t];
            double r_max = double(g.start.s[2]) + double(g.dims.s[2]) * double(g.cell.s[2]);
            cell = std::max({cell, double(g.cell.s[2]), r_max * double(g.cell.s[0]), r_max * double(g.cell.s[1])});
            if (g.next == 0) break;
        }
    }
    // the cells a lookup reads: the cell of each patch corner and its trilinear neighbour
    WorldBox target = boxes[j].grown(width + 2.0 * std::sqrt(3.0) * cell);
    if (options.shadows == ShadowTechnique::Ao) return boxes[i].overlaps(target);  // a cube around the sample
    // CSAT: the box from the sample to the grid face towards the light (Ament Eq. 8, 10); SSAT: the
    // pyramid from the light to the sample (Eq. 16–24)
    return between_light_and(boxes[i], target, packed.lights[m]);
}

std::vector<std::string> shadow_cache_keys(const Scene& scene, const packing::PackedScene& packed, const DeviceSat& sat,
                                           const std::vector<std::string>& extinction, const RenderOptions& options) {
    std::ostringstream common;
    common.precision(9);
    common << int(options.shadows) << ' ' << options.sat.filter_width << ' ' << options.sat.filter_kernel << ' '
           << options.sat.cone_angle_deg << ' ' << options.sat.precision << ' ' << options.jitter_seed << ' '
           << hash_of(sat.voxel_size);
    std::vector<std::string> keys;
    for (std::size_t i = 0; i < packed.volumes.size(); ++i)
        for (std::size_t m = 0; m < scene.lights.size(); ++m) {
            std::string key = common.str() + " | lattice " + hash_of(packed.voxel_to_world[i]) + hash_of(packed.volumes[i].dims);
            bool ao = options.shadows == ShadowTechnique::Ao;  // the same term for every light
            for (std::size_t table : light_sat_tables(sat, m)) key += " | table " + sat_table_geometry_key(sat, table);
            if (!ao) {
                const Light& l = scene.lights[m];
                key += " | light " + hash_of(l.type) + hash_of(l.position) + hash_of(l.direction) + hash_of(l.cone_angle_deg) +
                       " axis " + hash_of(sat.grids[m].light_axis) + hash_of(sat.grids[m].light_positive);
            }
            for (std::size_t j = 0; j < packed.volumes.size(); ++j)
                if (influences(packed, sat, options, i, j, m)) key += " | " + std::to_string(j) + ' ' + extinction[j];
            keys.push_back(key);
        }
    return keys;
}

}  // namespace sombra::shadows
