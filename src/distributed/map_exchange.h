// sombra — the deep shadow maps that the ranks of a distributed render exchange
// (sombra/distributed.h): each rank's views and nodes in the compact layout, as bytes, and the
// merge that makes every rank's region one more cluster of each light (Knecht Eq. 3.12: the
// lookup multiplies the clusters' transmittances, cl/techniques/dsm.h).
#pragma once
#include <string>
#include <vector>

#include "memory/dsm_storage.h"
#include "shared/types.h"

namespace sombra::distributed {

struct MapSet {
    std::vector<DsmViewGpu> views;          // a light's views consecutive, grouped by cluster
    std::vector<DsmLightViews> light_views;  // per light: its range of views
    memory::HostPackedNodes nodes;          // per texel of every view (view.first_texel) its nodes
    bool optical_depth = false;             // nodes hold τ (DsmOptions::error "relative")
};

std::vector<unsigned char> serialize(const MapSet& maps);
// Throws sombra::Error naming `where` for bytes serialize did not write.
MapSet deserialize(const std::vector<unsigned char>& bytes, const std::string& where);

// One set holding every rank's maps: for each light, rank 0's views, then rank 1's, …; each
// rank's clusters renumbered after the previous ranks' so that no two ranks share one. The sets
// must agree on the lights, the map resolution and what the nodes hold (sombra::Error otherwise).
MapSet merge_map_sets(const std::vector<MapSet>& ranks);

}  // namespace sombra::distributed
