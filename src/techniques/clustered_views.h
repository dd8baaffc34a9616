// sombra — clustered deep shadow maps (Knecht §3.4): the views of every light's object clusters
// (src/clustering/), each focused on its cluster and holding only its members, as the deep shadow
// map views the builder generates and cl/techniques/dsm.h looks up (Eq. 3.12: the product over a
// light's clusters).
#pragma once
#include <vector>

#include "clustering/clustering.h"
#include "geometry/scene_upload.h"
#include "shadows/dsm_views.h"
#include "sombra/render.h"

namespace sombra::techniques {

struct ClusteredViews {
    std::vector<DsmViewGpu> views;  // light after light, cluster after cluster (DsmViewGpu.cluster)
    shadows::ViewMeshes meshes;     // per view: the meshes its map holds
    std::vector<clustering::SceneObject> objects;
    std::vector<clustering::LightClusters> lights;
    clustering::ClusterOptions options;  // as clustered (previous: none)
    std::vector<DsmLightViews> light_views;  // per light: its clusters' views
};

// The clustered views of the scene's lights at `resolution` texels per side, and each light's range
// of them (a light whose objects all miss B gets none: lit; when
// no light has a view, one placeholder view that holds nothing keeps the backends' buffers).
ClusteredViews make_clustered_views(const Scene& scene, int resolution,
                                    const clustering::ClusterOptions& options);

// A focused view as a deep shadow map view (DsmViewGpu's depth conventions), widened by one
// texel on each side so that bilinear lookups at the members' silhouettes read texels inside.
DsmViewGpu focused_dsm_view(const clustering::FocusedView& view, int resolution);

// The clusters for RenderStats::dsm_clusters and dsm_ignored_objects.
void add_cluster_stats(const ClusteredViews& clustered, RenderStats& stats);

}  // namespace sombra::techniques
