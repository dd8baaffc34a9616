/* sombra — tile rasterizer (Knecht §3.1.1, §4.1.1): one work-item per screen-space triangle; for
 * every 8×8 tile its bounding box touches, a 64-bit coverage mask from the three edge half-planes
 * with bit shifts (Knecht Eq. 4.1–4.6). Two passes: raster_count counts the entries per tile, the
 * host allocates whole chunks of SOMBRA_TILE_CHUNK entries per tile with a prefix sum, raster_write
 * fills them (no tile is ever truncated).
 *
 * Fill rule (top-left): a pixel centre P is covered iff, for every edge A→B of the triangle wound
 * with positive area, E(P) = (Bx−Ax)(Py−Ay) − (By−Ay)(Px−Ax) > 0, or E(P) = 0 and the edge owns its
 * points (dy > 0, or dy = 0 and dx < 0). Integer arithmetic on fixed-point corners: exact. */
#include "shared/types.h"

#define TILE SOMBRA_TILE_SIZE
#define HALF_PIXEL (1 << (SOMBRA_SUBPIXEL_BITS - 1))

static inline long floor_div(long a, long b) { /* b > 0 */
    return a >= 0 ? a / b : -((-a + b - 1) / b);
}

/* Bits of the tile's pixels (x, y) with e + x·ex + y·ey ≥ t, bit 8y + x. */
static inline ulong edge_mask(long e, long ex, long ey, long t) {
    ulong m = 0;
    if (ex == 0 && ey == 0) return e >= t ? ~(ulong)0 : 0;
    if (abs(ex) >= abs(ey)) {
        /* rows (Knecht Eq. 4.1–4.3): the inside of row y is a run of n₁(y) pixels at one end */
        for (int y = 0; y < TILE; ++y) {
            long er = e + y * ey;
            ulong row;
            if (ex > 0) { /* x ≥ ⌈(t − er) / ex⌉ */
                long k = clamp(-floor_div(er - t, ex), 0L, (long)TILE);
                row = (0xFFul << k) & 0xFFul;
            } else {      /* x ≤ ⌊(er − t) / −ex⌋: n₁ = that + 1 pixels, r(y) = r₀ >> (N − n₁) (Eq. 4.2) */
                long n1 = clamp(floor_div(er - t, -ex) + 1, 0L, (long)TILE);
                row = 0xFFul >> (TILE - n1);
            }
            m |= row << (TILE * y); /* Eq. 4.3 */
        }
    } else {
        /* columns (Knecht Eq. 4.4–4.6), unit column c₀ = 0x0101…01 */
        const ulong c0 = 0x0101010101010101ul;
        for (int x = 0; x < TILE; ++x) {
            long ec = e + x * ex;
            ulong col;
            if (ey > 0) { /* y ≥ ⌈(t − ec) / ey⌉ */
                long k = clamp(-floor_div(ec - t, ey), 0L, (long)TILE);
                col = k < TILE ? c0 << (TILE * k) : 0;
            } else {      /* y < n₁(x) (Eq. 4.4–4.5) */
                long n1 = clamp(floor_div(ec - t, -ey) + 1, 0L, (long)TILE);
                col = n1 > 0 ? c0 >> (TILE * (TILE - n1)) : 0;
            }
            m |= col << x; /* Eq. 4.6 */
        }
    }
    return m;
}

typedef struct {
    long ax, ay, ex, ey, t; /* corner A, pixel steps of E, threshold (0: owned, 1: not) */
    long dx, dy;
} Edge;

static inline Edge make_edge(long ax, long ay, long bx, long by) {
    Edge g;
    g.ax = ax, g.ay = ay, g.dx = bx - ax, g.dy = by - ay;
    g.ex = -g.dy << SOMBRA_SUBPIXEL_BITS;
    g.ey = g.dx << SOMBRA_SUBPIXEL_BITS;
    g.t = (g.dy > 0 || (g.dy == 0 && g.dx < 0)) ? 0 : 1; /* top-left rule */
    return g;
}

/* E at the centre of pixel (px, py). */
static inline long edge_at(const Edge* g, int px, int py) {
    long cx = ((long)px << SOMBRA_SUBPIXEL_BITS) + HALF_PIXEL, cy = ((long)py << SOMBRA_SUBPIXEL_BITS) + HALF_PIXEL;
    return g->dx * (cy - g->ay) - g->dy * (cx - g->ax);
}

/* Pixels of the tile inside the screen. */
static inline ulong screen_mask(int tx, int ty, __global const RasterScreenGpu* s) {
    int cols = min(TILE, (int)s->width - tx * TILE), rows = min(TILE, (int)s->height - ty * TILE);
    ulong row = 0xFFul >> (TILE - cols);
    ulong m = 0;
    for (int y = 0; y < rows; ++y) m |= row << (TILE * y);
    return m;
}

/* Walks the tiles of triangle i's bounding box: counts (WRITE 0) or writes (WRITE 1) its masks. */
static inline void raster_triangle(uint i, __global const ScreenTriangleGpu* tris, __global const RasterScreenGpu* s,
                            __global uint* counts, __global const uint* first_chunk, __global uint* fill,
                            __global ulong* masks, __global uint* ids, __global uint* overflow, int write) {
    __global const ScreenTriangleGpu* tri = tris + i;
    long x0 = tri->x.x, y0 = tri->y.x, x1 = tri->x.y, y1 = tri->y.y, x2 = tri->x.z, y2 = tri->y.z;
    long area2 = (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0);
    if (area2 == 0) return; /* zero-area and edge-on triangles cover nothing */
    if (area2 < 0) {        /* wind with positive area */
        long tx = x1, ty = y1;
        x1 = x2, y1 = y2, x2 = tx, y2 = ty;
    }
    Edge g0 = make_edge(x0, y0, x1, y1), g1 = make_edge(x1, y1, x2, y2), g2 = make_edge(x2, y2, x0, y0);
    /* pixels whose centres lie in the bounding box, clamped to the screen */
    long lo_x = min(x0, min(x1, x2)), hi_x = max(x0, max(x1, x2));
    long lo_y = min(y0, min(y1, y2)), hi_y = max(y0, max(y1, y2));
    long px0 = max(-floor_div(HALF_PIXEL - lo_x, 1L << SOMBRA_SUBPIXEL_BITS), 0L);
    long px1 = min(floor_div(hi_x - HALF_PIXEL, 1L << SOMBRA_SUBPIXEL_BITS), (long)s->width - 1);
    long py0 = max(-floor_div(HALF_PIXEL - lo_y, 1L << SOMBRA_SUBPIXEL_BITS), 0L);
    long py1 = min(floor_div(hi_y - HALF_PIXEL, 1L << SOMBRA_SUBPIXEL_BITS), (long)s->height - 1);
    if (px0 > px1 || py0 > py1) return;
    for (int ty = (int)(py0 / TILE); ty <= (int)(py1 / TILE); ++ty)
        for (int tx = (int)(px0 / TILE); tx <= (int)(px1 / TILE); ++tx) {
            int ox = tx * TILE, oy = ty * TILE;
            ulong m = screen_mask(tx, ty, s);
            m &= edge_mask(edge_at(&g0, ox, oy), g0.ex, g0.ey, g0.t);
            m &= edge_mask(edge_at(&g1, ox, oy), g1.ex, g1.ey, g1.t);
            m &= edge_mask(edge_at(&g2, ox, oy), g2.ex, g2.ey, g2.t);
            if (m == 0) continue;
            uint tile = (uint)ty * s->tiles_x + (uint)tx;
            if (!write) {
                atomic_inc(counts + tile);
                continue;
            }
            uint slot = atomic_inc(fill + tile);
            if (slot >= counts[tile]) { /* cannot happen (both passes compute the same masks): counted */
                atomic_inc(overflow);
                continue;
            }
            uint at = first_chunk[tile] * SOMBRA_TILE_CHUNK + slot;
            masks[at] = m;
            ids[at] = i;
        }
}

__kernel void raster_count(__global const ScreenTriangleGpu* tris, uint triangle_count,
                           __global const RasterScreenGpu* screen, __global uint* counts) {
    uint i = get_global_id(0);
    if (i < triangle_count) raster_triangle(i, tris, screen, counts, 0, 0, 0, 0, 0, 0);
}

__kernel void raster_write(__global const ScreenTriangleGpu* tris, uint triangle_count,
                           __global const RasterScreenGpu* screen, __global const uint* counts,
                           __global const uint* first_chunk, __global uint* fill, __global ulong* masks,
                           __global uint* ids, __global uint* overflow) {
    uint i = get_global_id(0);
    if (i < triangle_count)
        raster_triangle(i, tris, screen, (__global uint*)counts, first_chunk, fill, masks, ids, overflow, 1);
}
