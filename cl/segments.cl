/* sombra — the fragment stage (Knecht §3.1.2, §4.1.2): one work-item per pixel gathers the
 * triangles whose coverage mask in its tile's list has the pixel's bit, computes each one's depth
 * from the triangle's depth plane, and stores them sorted near to far. Consecutive fragments bound
 * the pixel's homogeneous segments. Two passes like the raster stage: segments_count, a prefix
 * sum over the pixels (host), segments_write — every fragment is kept. */
#include "shared/types.h"

#define TILE SOMBRA_TILE_SIZE

static inline ulong pixel_bit(uint px, uint py) { return 1ul << ((py % TILE) * TILE + px % TILE); }
static inline uint tile_of(uint px, uint py, __global const RasterScreenGpu* s) { return (py / TILE) * s->tiles_x + px / TILE; }

/* Depth of triangle t at the centre of pixel (px, py) (DsmViewGpu convention). */
static inline float fragment_depth(__global const ScreenTriangleGpu* t, uint px, uint py, __global const RasterScreenGpu* s) {
    const float unit = 1.0f / (float)(1 << SOMBRA_SUBPIXEL_BITS);
    float cx = (float)px + 0.5f, cy = (float)py + 0.5f;
    /* plane equation over the screen (Knecht §3.1.2); q = 1 / view z or view z */
    float q = t->depth_plane.x + t->depth_plane.y * (cx - (float)t->x.x * unit) + t->depth_plane.z * (cy - (float)t->y.x * unit);
    if (!s->perspective) return q;
    float nx = ((cx + s->pixel_shift) / (float)s->width * 2.0f - 1.0f) * s->extent_x;
    float ny = ((cy + s->pixel_shift) / (float)s->height * 2.0f - 1.0f) * s->extent_y;
    return sqrt(1.0f + nx * nx + ny * ny) / fmax(q, FLT_MIN); /* view z → distance along the ray */
}

__kernel void segments_count(__global const RasterScreenGpu* s, __global const uint* count,
                             __global const uint* first_chunk, __global const ulong* masks, __global uint* pixel_count) {
    uint px = get_global_id(0), py = get_global_id(1);
    if (px >= s->width || py >= s->height) return;
    uint tile = tile_of(px, py, s), n = 0;
    ulong bit = pixel_bit(px, py);
    __global const ulong* m = masks + first_chunk[tile] * SOMBRA_TILE_CHUNK;
    for (uint k = 0; k < count[tile]; ++k) n += (m[k] & bit) != 0;
    pixel_count[py * s->width + px] = n;
}

/* (depth, triangle) order: near first, ties by triangle index (deterministic). */
static inline int before(FragmentGpu a, FragmentGpu b) {
    return a.depth < b.depth || (a.depth == b.depth && a.triangle < b.triangle);
}

/* Moves out[i] down the max-heap out[0 … n) until both children are not after it. */
static inline void sift_down(__global FragmentGpu* out, uint i, uint n) {
    FragmentGpu f = out[i];
    for (uint child; (child = 2 * i + 1) < n; i = child) {
        if (child + 1 < n && before(out[child], out[child + 1])) ++child;
        if (!before(f, out[child])) break;
        out[i] = out[child];
    }
    out[i] = f;
}

/* Heapsort of a pixel's fragments in place: O(n log n) however many there are (insertion sort
 * was quadratic: 20,000 coincident triangles took minutes). The order is total (ties by triangle
 * index), so the result does not depend on the order the tile lists hold them in. */
static inline void sort_fragments(__global FragmentGpu* out, uint n) {
    for (uint i = n / 2; i-- > 0;) sift_down(out, i, n);
    for (uint end = n; end > 1;) {
        --end;
        FragmentGpu top = out[0];
        out[0] = out[end];
        out[end] = top;
        sift_down(out, 0, end);
    }
}

__kernel void segments_write(__global const RasterScreenGpu* s, __global const ScreenTriangleGpu* tris,
                             __global const uint* count, __global const uint* first_chunk,
                             __global const ulong* masks, __global const uint* ids,
                             __global const uint* pixel_first, __global FragmentGpu* fragments) {
    uint px = get_global_id(0), py = get_global_id(1);
    if (px >= s->width || py >= s->height) return;
    uint tile = tile_of(px, py, s), base = first_chunk[tile] * SOMBRA_TILE_CHUNK;
    ulong bit = pixel_bit(px, py);
    __global FragmentGpu* out = fragments + pixel_first[py * s->width + px];
    uint n = 0;
    for (uint k = 0; k < count[tile]; ++k) {
        if (!(masks[base + k] & bit)) continue;
        FragmentGpu f;
        f.triangle = ids[base + k];
        f.depth = fragment_depth(tris + f.triangle, px, py, s);
        out[n++] = f;
    }
    sort_fragments(out, n);
}
