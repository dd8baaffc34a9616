// sombra — distributed rendering (sombra/distributed.h): the k-d split into regions, each rank's
// part of the scene, the compositing of the ranks' images, and the protocol between the ranks.
#include "sombra/distributed.h"

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstring>
#include <limits>

#include <nlohmann/json.hpp>

#include "distributed/map_exchange.h"
#include "geometry/scene_upload.h"

namespace sombra {

namespace {

using Corner = std::array<double, 3>;

// p' = M·p for a row-major affine 4×4 matrix
Corner transform_point(const std::array<float, 16>& m, const Corner& p) {
    Corner q{};
    for (std::size_t r = 0; r < 3; ++r) q[r] = m[4 * r] * p[0] + m[4 * r + 1] * p[1] + m[4 * r + 2] * p[2] + m[4 * r + 3];
    return q;
}

Box empty_box() {
    const float inf = std::numeric_limits<float>::infinity();
    return {{inf, inf, inf}, {-inf, -inf, -inf}};
}

void grow(Box& box, const Corner& p) {
    for (std::size_t a = 0; a < 3; ++a) {
        box.min[a] = std::min(box.min[a], float(p[a]));
        box.max[a] = std::max(box.max[a], float(p[a]));
    }
}

Box mesh_box(const MeshInstance& mi) {
    Box box = empty_box();
    for (const auto& p : mi.mesh->positions) grow(box, transform_point(mi.transform, {p[0], p[1], p[2]}));
    return box;
}

// The world box of voxel-space box [lo, hi] of a volume (voxel_to_world: pack_scene's)
Box world_box(const std::array<float, 16>& voxel_to_world, const Corner& lo, const Corner& hi) {
    Box box = empty_box();
    for (int c = 0; c < 8; ++c) grow(box, transform_point(voxel_to_world, {c & 1 ? hi[0] : lo[0], c & 2 ? hi[1] : lo[1], c & 4 ? hi[2] : lo[2]}));
    return box;
}

// The world centres of the bricks some transfer-function entry makes visible (pack_scene's
// occupancy), or of every brick of a volume known by its header only: what the split divides
// between the ranks.
std::vector<Corner> occupied_brick_centres(const Scene& scene) {
    std::vector<Corner> centres;
    for (const VolumeInstance& vi : scene.volumes) {
        const auto& dims = vi.volume->dims;
        std::vector<unsigned char> occupied;  // per brick; empty: all (a header)
        if (!vi.volume->header_only) {
            Scene one;
            one.volumes = {vi};
            occupied = packing::pack_scene(one).occupancy;
        }
        const std::array<float, 16> voxel_to_world = packing::voxel_to_world_matrix(vi);
        const int bricks[3] = {(dims[0] + SOMBRA_BRICK_SIZE - 1) / SOMBRA_BRICK_SIZE, (dims[1] + SOMBRA_BRICK_SIZE - 1) / SOMBRA_BRICK_SIZE,
                               (dims[2] + SOMBRA_BRICK_SIZE - 1) / SOMBRA_BRICK_SIZE};
        std::size_t b = 0;
        for (int z = 0; z < bricks[2]; ++z)
            for (int y = 0; y < bricks[1]; ++y)
                for (int x = 0; x < bricks[0]; ++x, ++b) {
                    if (!occupied.empty() && !occupied[b]) continue;
                    Corner centre;
                    const int index[3] = {x, y, z};
                    for (std::size_t a = 0; a < 3; ++a) {  // the middle of the brick's voxels
                        const int first = index[a] * SOMBRA_BRICK_SIZE, last = std::min(first + SOMBRA_BRICK_SIZE, dims[a]) - 1;
                        centre[a] = 0.5 * (first + last);
                    }
                    centres.push_back(transform_point(voxel_to_world, centre));
                }
    }
    return centres;
}

// A cut at `position` on `axis` through the middle of a mesh's box moves to the nearer face of
// that box, as long as it stays inside (lo, hi); nullopt when no position there avoids every mesh.
std::optional<float> cut_between_meshes(float position, int axis, float lo, float hi, const std::vector<Box>& meshes) {
    for (std::size_t tries = 0; tries <= 2 * meshes.size(); ++tries) {
        const Box* cut = nullptr;
        for (const Box& m : meshes)
            if (m.min[std::size_t(axis)] < position && position < m.max[std::size_t(axis)]) cut = &m;
        if (!cut) return position;
        const float below = cut->min[std::size_t(axis)], above = cut->max[std::size_t(axis)];
        const bool below_ok = below > lo, above_ok = above < hi;
        if (!below_ok && !above_ok) return std::nullopt;
        if (below_ok && (!above_ok || position - below <= above - position)) position = below;
        else position = above;
    }
    return std::nullopt;
}

struct Splitter {
    RegionSplit& split;
    const std::vector<Box>& meshes;

    // Splits `box` (finite, for choosing the cut; `region` is what the leaves get, ±∞ outside)
    // holding `points` into `count` regions; returns the node's index.
    int node(Box box, Box region, std::vector<Corner> points, int count) {
        const int index = int(split.nodes.size());
        split.nodes.emplace_back();
        if (count == 1) {
            split.nodes[std::size_t(index)].region = int(split.regions.size());
            split.regions.push_back(region);
            return index;
        }
        const int low_count = count / 2;
        // the axes by decreasing extent: the first whose cut avoids every mesh
        std::array<int, 3> axes{0, 1, 2};
        std::sort(axes.begin(), axes.end(), [&](int a, int b) {
            return box.max[std::size_t(a)] - box.min[std::size_t(a)] > box.max[std::size_t(b)] - box.min[std::size_t(b)];
        });
        for (int axis : axes) {
            const std::size_t a = std::size_t(axis);
            const float lo = box.min[a], hi = box.max[a];
            if (!(hi > lo)) continue;
            float position = lo + (hi - lo) * float(low_count) / float(count);  // no occupied brick: by extent
            if (!points.empty()) {
                std::sort(points.begin(), points.end(), [&](const Corner& p, const Corner& q) { return p[a] < q[a]; });
                const std::size_t k = std::min(points.size() - 1, points.size() * std::size_t(low_count) / std::size_t(count));
                position = float(k == 0 ? points[0][a] : 0.5 * (points[k - 1][a] + points[k][a]));
                if (!(position > lo && position < hi)) position = lo + (hi - lo) * float(low_count) / float(count);
            }
            std::optional<float> cut = cut_between_meshes(position, axis, lo, hi, meshes);
            if (!cut) continue;
            std::vector<Corner> below, above;
            for (const Corner& p : points) (p[a] < *cut ? below : above).push_back(p);
            Box low_box = box, high_box = box, low_region = region, high_region = region;
            low_box.max[a] = high_box.min[a] = low_region.max[a] = high_region.min[a] = *cut;
            split.nodes[std::size_t(index)].axis = axis;
            split.nodes[std::size_t(index)].position = *cut;
            const int low = node(low_box, low_region, std::move(below), low_count);
            const int high = node(high_box, high_region, std::move(above), count - low_count);
            split.nodes[std::size_t(index)].low = low;
            split.nodes[std::size_t(index)].high = high;
            return index;
        }
        throw Error("--distributed: no cut into " + std::to_string(count) +
                    " regions avoids every mesh (a mesh is never split between ranks); use fewer ranks");
    }
};

unsigned long long peak_memory_bytes() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return (unsigned long long)usage.ru_maxrss * 1024ull;  // Linux: kilobytes
}


// A rank's partial image and stats as they travel to rank 0: width, height, the stats' JSON
// length, the pixels (premultiplied RGBA floats), the JSON.
std::vector<unsigned char> pack_partial(const Image& image, const std::string& stats_json) {
    std::vector<unsigned char> out(3 * sizeof(std::uint64_t));
    const std::uint64_t head[3] = {std::uint64_t(image.width), std::uint64_t(image.height), stats_json.size()};
    std::memcpy(out.data(), head, sizeof head);
    const auto* pixels = reinterpret_cast<const unsigned char*>(image.rgba.data());
    out.insert(out.end(), pixels, pixels + image.rgba.size() * sizeof(float));
    out.insert(out.end(), stats_json.begin(), stats_json.end());
    return out;
}

Image unpack_partial(const std::vector<unsigned char>& bytes, int rank, std::string& stats_json) {
    const std::string where = "rank " + std::to_string(rank) + ": partial image";
    std::uint64_t head[3];
    if (bytes.size() < sizeof head) throw Error(where + ": cut short");
    std::memcpy(head, bytes.data(), sizeof head);
    Image image;
    image.width = int(head[0]), image.height = int(head[1]);
    const std::size_t floats = std::size_t(head[0]) * std::size_t(head[1]) * 4;
    if (head[0] > 16384 || head[1] > 16384 || bytes.size() != sizeof head + floats * sizeof(float) + head[2])
        throw Error(where + ": size does not match its header");
    image.rgba.resize(floats);
    std::memcpy(image.rgba.data(), bytes.data() + sizeof head, floats * sizeof(float));
    stats_json.assign(reinterpret_cast<const char*>(bytes.data() + sizeof head + floats * sizeof(float)), std::size_t(head[2]));
    return image;
}

// The rank's protocol step that may fail: every rank runs it, then all learn whether any failed.
// A rank that failed rethrows its error; the others throw OtherRankFailed.
template <class Step>
void step_on_every_rank(RankExchange& exchange, Step&& step) {
    try {
        step();
    } catch (const OtherRankFailed&) {
        throw;  // a collective inside the step learnt it: every rank has left the protocol
    } catch (...) {
        exchange.all_ok(false);  // the collective the others wait in
        throw;
    }
    if (!exchange.all_ok(true)) throw OtherRankFailed();
}

}  // namespace

std::vector<int> RegionSplit::front_to_back(const Vec3& eye) const {
    std::vector<int> order;
    if (nodes.empty()) return order;
    std::vector<int> stack{0};
    while (!stack.empty()) {
        const Node& n = nodes[std::size_t(stack.back())];
        stack.pop_back();
        if (n.axis < 0) {
            order.push_back(n.region);
            continue;
        }
        const bool eye_below = eye[std::size_t(n.axis)] < n.position;
        stack.push_back(eye_below ? n.high : n.low);  // the far side after the near one
        stack.push_back(eye_below ? n.low : n.high);
    }
    return order;
}

RegionSplit split_regions(const Scene& scene, int count) {
    if (count < 1) throw Error("--distributed: needs at least one rank");
    Box world = empty_box();
    for (const VolumeInstance& vi : scene.volumes) {
        const auto& dims = vi.volume->dims;
        Box b = world_box(packing::voxel_to_world_matrix(vi), {-0.5, -0.5, -0.5}, {dims[0] - 0.5, dims[1] - 0.5, dims[2] - 0.5});
        grow(world, {b.min[0], b.min[1], b.min[2]});
        grow(world, {b.max[0], b.max[1], b.max[2]});
    }
    std::vector<Box> meshes;
    for (const MeshInstance& mi : scene.meshes) {
        if (!mi.mesh || mi.mesh->positions.empty()) continue;
        meshes.push_back(mesh_box(mi));
        grow(world, {meshes.back().min[0], meshes.back().min[1], meshes.back().min[2]});
        grow(world, {meshes.back().max[0], meshes.back().max[1], meshes.back().max[2]});
    }
    if (!(world.max[0] >= world.min[0])) world = {{-1, -1, -1}, {1, 1, 1}};  // nothing in the scene
    RegionSplit split;
    const float inf = std::numeric_limits<float>::infinity();
    Splitter{split, meshes}.node(world, {{-inf, -inf, -inf}, {inf, inf, inf}}, occupied_brick_centres(scene), count);
    return split;
}

Scene region_scene(const Scene& scene, const Box& region, const VolumeLoadOptions& load) {
    Scene part = scene;
    part.volumes.clear();
    part.meshes.clear();
    part.background = {0, 0, 0};
    for (const VolumeInstance& vi : scene.volumes) {
        const Volume& v = *vi.volume;
        // the region in voxel space: its corners through world → voxel, clamped to the volume's box
        const std::array<float, 16> world_to_voxel = packing::world_to_voxel_matrix(vi);
        Corner lo{-0.5, -0.5, -0.5}, hi{v.dims[0] - 0.5, v.dims[1] - 0.5, v.dims[2] - 0.5};
        const Box in_world = world_box(packing::voxel_to_world_matrix(vi), lo, hi);
        Box clamped;
        for (std::size_t a = 0; a < 3; ++a) {
            clamped.min[a] = std::max(region.min[a], in_world.min[a]);
            clamped.max[a] = std::min(region.max[a], in_world.max[a]);
        }
        if (!(clamped.min[0] < clamped.max[0] && clamped.min[1] < clamped.max[1] && clamped.min[2] < clamped.max[2])) continue;
        Box in_voxels = empty_box();
        for (int c = 0; c < 8; ++c)
            grow(in_voxels, transform_point(world_to_voxel, {c & 1 ? clamped.max[0] : clamped.min[0], c & 2 ? clamped.max[1] : clamped.min[1],
                                                   c & 4 ? clamped.max[2] : clamped.min[2]}));
        // trilinear samples at x read voxels ⌊x⌋ and ⌊x⌋ + 1; central differences one further
        std::array<int, 3> first{}, last{}, dims{};
        for (std::size_t a = 0; a < 3; ++a) {
            first[a] = std::clamp(int(std::floor(in_voxels.min[a])) - 1, 0, v.dims[a] - 1);
            last[a] = std::clamp(int(std::floor(in_voxels.max[a])) + 2, 0, v.dims[a] - 1);
            dims[a] = last[a] - first[a] + 1;
        }
        auto cropped = std::make_shared<Volume>();
        if (v.header_only) {  // read from the file: this rank's box only
            VolumeLoadOptions part = load;
            part.header_only = false, part.read_part = true;
            part.part = {first, last};
            *cropped = load_volume(v.source, part);
        } else {
            cropped->dims = dims;
            cropped->voxels.reserve(cropped->voxel_count());
            for (int z = first[2]; z <= last[2]; ++z)
                for (int y = first[1]; y <= last[1]; ++y)
                    for (int x = first[0]; x <= last[0]; ++x) cropped->voxels.push_back(v.at(x, y, z));
            cropped->update_range();
        }
        cropped->spacing = v.spacing;
        cropped->placement = v.placement;
        cropped->source = v.source;
        cropped->stored_type = v.stored_type;
        VolumeInstance part_vi = vi;
        part_vi.volume = cropped;
        // the cropped grid is centred on its own middle: shift by where that middle lies in the old
        // object frame, (first + (m − 1)/2 − (n − 1)/2)·spacing, through the old transform
        Corner shift{};
        for (std::size_t a = 0; a < 3; ++a) shift[a] = (first[a] + 0.5 * (dims[a] - 1) - 0.5 * (v.dims[a] - 1)) * vi.spacing[a];
        for (std::size_t r = 0; r < 3; ++r)
            part_vi.transform[4 * r + 3] +=
                float(vi.transform[4 * r] * shift[0] + vi.transform[4 * r + 1] * shift[1] + vi.transform[4 * r + 2] * shift[2]);
        for (std::size_t a = 0; a < 3; ++a) {
            part_vi.clip_min[a] = std::max(vi.clip_min[a], region.min[a]);
            part_vi.clip_max[a] = std::min(vi.clip_max[a], region.max[a]);
        }
        part.volumes.push_back(part_vi);
    }
    for (const MeshInstance& mi : scene.meshes) {
        if (!mi.mesh || mi.mesh->positions.empty()) continue;
        const Box b = mesh_box(mi);
        bool inside = true;
        for (std::size_t a = 0; a < 3; ++a) {
            const float centre = 0.5f * (b.min[a] + b.max[a]);
            inside = inside && centre >= region.min[a] && centre < region.max[a];
        }
        if (inside) part.meshes.push_back(mi);
    }
    return part;
}

Image composite_front_to_back(const std::vector<const Image*>& front_to_back, const Vec3& background) {
    Image out;
    if (front_to_back.empty()) return out;
    out.width = front_to_back.front()->width, out.height = front_to_back.front()->height;
    out.background = background;
    const std::size_t pixels = std::size_t(out.width) * std::size_t(out.height);
    out.rgba.assign(pixels * 4, 0.f);
    std::vector<float> transmittance(pixels, 1.f);
    for (const Image* part : front_to_back) {
        if (part->width != out.width || part->height != out.height) throw Error("--distributed: the ranks' images differ in size");
        for (std::size_t p = 0; p < pixels; ++p) {
            for (std::size_t c = 0; c < 3; ++c) out.rgba[4 * p + c] += transmittance[p] * part->rgba[4 * p + c];
            transmittance[p] *= 1.f - part->rgba[4 * p + 3];
        }
    }
    for (std::size_t p = 0; p < pixels; ++p) {
        for (std::size_t c = 0; c < 3; ++c) out.rgba[4 * p + c] += transmittance[p] * background[c];
        out.rgba[4 * p + 3] = 1.f - transmittance[p];
    }
    return out;
}

RenderResult render_distributed(Context& context, const Scene& scene, const RenderOptions& options, RankExchange& exchange,
                                const VolumeLoadOptions& load) {
    const int rank = exchange.rank(), ranks = exchange.size();
    const bool maps = !scene.lights.empty() && (options.shadows == ShadowTechnique::Dsm || options.shadows == ShadowTechnique::ShadowMap);
    RenderResult result;
    RegionSplit split;
    Scene part;
    auto start = std::chrono::steady_clock::now();
    step_on_every_rank(exchange, [&] {
        if (!maps && options.shadows != ShadowTechnique::None && !scene.lights.empty())
            throw Error(std::string("--shadows ") + shadow_technique_name(options.shadows) +
                        ": a distributed render exchanges deep shadow maps between ranks; use dsm, shadowmap or none");
        if (maps && options.dsm.clusters > 0)
            throw Error("--clusters: a distributed render's ranks build one map per light of their own region; use --clusters 0");
        split = split_regions(scene, ranks);
        part = region_scene(scene, split.regions[std::size_t(rank)], load);
        if (const char* fail = std::getenv("SOMBRA_TEST_FAIL_RANK"); fail && std::atoi(fail) == rank)  // tests/distributed
            throw Error(scene.source + ": rank " + std::to_string(rank) + ": SOMBRA_TEST_FAIL_RANK asks this rank to fail");
    });
    const double split_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    step_on_every_rank(exchange, [&] {
        context.release_prepared_scenes();  // the exchanged maps are built once, for this call
        if (part.volumes.empty() && part.meshes.empty()) {  // an empty region: nothing to render, no maps of its own
            result.stats.width = options.width > 0 ? options.width : scene.width;
            result.stats.height = options.height > 0 ? options.height : scene.height;
            result.image.width = result.stats.width, result.image.height = result.stats.height;
            result.image.rgba.assign(std::size_t(result.image.width) * std::size_t(result.image.height) * 4, 0.f);
            if (maps) {  // the others wait for this rank's maps: none
                const distributed::ReceivedMaps received = distributed::exchange_maps(
                    exchange, distributed::no_maps(scene.lights.size(), options.dsm.error == "relative"), [](const char*) {});
                result.stats.map_bytes_sent = received.bytes_sent, result.stats.map_bytes_received = received.bytes_received;
            }
            return;
        }
        struct Scope {
            Context& c;
            ~Scope() { c.set_rank_exchange(nullptr); }
        } scope{context};
        context.set_rank_exchange(&exchange);
        result = render(context, part, options);
    });
    RenderStats& stats = result.stats;
    stats.stage_ms["distributed_region"] = split_ms;  // the split, and reading or cropping the region
    stats.rank = rank, stats.ranks = ranks;
    stats.region_volumes = int(part.volumes.size()), stats.region_meshes = int(part.meshes.size());
    for (const VolumeInstance& vi : part.volumes) stats.region_voxels += vi.volume->voxel_count();
    stats.peak_memory_bytes = peak_memory_bytes();
    stats.image_bytes_sent = rank == 0 ? 0 : result.image.rgba.size() * sizeof(float);  // the pixels (and a short header and the stats)
    const std::vector<unsigned char> partial = pack_partial(result.image, stats.to_json());
    auto composite_start = std::chrono::steady_clock::now();
    const std::vector<std::vector<unsigned char>> gathered = exchange.gather_to_root(partial);
    if (rank != 0) {
        result.image = Image();
        return result;
    }
    std::vector<Image> images;
    for (std::size_t r = 0; r < gathered.size(); ++r) {
        std::string json;
        images.push_back(unpack_partial(gathered[r], int(r), json));
        stats.rank_stats.push_back(json);
    }
    std::vector<const Image*> order;
    for (int region : split.front_to_back(scene.camera.position)) order.push_back(&images[std::size_t(region)]);
    result.image = composite_front_to_back(order, scene.background);
    stats.stage_ms["distributed_composite"] =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - composite_start).count();
    return result;
}

}  // namespace sombra
