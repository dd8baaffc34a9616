// sombra — the maps the ranks exchange (map_exchange.h).
#include "distributed/map_exchange.h"

#include <cstring>

#include "sombra/distributed.h"
#include "sombra/error.h"

namespace sombra::distributed {

namespace {

constexpr char kExchangeMagic[8] = {'s', 'o', 'm', 'b', 'r', 'a', 'M', '1'};

template <class T>
void put_array(std::vector<unsigned char>& out, const std::vector<T>& items) {
    const unsigned long long count = items.size();
    const auto* c = reinterpret_cast<const unsigned char*>(&count);
    out.insert(out.end(), c, c + sizeof count);
    const auto* data = reinterpret_cast<const unsigned char*>(items.data());
    out.insert(out.end(), data, data + items.size() * sizeof(T));
}

struct Reader {
    const std::vector<unsigned char>& bytes;
    const std::string& where;
    std::size_t at = 0;
    void take(void* to, std::size_t size) {
        if (size > bytes.size() - at) throw Error(where + ": deep shadow maps cut short");
        std::memcpy(to, bytes.data() + at, size);
        at += size;
    }
    template <class T>
    std::vector<T> array() {
        unsigned long long count = 0;
        take(&count, sizeof count);
        if (count > (bytes.size() - at) / sizeof(T)) throw Error(where + ": deep shadow maps cut short");
        std::vector<T> items(count);
        take(items.data(), count * sizeof(T));
        return items;
    }
};

}  // namespace

std::vector<unsigned char> serialize(const MapSet& maps) {
    std::vector<unsigned char> out(kExchangeMagic, kExchangeMagic + sizeof kExchangeMagic);
    out.push_back(maps.optical_depth ? 1 : 0);
    put_array(out, maps.views);
    put_array(out, maps.light_views);
    put_array(out, maps.nodes.texel_first);
    put_array(out, maps.nodes.nodes);
    return out;
}

MapSet deserialize(const std::vector<unsigned char>& bytes, const std::string& where) {
    Reader in{bytes, where};
    char magic[sizeof kExchangeMagic];
    in.take(magic, sizeof magic);
    if (std::memcmp(magic, kExchangeMagic, sizeof magic) != 0) throw Error(where + ": not a set of deep shadow maps");
    MapSet maps;
    unsigned char optical_depth = 0;
    in.take(&optical_depth, 1);
    maps.optical_depth = optical_depth != 0;
    maps.views = in.array<DsmViewGpu>();
    maps.light_views = in.array<DsmLightViews>();
    maps.nodes.texel_first = in.array<cl_uint>();
    maps.nodes.nodes = in.array<float>();
    if (in.at != bytes.size()) throw Error(where + ": bytes after the deep shadow maps");
    // every range in bounds, so that the merge and the lookups read inside the arrays
    const std::vector<cl_uint>& first = maps.nodes.texel_first;
    if (first.empty() || first.back() != maps.nodes.nodes.size() / 2 || maps.nodes.nodes.size() % 2 != 0)
        throw Error(where + ": deep shadow map node offsets do not match the nodes");
    for (std::size_t i = 1; i < first.size(); ++i)
        if (first[i] < first[i - 1]) throw Error(where + ": deep shadow map node offsets decrease");
    for (const DsmLightViews& l : maps.light_views)
        if (std::size_t(l.first) + l.count > maps.views.size()) throw Error(where + ": a light's views lie past the views");
    for (const DsmViewGpu& v : maps.views)
        if (std::size_t(v.first_texel) + std::size_t(v.resolution) * v.resolution >= first.size())
            throw Error(where + ": a view's texels lie past the node offsets");
    return maps;
}

MapSet merge_map_sets(const std::vector<MapSet>& ranks) {
    MapSet merged;
    if (ranks.empty()) return merged;
    const std::size_t lights = ranks.front().light_views.size();
    merged.optical_depth = ranks.front().optical_depth;
    for (const MapSet& r : ranks) {
        if (r.light_views.size() != lights) throw Error("distributed maps: the ranks disagree on the number of lights");
        if (r.optical_depth != merged.optical_depth) throw Error("distributed maps: the ranks disagree on --dsm-error");
        for (const DsmViewGpu& v : r.views)
            if (v.resolution != ranks.front().views.front().resolution)
                throw Error("distributed maps: the ranks disagree on --dsm-res");
    }
    merged.nodes.texel_first.push_back(0);
    for (std::size_t light = 0; light < lights; ++light) {
        DsmLightViews range{cl_uint(merged.views.size()), 0};
        cl_uint cluster = 0;  // the next unused cluster number of this light
        for (const MapSet& r : ranks) {
            const DsmLightViews own = r.light_views[light];
            cl_uint first_cluster = cluster;
            for (cl_uint i = 0; i < own.count; ++i) {
                DsmViewGpu view = r.views[own.first + i];
                const std::size_t texels = std::size_t(view.resolution) * view.resolution;
                const cl_uint node_base = r.nodes.texel_first[view.first_texel];
                const cl_uint merged_base = merged.nodes.texel_first.back();
                for (std::size_t t = 1; t <= texels; ++t)
                    merged.nodes.texel_first.push_back(merged_base + (r.nodes.texel_first[view.first_texel + t] - node_base));
                const cl_uint node_end = r.nodes.texel_first[view.first_texel + texels];
                merged.nodes.nodes.insert(merged.nodes.nodes.end(), r.nodes.nodes.begin() + std::ptrdiff_t(node_base) * 2,
                                          r.nodes.nodes.begin() + std::ptrdiff_t(node_end) * 2);
                view.first_texel = cl_uint(merged.nodes.texel_first.size() - 1 - texels);
                view.cluster = first_cluster + view.cluster - r.views[own.first].cluster;
                cluster = std::max(cluster, view.cluster + 1);
                merged.views.push_back(view);
                ++range.count;
            }
        }
        merged.light_views.push_back(range);
    }
    if (merged.nodes.nodes.size() / 2 > 0x7fffffffull) throw Error("distributed maps: more than 2^31 deep shadow map nodes in all");
    return merged;
}

MapSet no_maps(std::size_t lights, bool optical_depth) {
    MapSet none;
    none.light_views.assign(lights, DsmLightViews{0, 0});
    none.nodes.texel_first = {0};
    none.optical_depth = optical_depth;
    return none;
}

ReceivedMaps exchange_maps(RankExchange& exchange, const MapSet& own, const std::function<void(const char*)>& stage) {
    ReceivedMaps out;
    const std::vector<unsigned char> bytes = serialize(own);
    stage("dsm_exchange_send");  // read back (by the caller) and serialized
    if (!exchange.all_ok(true)) throw OtherRankFailed();
    stage("dsm_exchange_wait");  // for the slowest rank's maps
    out.ranks = exchange.all_gather(bytes);
    stage("dsm_exchange_gather");
    out.bytes_sent = bytes.size();
    for (std::size_t r = 0; r < out.ranks.size(); ++r)
        if (int(r) != exchange.rank()) out.bytes_received += out.ranks[r].size();
    return out;
}

}  // namespace sombra::distributed
