// sombra — the deep shadow maps that the ranks of a distributed render exchange
// (sombra/distributed.h): each rank's views and nodes in the compact layout, as bytes, and the
// merge that makes every rank's region one more cluster of each light (Knecht Eq. 3.12: the
// lookup multiplies the clusters' transmittances, cl/techniques/dsm.h).
#pragma once
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "memory/dsm_storage.h"
#include "shared/types.h"

namespace sombra {
class RankExchange;
}

namespace sombra::distributed {

struct MapSet {
    std::vector<DsmViewGpu> views;          // a light's views consecutive, grouped by cluster
    std::vector<DsmLightViews> light_views;  // per light: its range of views
    memory::HostPackedNodes nodes;          // per texel of every view (view.first_texel) its nodes
    bool optical_depth = false;             // nodes hold τ (DsmOptions::error "relative")
};

// The maps of a rank without objects: every light with no views.
MapSet no_maps(std::size_t lights, bool optical_depth);

std::vector<unsigned char> serialize(const MapSet& maps);
// Throws sombra::Error naming `where` for bytes serialize did not write.
MapSet deserialize(const std::vector<unsigned char>& bytes, const std::string& where);

// One set holding every rank's maps: for each light, rank 0's views, then rank 1's, …; each
// rank's clusters renumbered after the previous ranks' so that no two ranks share one. The sets
// must agree on the lights, the map resolution and what the nodes hold (sombra::Error otherwise).
MapSet merge_map_sets(const std::vector<MapSet>& ranks);

// Every rank's serialized maps (its own included, in rank order), and the bytes this rank sent
// and received.
struct ReceivedMaps {
    std::vector<std::vector<unsigned char>> ranks;
    std::size_t bytes_sent = 0, bytes_received = 0;
};
// The one exchange step of every rank: serializes `own`, waits until every rank is ready (throws
// OtherRankFailed if one failed) and all-gathers. `stage(name)` is called after each part:
// "dsm_exchange_send", "dsm_exchange_wait", "dsm_exchange_gather".
ReceivedMaps exchange_maps(RankExchange& exchange, const MapSet& own, const std::function<void(const char*)>& stage);

}  // namespace sombra::distributed
