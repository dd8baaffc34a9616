// sombra — data-parallel rendering over several processes ("ranks"), each holding one region of
// the world (docs/distributed.md). Every rank renders its region with deep shadow maps of its own
// objects; the ranks exchange those compressed maps, so that each rank's lookups take the product
// of every region's transmittance (Knecht Eq. 3.12: the regions are independent clusters), and
// rank 0 composites the ranks' premultiplied images front to back.
#pragma once
#include <string>
#include <vector>

#include "sombra/device.h"
#include "sombra/error.h"
#include "sombra/render.h"
#include "sombra/scene.h"

namespace sombra {

// The collective operations between the ranks. The CLI implements them over MPI
// (src/cli/distributed_mpi.cpp); any transport can. Every rank calls the same operations in the
// same order.
class RankExchange {
public:
    virtual ~RankExchange() = default;
    virtual int rank() const = 0;
    virtual int size() const = 0;
    // Every rank's `mine`, in rank order, on every rank.
    virtual std::vector<std::vector<unsigned char>> all_gather(const std::vector<unsigned char>& mine) = 0;
    // Every rank's `mine`, in rank order, on rank 0; nothing on the others.
    virtual std::vector<std::vector<unsigned char>> gather_to_root(const std::vector<unsigned char>& mine) = 0;
    // Whether every rank says ok. A rank that fails calls it once with false instead of its next
    // collective, so that no rank waits forever: all then stop.
    virtual bool all_ok(bool ok) = 0;
};

// Thrown on the ranks that did not fail when another rank did (that rank reports the error).
class OtherRankFailed : public Error {
public:
    OtherRankFailed() : Error("another rank of the distributed render failed") {}
};

struct Box {
    Vec3 min, max;
};

// A k-d split of the world into convex, disjoint regions, one per rank: the scene's box cut along
// its longest axis where the occupied bricks (voxels some transfer-function entry makes visible)
// divide in the ratio of the ranks on each side, recursively. A cut never passes through a mesh's
// box: it moves to the nearer face of that box, and the split fails (sombra::Error) when no cut
// can avoid every mesh. Regions on the outside extend to ±∞.
struct RegionSplit {
    struct Node {
        int axis = -1;       // -1: a leaf, holding `region`
        float position = 0;  // the cut: low child below, high child above
        int low = -1, high = -1, region = -1;
    };
    std::vector<Node> nodes;  // nodes[0] is the root
    std::vector<Box> regions;
    // The regions in front-to-back order seen from `eye` (a k-d tree gives one order for every
    // pixel of a perspective camera: at each cut, the side holding the eye first).
    std::vector<int> front_to_back(const Vec3& eye) const;
};
RegionSplit split_regions(const Scene& scene, int count);

// The part of `scene` in `region`: each volume that overlaps it cropped to its voxels there plus
// a ghost layer of two voxels (trilinear interpolation and central differences at the faces see
// the neighbours' voxels) and clipped to the region (VolumeInstance::clip_min/max); the meshes
// whose box centre lies in it (split_regions never cuts one); every light; the camera; a black
// background, so that the image is the region's premultiplied contribution. A volume loaded by
// its header only (VolumeLoadOptions::header_only) is read here, its box alone, with `load`.
Scene region_scene(const Scene& scene, const Box& region, const VolumeLoadOptions& load = {});

// Composites premultiplied partial images in front-to-back order ("over"), then the background
// behind what light is left: the image one render of the whole scene gives.
Image composite_front_to_back(const std::vector<const Image*>& front_to_back, const Vec3& background);

// One rank's part of a distributed render of `scene` (every rank passes the same scene and
// options): its region's image with the maps of all ranks, gathered and composited on rank 0,
// which returns the image and its stats with every rank's (RenderStats::rank_stats); the other
// ranks return their own stats and no image. Only deep shadow maps (dsm, shadowmap) and none
// cross ranks; other techniques, clustered maps (--clusters) and native map lookups throw
// sombra::Error. A rank that fails throws its error; the others throw OtherRankFailed. A scene
// loaded with VolumeLoadOptions::header_only has each rank read only its region's voxels (with
// `load`), so that no rank holds a whole volume (.npy, raw and NRRD files; see VolumeLoadOptions::part).
RenderResult render_distributed(Context& context, const Scene& scene, const RenderOptions& options, RankExchange& exchange,
                                const VolumeLoadOptions& load = {});

}  // namespace sombra
