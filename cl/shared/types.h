/* sombra — the one definition of every struct that crosses the host/kernel boundary.
 * Compiles as OpenCL C 1.2 and as C++17. Every field is 4 bytes or a 16-byte vector, grouped so
 * that no compiler inserts padding; tests/test_layout.cpp checks sizeof/offsetof against the
 * kernel's view. */
#ifndef SOMBRA_SHARED_TYPES_H
#define SOMBRA_SHARED_TYPES_H

#ifdef __OPENCL_C_VERSION__
typedef float4 sb_float4;
typedef int4 sb_int4;
typedef uint sb_uint;
#else
#include <CL/cl_platform.h>
typedef cl_float4 sb_float4;
typedef cl_int4 sb_int4;
typedef cl_uint sb_uint;
#endif

/* Edge length of the bricks used for empty-space skipping (Hadwiger §3: brick min/max). 4 rather
 * than 8: thin structures (the CT's stent) leave more of the volume in empty bricks; DSM generation
 * of the CT takes ~17 % less CPU time (bench/README.md "DSM generation"), the camera pass a little less. */
#define SOMBRA_BRICK_SIZE 4
/* Upper bound on volumes per scene (the segment cursor's active set is a 32-bit mask; kernels size
 * their per-ray arrays by the scene's own count, SOMBRA_VOLUME_SLOTS). */
#define SOMBRA_MAX_VOLUMES 32
#define SOMBRA_MAX_LIGHTS 8
/* Kernels size their per-ray arrays by the scene's volume count (a -D define) when it is given. */
#ifndef SOMBRA_VOLUME_SLOTS
#define SOMBRA_VOLUME_SLOTS SOMBRA_MAX_VOLUMES
#endif
#ifndef SOMBRA_LIGHT_SLOTS
#define SOMBRA_LIGHT_SLOTS SOMBRA_MAX_LIGHTS
#endif

enum {
    SOMBRA_LIGHT_DIRECTIONAL = 0,
    SOMBRA_LIGHT_SPOT = 1,
    SOMBRA_LIGHT_POINT = 2
};

/* One volume instance of the scene, as the kernels see it. */
typedef struct {
    /* voxel = (dot(row0.xyz, p) + row0.w, ...): world position → continuous voxel coordinate,
     * voxel centres at integers 0..dims-1. Its 3×3 part is also the Jacobian used to turn a
     * voxel-space gradient into a world-space one (g_world = Jᵀ g_voxel). */
    sb_float4 world_to_voxel[3];
    sb_int4 dims;        /* x, y, z, unused */
    sb_int4 brick_dims;  /* bricks along x, y, z, unused */
    /* World box the volume is active in, besides its voxel box (VolumeInstance::clip_min/max): a
     * rank of a distributed render owns a region of the world, and its voxel grid holds a ghost
     * layer past the region for interpolation. Read only with SOMBRA_VOLUME_CLIP (xyz; w unused). */
    sb_float4 clip_min, clip_max;
    sb_uint data_offset;   /* first voxel in the volume buffer (buffer path) */
    sb_uint brick_offset;  /* first brick flag in the occupancy buffer */
    sb_uint tf_offset;     /* first entry of this volume's transfer-function table */
    sb_uint tf_size;       /* entries in the table (≥ 2) */
    float tf_domain_min;   /* data value of table entry 0 */
    float tf_domain_scale; /* (tf_size − 1) / (domain max − domain min) */
    float step;            /* ray-marching step in world units */
    float image_z_offset;  /* first z slice of this volume in the 3D image atlas (image path) */
    float ambient, diffuse, specular, shininess; /* Phong material (Knecht Eq. 3.8) */
    /* Polyhedral bound (issue 4; Knecht §3.1.2): the volume is active only inside its box AND
     * inside this closed mesh. Its world triangles are [bound_first, bound_first + bound_count) of
     * the host's bound-triangle list (PackedScene::bound_triangles; the device holds them in BVH
     * order, each with its volume in corner.w); bound_count 0: bounded by the box only. */
    sb_uint bound_first;
    sb_uint bound_count;
    /* Pre-integration (volume_sample.h preintegrated_sigma): F[i] = ∫₀ⁱ σ du over the table (u in
     * entries, σ linear between entries), as float pairs (hi, lo) at tf_integral_offset floats
     * into the transfer-function buffer; F[i] = hi + lo to ~48 bits. */
    sb_uint tf_integral_offset;
    /* 1: the transfer function reaches σ·step ≥ 2 somewhere (one step can absorb 86 %): the light
     * passes split each interval where the ray crosses a voxel-centre plane (traversal.h
     * interval_volume_depth), so a thin near-opaque feature between two samples counts in full */
    sb_uint stiff;
} VolumeGpu;

typedef struct {
    sb_float4 position;   /* spot/point: world position */
    sb_float4 direction;  /* directional/spot: unit vector the light travels along */
    sb_float4 color;      /* rgb × intensity */
    sb_uint type;         /* SOMBRA_LIGHT_* */
    float cos_outer;      /* spot: cosine of the cone's half angle (no light outside) */
    float cos_inner;      /* spot: cosine where the smooth edge starts (full light inside) */
    float att_constant;   /* distance attenuation 1 / (c + l·d + q·d²) (course slides) */
    float att_linear;
    float att_quadratic;
} LightGpu;

/* One light's deep shadow map views (the dsm module's own per-light data, techniques/dsm.h):
 * [first, first + count) of the views, 1 for a spot or directional light, 6 for a point light,
 * those of its clusters when clustered, 0 if none. */
typedef struct {
    sb_uint first;
    sb_uint count;
} DsmLightViews;

/* One deep shadow map view: a spot light, one cube face of a point light (90°), or a
 * directional light's orthographic box fitted to the scene. Depth convention (docs/architecture.md): the
 * distance from the light along the texel's ray (perspective) or from the near plane along
 * axis_z (orthographic), in world units — never NDC z. */
typedef struct {
    sb_float4 axis_x, axis_y, axis_z; /* orthonormal light frame; axis_z looks into the scene */
    sb_float4 origin;    /* perspective: the light's position; orthographic: centre of the near plane */
    float extent_x, extent_y; /* perspective: tan(half field of view); orthographic: half width, height */
    sb_uint resolution;  /* texels per side */
    sb_uint perspective; /* 1: perspective, 0: orthographic */
    sb_uint first_texel; /* index of texel (0, 0) in the storage's per-texel arrays */
    sb_uint max_nodes;   /* most nodes in one texel (statistics; lookups walk, cl/dsm_storage_common.h) */
    float near_depth, far_depth; /* depth range of the scene's boxes in this view */
    /* Texel (x, y)'s ray passes through (x + ½ + ray_shift + jitter·(h − ½), …) texels of the image
     * plane, h a hash of (x, y, jitter_seed) (shared/hash.h sombra_texel_ray_coord). 0, 0 in maps
     * that are looked up; only the sub-pixel maps of pre-filtering shift or jitter their rays. */
    float ray_shift;
    float jitter;        /* stratified jitter: the extent of the ray's range in texels (≤ 1) */
    sb_uint jitter_seed;
    /* Clustered maps (Knecht §3.4): the volumes this view's map holds (bit i: volume i; all bits
     * when unclustered; its meshes are chosen on the host), and the cluster of its light it
     * belongs to. A light's views are consecutive and grouped by cluster; the lookup takes one
     * covering view per cluster and multiplies the clusters' transmittances (Eq. 3.12). */
    sb_uint volume_mask;
    sb_uint cluster;
    sb_uint pad0, pad1;
} DsmViewGpu;

typedef struct {
    sb_float4 position;
    sb_float4 forward;  /* unit view direction */
    sb_float4 right;    /* scaled by tan(fov/2) · aspect */
    sb_float4 up;       /* scaled by tan(fov/2) */
    sb_float4 background;
    sb_uint width, height;
    sb_uint volume_count, light_count;
    float ambient_intensity;       /* i_a of Knecht Eq. 3.8 */
    float termination_transmittance; /* early ray termination below this t_acc */
    sb_uint jitter_seed;
    float phase_g; /* single scattering (SOMBRA_SCATTERING): Henyey–Greenstein asymmetry g */
    /* The pixels render_camera's launch covers: launch row j is image row first_row + j · row_stride,
     * written to image row j; in it, launch packet i is the image's packet of SOMBRA_LANES pixels
     * i · packet_stride + (first_packet + j) mod packet_stride, written where the image's would be
     * (a frame: 0, 1, 0, 1; the shadow cache's auto probe renders every packet_stride-th packet of
     * rows spread over the image, staggered from row to row) */
    sb_uint first_row, row_stride;
    sb_uint first_packet, packet_stride;
} CameraGpu;

/* A volume's pre-compressed visibility table (Hadwiger §3.2; src/shadows/precompression.h):
 * entry (front, back) of `size`² holds ≤ 4 nodes (fraction of the step, opacity) at
 * [4·(entry_offset + front·size + back), +4) of the shared node arrays. */
typedef struct {
    sb_uint entry_offset;
    sb_uint size;        /* entries per axis; 0: no table for this volume */
    float domain_min;    /* density of index 0 */
    float domain_scale;  /* (size − 1) / (domain max − domain min) */
} PrecompressionGpu;

/* Raster stage (Knecht §3.1.1, §4.1.1): the screen is split into tiles of SOMBRA_TILE_SIZE²
 * pixels; a tile's list holds (64-bit coverage mask, triangle) pairs in chunks of
 * SOMBRA_TILE_CHUNK entries. Screen positions are fixed point with SOMBRA_SUBPIXEL_BITS fraction
 * bits, so that edge functions are exact integers (one fill rule, no cracks). */
#define SOMBRA_TILE_SIZE 8
#define SOMBRA_TILE_CHUNK 64
#define SOMBRA_SUBPIXEL_BITS 8
#define SOMBRA_TRI_BACK_FACING 1u
/* The triangle bounds a volume (ScreenTriangleGpu.mesh is then the volume's index): its fragments
 * toggle that volume's inside bit in the segment cursor (cl/traversal.h); never shaded. */
#define SOMBRA_TRI_BOUND 2u

/* A triangle projected to the screen. Pixel (i, j) has its centre at (i + ½, j + ½); screen x runs
 * along the view's axis_x, y along axis_y (for a camera: right and down). */
typedef struct {
    sb_int4 x;  /* fixed-point x of corners 0, 1, 2; w unused */
    sb_int4 y;  /* fixed-point y of corners 0, 1, 2; w unused */
    /* q(x, y) = q0 + dq/dx·(x − x0) + dq/dy·(y − y0) in pixels, (x0, y0) corner 0: q = 1 / view z
     * (perspective) or view z (orthographic), affine over the screen. (q0, dq/dx, dq/dy, unused) */
    sb_float4 depth_plane;
    sb_uint source;  /* source triangle: index over all meshes' triangles, mesh after mesh */
    sb_uint mesh;    /* mesh instance; with SOMBRA_TRI_BOUND: the volume it bounds */
    sb_uint flags;   /* SOMBRA_TRI_BACK_FACING: its world normal (right-hand rule) faces away;
                      * SOMBRA_TRI_BOUND: a polyhedral volume bound, not a surface */
    sb_uint pad0;
} ScreenTriangleGpu;

/* One fragment of a pixel: a triangle crossing its ray (cl/segments.cl). A pixel's fragments,
 * sorted by depth, bound its homogeneous segments (Knecht §3.1.2). */
typedef struct {
    float depth;      /* DsmViewGpu convention: distance along the ray (perspective) or view z */
    sb_uint triangle; /* index into the rasterized ScreenTriangleGpu list */
} FragmentGpu;

/* A mesh triangle in the world, for shading surface fragments (cl/surfaces.h): indexed by
 * ScreenTriangleGpu.source. Normals are interpolated barycentrically at the fragment's point.
 * Bound triangles (VolumeGpu.bound_first) use the same layout, corner.w = the volume's index and
 * no normals. */
typedef struct {
    sb_float4 corner;    /* corner 0; w: the mesh's opacity (shadow rays) */
    sb_float4 corner1;   /* corner 1 (xyz) */
    sb_float4 corner2;   /* corner 2 (xyz); corners, not edges: a corner that triangles share has
                          * the same bits in each, so ray_triangle_t is watertight */
    sb_float4 normal[3]; /* unit normal at each corner (the face normal if the mesh has none) */
} SurfaceTriangleGpu;

/* A node of the bounding-volume hierarchy over the world-space mesh triangles that shadow rays
 * cross (src/geometry/bvh.h, cl/bvh.h). Nodes are stored depth first: an inner node's first child
 * follows it, `first` indexes its second child; a leaf holds triangles [first, first + count) of
 * the triangle array in BVH order. */
typedef struct {
    sb_float4 box_min;  /* xyz: the node's bounding box (w unused) */
    sb_float4 box_max;
    sb_uint first;      /* leaf: first triangle; inner node: index of the second child */
    sb_uint count;      /* leaf: triangles (≥ 1); inner node: 0 */
    sb_uint pad0, pad1;
} BvhNodeGpu;
/* The deepest a hierarchy gets (src/geometry/bvh.cpp: 32 SAH levels, then median splits of at most
 * 2^32 triangles); the kernels' traversal stack holds this many nodes. */
#define SOMBRA_BVH_MAX_DEPTH 64

/* A mesh instance's material: Phong (Knecht Eq. 3.8) and the opacity of one surface crossing. */
typedef struct {
    sb_float4 color;     /* rgb, a: opacity of one crossing */
    float ambient, diffuse, specular, shininess;
} SurfaceMaterialGpu;

/* The screen the raster and segment kernels work on. */
typedef struct {
    sb_uint width, height;  /* pixels */
    sb_uint tiles_x, tiles_y;
    sb_uint perspective;    /* 1: q = 1 / view z; 0: q = view z */
    float extent_x, extent_y; /* perspective: tan(half field of view); orthographic: half width, height */
    float pixel_shift;      /* pixel (i, j) samples the image plane at (i + ½ + shift, j + ½ + shift) (DsmViewGpu.ray_shift) */
} RasterScreenGpu;
/* Optical depth past which a shadow march stops: exp(−13.8155) = 10⁻⁶ of the light is left. */
#define SOMBRA_OPAQUE_DEPTH 13.8155f
/* Cone shadows: cubes of at least this radius (cells) have their faces on the nearest cell faces
 * (cl/lowpass.h, sat_cone_depth). */
#define SOMBRA_CONE_SNAP_RADIUS 2

/* Fixed-point optical depth in the summed-area tables: units per unit of τ, and the most τ one
 * cell holds (stiffer cells are clamped: exp(−4096/W²) is 0 for every W up to 40 cells). With
 * (dims+1)³ ≤ 2^29 entries no sum overflows 2^63. */
#define SOMBRA_SAT_UNITS_PER_TAU 4194304.0f /* 2^22 */
#define SOMBRA_SAT_MAX_CELL_TAU 4096.0f
#define SOMBRA_SAT_MAX_ENTRIES (1u << 29)

/* One light's view of a light-aligned summed-area table (Ament §4.2.1–4.2.2; cl/lowpass.h,
 * src/shadows/sat_grid.h). The grid holds cells of optical depth σ·h (h = cell length) as 64-bit
 * fixed-point integers; the table is exclusive: (dims+1)³ entries, S(i,j,k) = Σ cells < (i,j,k),
 * entry (i,j,k) at data_offset + i + (dims.x+1)·(j + (dims.y+1)·k). Lights whose directions are
 * ± the same grid axes share one table (orthodirectional lights, Ament Eq. 14–15). A light's
 * volumes may be split over several tables on one lattice, one per group of volumes: light m's
 * first table at index m, the others after every light's first, chained by `next`; a lookup sums
 * the chain (σ adds over volumes). */
typedef struct {
    sb_float4 to_grid[3];  /* grid coordinate a (in cells) = dot(to_grid[a].xyz, p) + to_grid[a].w */
    sb_int4 dims;          /* cells along the three grid axes; w: 0 = no table for this light */
    sb_uint data_offset;   /* first entry of this table in the shared SAT buffer */
    sb_uint light_axis;    /* grid axis along the light (0, 1, 2) */
    sb_uint light_positive;/* 1: the light lies towards +light_axis, 0: towards −light_axis */
    sb_uint filter_cells;  /* lateral box width W in cells (≥ 1; Ament Eq. 13, U = V = W/2) */
    float tau_per_unit;    /* optical depth of one fixed-point unit */
    float cell_size;       /* world length of a cell */
    float cone_tan;        /* cone shadows: tangent of the cone's half angle */
    sb_uint next;          /* the light's next CSAT in the grid array (the tables add up); 0: the last */
} SatGridGpu;

/* A point light's spherical summed-area table (SSAT, Ament §4.2.3): a regular grid over azimuth φ,
 * polar angle θ and radius r around the light, r along grid axis 2. A cell holds σ·Δr·w_θ with
 * w_θ = (cos θ_j − cos θ_j+1)/Δθ (its solid angle over Δφ·Δθ), so a box sum × Δφ·Δθ / (the box's
 * solid angle) is the solid-angle average of the optical depth of the rays in the spherical
 * pyramid (Eq. 22–24). Same fixed point and table layout as SatGridGpu. A light's volumes may be
 * split over several tables, one per group of volumes (each over the angles its group subtends):
 * the grid array holds light m's first table at index m and the others after every light's first,
 * chained by `next`; a lookup sums the chain's optical depths (σ adds over volumes). */
typedef struct {
    sb_float4 axes[3];    /* world directions of the spherical frame: x (φ = 0, θ = π/2), y, z (θ = 0) */
    sb_float4 light;      /* light position (xyz) */
    sb_float4 start;      /* φ, θ, r of the grid's first corner */
    sb_float4 cell;       /* Δφ, Δθ, Δr */
    sb_int4 dims;         /* cells along φ, θ, r; w: 0 = no table for this light */
    sb_uint data_offset;  /* first entry of this table in the shared SAT buffer */
    sb_uint wrap_phi;     /* 1: the grid spans all φ (light inside the bounds), boxes wrap at ±π */
    float half_width;     /* U = V: half the filter width in world units (Eq. 16) */
    float tau_per_unit;
    sb_uint volume_mask;  /* the volumes whose σ this table holds (bit i: volume i) */
    sb_uint next;         /* the light's next SSAT in the grid array (the tables add up); 0: the last */
    /* cos, sin of the largest angle between axes[0] and a direction from the light into the table
     * (−1, 0 for the whole sphere): a lookup whose pyramid stays outside that cone adds 0 */
    float cos_reach, sin_reach;
} SsatGridGpu;

/* The shadow cache (Ament Alg. 1; the EG 2009 course's 3D texture caching): for one volume and one
 * light, the shadow term at a lattice of points spanning the volume's voxel coordinates
 * [0, dims − 1] (lattice point k at k · spacing), filled by the shadow technique and kept while
 * its key holds; camera samples read it trilinearly. Entry (x, y, z) at
 * offset + x + dims.x · (y + dims.y · z). Table index: volume · light count + light. */
typedef struct {
    sb_int4 dims;       /* lattice points per axis; w unused */
    sb_float4 spacing;  /* voxel units between lattice points (xyz; 1 where dims is 1) */
    sb_uint offset;     /* first entry in the cache buffer */
    /* voxel units around a lattice point in which a shaded sample may read it (a lattice cell,
     * one step of pre-integration, the voxel a sample interpolates): the fill evaluates only points
     * with a possibly visible brick that near (VolumeGpu.brick_offset) */
    float reach;
    /* the lattice's points along y and z come in blocks of row_block neighbours, spacing /
     * row_block_stride apart, the blocks spacing apart, the first at block_origin: index k at voxel
     * block_origin + (k / row_block) · spacing + (k % row_block) · spacing / row_block_stride
     * (lattice_voxel in render.cl). The frame's lattices: 1, 1 and 0 (k · spacing); auto's probe
     * fills blocks of neighbouring points, which cost per point what the frame's fill does
     * (src/render/shadow_cache.cpp probe_volume_costs) */
    sb_uint row_block, row_block_stride;
    /* world = (dot(row.xyz, voxel) + row.w, …): the volume's voxel → world transform (the fill) */
    sb_float4 voxel_to_world[3];
    /* voxel coordinates of the first block along y and z. A light lattice's columns: x, the first
     * one's index; w, the columns from one packet of SOMBRA_LANES to the next (auto's probe fills
     * every k-th packet; 0: SOMBRA_LANES, neighbouring packets) */
    sb_float4 block_origin;
    /* the visible fill's bit masks (one bit per lattice point, src/render/shadow_cache.cpp
     * prepare_volume_fill): point (x, y, z) is bit x % 32 of word mark_offset + (y + dims.y · z) ·
     * mark_row_words + x / 32 (rows start on a word) */
    sb_uint mark_offset, mark_row_words, mark_pad0, mark_pad1;
    /* lattice coordinates q of voxel point v (render.cl lattice_cell): q.x = dot(rows[0], (v, 1)) /
     * dot(rows[3], (v, 1)), q.y likewise with rows[1], q.z = dot(rows[2], (v, 1)). A volume lattice:
     * rows diag(1 / spacing) and rows[3] = (0, 0, 0, 1). */
    sb_float4 voxel_to_lattice[4];
    /* A light's lattice (column_axes.w = 1; src/render/shadow_cache_columns.cpp): lattice column
     * (x, y) lies on one ray of the light, point z = 0 nearest the light, so that one march along
     * the column fills all its points (render.cl shadow_cache_fill_columns). Voxel axes a, b, c =
     * column_axes.xyz; point (x, y, z): v_c = along.x + z · along.y, w = along.z · v_c + along.w,
     * v_a = across[0].x + across[0].y · v_c + w · (across[0].z + x · across[0].w), v_b likewise
     * with across[1] and y. A directional light: w = 1 (parallel columns sheared along it); a
     * point light: w = v_c − light_c, the columns fan out from the light. column_axes.w = 0: a
     * volume lattice (voxel k · spacing). */
    sb_int4 column_axes;
    sb_float4 column_along;
    sb_float4 column_across[2];
} ShadowCacheGpu;

#endif /* SOMBRA_SHARED_TYPES_H */
