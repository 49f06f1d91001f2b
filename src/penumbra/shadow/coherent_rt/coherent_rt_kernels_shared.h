// `coherent-rt` on the GPU (coherent_rt_gpu.cpp; agrawala2000 §5): the kernels' parameters and
// buffers, byte by byte, and the tile order and per-point light sum both devices use. Common
// subset of C++ and GLSL (core/shader_compat.h), scalar block layout.
//
// prepare (stage "precompute", the CPU's phase), per reference view (4 corners by default):
//   the GPU rasterizer's depth map, then one thread per texel:
//   crt_links    its walls (reference_images_shared.h crt_links_of), uint per texel;
//   crt_floors   its biased floor (crt_floor_of), float per texel (window depth, +inf empty);
//   crt_ranges   level 0 of the min/max pyramid (crt_range_of) and of the connectedness tree;
//   the shared pyramid builder (gpu/minmax_pyramid_gpu.h), and per level above 0
//   crt_connected one thread per node (crt_node_connected_of).
// evaluate (stage "trace"): coherent_rt_tiles, ONE THREAD PER TILE of the image (the `tile`
// parameter's tiles, clipped to the window): it walks its pixels in the CPU's Hilbert order and
// their view samples in slot order, so SoftShad (soft_shad_shared.h) predicts each point from the
// very points the CPU's tile shaded before it (agrawala2000 §5.2's coherence is sequential within
// a tile; tiles are independent). Each traced cell's ray goes through the images
// (depth_image_trace_shared.h) or, with tracer=geometry, the GPU's BVH.
#ifndef PENUMBRA_SHADOW_COHERENT_RT_COHERENT_RT_KERNELS_SHARED_H
#define PENUMBRA_SHADOW_COHERENT_RT_COHERENT_RT_KERNELS_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/raster/raster_shared.h"
#include "penumbra/shadow/coherent_rt/depth_image_trace_shared.h"
#include "penumbra/shadow/coherent_rt/reference_images_shared.h"
#include "penumbra/shadow/coherent_rt/soft_shad_shared.h"
#include "penumbra/shadow/near_field_shared.h"

PN_SHARED_BEGIN

// Point d of the Hilbert curve filling an n x n square (n a power of two): a tile's pixel order
// (§5.2: consecutive points close to each other).
PN_INLINE void crt_hilbert_point(int n, int d, PN_OUT(int) x, PN_OUT(int) y) {
  int px = 0;
  int py = 0;
  for (int s = 1; s < n; s *= 2) {
    int rx = 1 & (d / 2);
    int ry = 1 & (d ^ rx);
    if (ry == 0) {
      if (rx == 1) {
        px = s - 1 - px;
        py = s - 1 - py;
      }
      int t = px;
      px = py;
      py = t;
    }
    px += s * rx;
    py += s * ry;
    d /= 4;
  }
  x = px;
  y = py;
}

// One visible cell's share of eq. 1 (area sampling): the light point q seen from p (shading normal
// ns) through the light's normal n, before the radiance and area / n.
PN_INLINE float crt_cell_irradiance(vec3 p, vec3 ns, vec3 light_n, vec3 q) {
  vec3 dv = q - p;
  float d2 = dot(dv, dv);
  vec3 w = dv / sqrt(d2);
  float cos_l = max(0.0f, -dot(w, light_n));
  return max(0.0f, dot(ns, w)) * cos_l / d2;
}

// The near field of a shadow ray (penumbra's addition; coherent-rt.md "The near field"): how far
// from its origin, along the segment of length tfar, the ray is traced through the scene itself
// before the depth images answer for the rest. `scale` is near_field (texels) times the images'
// largest texel at unit depth, `eye` and `forward` the images' (shared) depth axis: the images
// answer for occluders whose penumbra at p is at least near_field texels of the images at p's
// depth wide (near_field_length). Nearer, the images hold a ray's occluders only as whole texels'
// floors pushed back by their biases (a leaf a few centimetres under another).
PN_INLINE float crt_near_field_length(vec3 p, vec3 eye, vec3 forward, float scale, float light_width, float tfar) {
  float z = max(0.0f, dot(p - eye, forward));
  return near_field_length(scale * z, tfar, light_width);
}

// The light field (coherent-rt.md, "Casters beside the light"): where the shadow ray org + t dir,
// t in [0, tfar], comes nearer the light's plane (centre c, unit normal n toward the scene) than
// depth z_l, the reference images cannot hold a caster that ShadowRegion::light_field says may be
// there, and the rest of the ray is traced through the scene. The t it starts at: tfar where the
// ray never comes that near (and for z_l = 0: no light field), 0 where it starts there.
PN_INLINE float crt_light_field_start(vec3 org, vec3 dir, float tfar, vec3 c, vec3 n, float z_l) {
  if (!(z_l > 0.0f)) return tfar;
  float z0 = dot(org - c, n);
  if (!(z0 > z_l)) return 0.0f;
  float dz = dot(dir, n);  // < 0 toward the light
  if (!(dz < 0.0f)) return tfar;
  return min(tfar, (z0 - z_l) / -dz);
}

// What the tiles read besides their buffers, 168 bytes (the near field's 32 and the light field's
// 4 at bytes 120-155, 4 bytes of padding, the sphere emitter's address at 160-167), uploaded with
// each evaluate.
struct CrtTileBlock {
  CrtTraceOptions trace;  // 24 bytes
  int cols;               // light cells (stratification_grid)
  int rows;
  int sub_grid;
  uint coherence;
  uint shortcut;
  float reset_distance;
  int window_x0;  // the rendered window within the image
  int window_y0;
  int window_x1;
  int window_y1;
  int spp;        // view samples per pixel (slots per pixel)
  int tile;       // tile edge (power of two)
  int tile_x0;    // the window's first tile (the image's tile grid)
  int tile_y0;
  int tiles_x;
  int tiles_y;
  int n;          // light samples (cells)
  int grid_cols;  // StratifiedGrid(n)
  float inv_cols;
  float inv_rows;
  int images;
  int span_capacity;  // spans per list per tile
  uint own_plane;     // closed meshes: light behind the point's plane is blocked without a ray
  uint geometry;      // tracer=geometry: rays through the GPU's BVH
  vec3 near_eye;      // crt_near_field_length's depth axis and scale (0: no near field)
  float near_scale;
  vec3 near_forward;
  float near_light_width;  // near_field_light_width of the light
  float light_field;       // crt_light_field_start's z_l (0: no light field)
  uint pad;
  // A sphere light's GpuLight, whose closed form times V is E, where the tiles sample its central
  // disk (soft_shad.h sampled_light); 0: E from the samples (eq. 1).
  uint64_t sphere_emitter;
};

// A tile's scratch, `words` uint32 words each (crt_tile_scratch_words): stamps (n sub^2),
// packed cell flags (n), jittered samples (2 n), the queue (n), blocker points (3 n sub^2), light
// points (3 n), the sampler's SoftShadState (16) and where the tile stands (2: its step, whether
// that step's point has begun), kept from one dispatch of the tile's work to the next.
PN_INLINE uint crt_tile_scratch_words(int n, int sub_grid) {
  uint cells = uint(n);
  uint subs = cells * uint(sub_grid) * uint(sub_grid);
  return subs + cells + 2u * cells + cells + 3u * subs + 3u * cells + 16u + 2u;
}

// What the tiles count, 168 bytes (one atomic per tile and counter): SoftShadCounts, CrtTraceCounts
// (overflow: some ray's span lists were too small: the host traces again with longer ones), the
// own-plane cells, the BVH rays of tracer=geometry and of the near and light fields.
struct CrtGpuCounters {
  uint64_t points;
  uint64_t rays;
  uint64_t resets;
  uint64_t predicted_wrong;
  uint64_t shortcut_cells;
  uint64_t blocker_points;
  uint64_t traced;       // rays through the images (CrtTraceCounts::rays)
  uint64_t blocked;
  uint64_t maps_walked;
  uint64_t clear_misses;
  uint64_t intervals_exhausted;
  uint64_t connected_hits;
  uint64_t hidden_everywhere;
  uint64_t nodes;
  uint64_t texels;
  uint64_t own_plane_cells;
  uint64_t geometry_rays;
  uint64_t near_rays;  // the near fields traced through the BVH (crt_near_field_length)
  uint64_t light_rays;  // the light fields traced through the BVH (crt_light_field_start)
  uint overflow;
  // Some tile's dispatch ran into the driver's loop limit (lavapipe: 65535 loop iterations per
  // invocation; the loops then stop early, silently): what is written is wrong and the host traces
  // again with less work per dispatch. limited_after: the fewest cells such a tile had evaluated.
  uint limited;
  uint limited_after;
  uint unfinished;  // tiles with work left after the last dispatch
};

// coherent_rt_tiles.comp's push constants.
struct CrtTilesParams {
  uint64_t scene;
  uint64_t samples;     // GpuViewSample[slots]
  uint64_t light;       // GpuLight
  uint64_t visibility;  // float per slot
  uint64_t irradiance;  // vec3 per slot
  uint64_t block;       // CrtTileBlock
  uint64_t descs;       // CrtImageDesc[images]
  uint64_t scratch;     // per tile crt_tile_scratch_words words
  uint64_t spans;       // per tile 3 span_capacity vec2
  uint64_t counters;    // CrtGpuCounters
  uint64_t seed;
  int light_index;
  int frame;
  // 0: every tile starts afresh; 1: each goes on where its last dispatch stopped. A dispatch
  // takes at most cell_budget units of a tile's work (<= 0: all): steps passed over, point starts,
  // light cells evaluated.
  int resume;
  int cell_budget;
  int canary;  // 2: a loop of this many iterations tells whether the driver's loop limit was hit
};

// crt_links, crt_floors, crt_ranges and crt_connected's push constants.
struct CrtBuildParams {
  uint64_t scene;      // SceneDesc (crt_floors: which object each texel's triangle is of)
  uint64_t z;          // the depth map's planes
  uint64_t triangle;
  uint64_t links;      // uint per texel
  uint64_t floors;     // float per texel
  uint64_t nodes;      // the min/max pyramid
  uint64_t connected;  // uint per pyramid node
  uint64_t view;       // RasterView record
  uint64_t levels;     // the pyramid's level table
  CrtBuildOptions options;
  int width;
  int height;
  int level;  // crt_connected: the level built
  int level_count;
};

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::CrtTileBlock) == 168);
static_assert(sizeof(penumbra::shader::CrtGpuCounters) == 168);
static_assert(sizeof(penumbra::shader::CrtTilesParams) <= 128);
static_assert(sizeof(penumbra::shader::CrtBuildParams) <= 128);
#endif

#endif  // PENUMBRA_SHADOW_COHERENT_RT_COHERENT_RT_KERNELS_SHARED_H
