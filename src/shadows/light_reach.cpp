// sombra — volume boxes and the region between a box and a light (light_reach.h).
#include "shadows/light_reach.h"

#include <algorithm>

namespace sombra::shadows {
namespace {

// Whether box `a` swept to infinity along `towards` meets box `b`: the ray from the origin along
// `towards` through the Minkowski difference b ⊖ a (slab test).
bool sweep_meets(const WorldBox& a, const WorldBox& b, const D3& towards) {
    double t0 = 0, t1 = INFINITY;
    for (std::size_t k = 0; k < 3; ++k) {
        double lo = b.lo[k] - a.hi[k], hi = b.hi[k] - a.lo[k];
        if (towards[k] == 0) {
            if (lo > 0 || hi < 0) return false;
            continue;
        }
        double ta = lo / towards[k], tb = hi / towards[k];
        t0 = std::max(t0, std::min(ta, tb)), t1 = std::min(t1, std::max(ta, tb));
    }
    return t0 <= t1;
}

}  // namespace

void WorldBox::add(const D3& p) {
    for (std::size_t a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
}

WorldBox WorldBox::grown(double r) const {
    WorldBox b = *this;
    for (std::size_t a = 0; a < 3; ++a) b.lo[a] -= r, b.hi[a] += r;
    return b;
}

bool WorldBox::overlaps(const WorldBox& o) const {
    for (std::size_t a = 0; a < 3; ++a)
        if (o.hi[a] < lo[a] || hi[a] < o.lo[a]) return false;
    return true;
}

double WorldBox::diagonal() const { return std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]); }

std::vector<WorldBox> volume_boxes(const packing::PackedScene& packed) {
    double voxel = 0;
    std::vector<D3> corners = scene_corners(packed, voxel);
    std::vector<WorldBox> boxes(packed.volumes.size());
    for (std::size_t c = 0; c < corners.size(); ++c) boxes[c / 8].add(corners[c]);
    return boxes;
}

bool between_light_and(const WorldBox& receiver, const WorldBox& caster, const LightGpu& light) {
    if (light.type == SOMBRA_LIGHT_DIRECTIONAL)
        return sweep_meets(receiver, caster, {-light.direction.s[0], -light.direction.s[1], -light.direction.s[2]});
    WorldBox hull = receiver;
    hull.add({light.position.s[0], light.position.s[1], light.position.s[2]});
    return hull.overlaps(caster);
}

}  // namespace sombra::shadows
