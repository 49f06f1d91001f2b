#version 460
// `coherent-rt` on the GPU (coherent_rt_kernels_shared.h; coherent_rt.cpp evaluate): ONE THREAD PER
// TILE. agrawala2000 §5.2's coherence is sequential: SoftShad predicts a point's light cells from
// the blocker points of the points shaded before it. The CPU shades each tile's pixels along a
// Hilbert curve, each tile with its own prediction; here each tile is one thread that walks its
// pixels in that very order, and each pixel's view samples in slot order, so every point follows
// the same points as on the CPU and gets the same prediction. Per point: the `reference` stream's
// stratified light points (area samples), SoftShad's cells to trace (soft_shad_shared.h), each
// traced through the reference depth images (depth_image_trace_shared.h) after its near field
// through the GPU's BVH (crt_near_field_length), or, with tracer=geometry, wholly through the BVH
// (closest hit: the blocker point), and eq. 1 (area sampling) over the visible cells. The tile's sampler and span lists live in its slices of two scratch buffers.
// A tile's work may be split over several dispatches (resume, cell_budget; lavapipe limits the
// loop iterations of one invocation): where it stands and the sampler wait in its scratch.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/bvh_traverse.glsl"
#include "penumbra/gpu/light_access.glsl"
#include "penumbra/core/rng_shared.h"
#include "penumbra/core/sampling_shared.h"
#include "penumbra/shadow/coherent_rt/coherent_rt_kernels_shared.h"
#include "penumbra/shadow/view_samples_shared.h"
#include "penumbra/trace/ray_shared.h"

// One tile a work group: each tile's walk is a long chain of dependent loads, so what hides their
// latency is many resident warps, not full ones. 32 tiles a group (one warp, 64 of an H200's 132
// SMs busy at 1920x1080) made a 480x270 frame 14.2 s against 5 s (NVIDIA, 2026-11-28).
layout(local_size_x = 1) in;
layout(push_constant, scalar) uniform Push { CrtTilesParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };
layout(buffer_reference, scalar) readonly buffer TileBlockRef { CrtTileBlock b; };
layout(buffer_reference, scalar) buffer CountersRef { CrtGpuCounters c; };
layout(buffer_reference, scalar) buffer SoftShadStateRef { SoftShadState s; };

void main() {
  CrtTileBlock b = TileBlockRef(pc.p.block).b;
  uint tile = pn_thread_index();
  if (tile >= uint(b.tiles_x) * uint(b.tiles_y)) return;
  scene_bind(pc.p.scene);
  GpuLight light = LightRef(pc.p.light).v;
  LightGeometry L = light.geometry;
  // The tile's slices.
  uint n = uint(b.n);
  uint subs = n * uint(b.sub_grid) * uint(b.sub_grid);
  uint64_t base = pc.p.scratch + uint64_t(tile) * uint64_t(crt_tile_scratch_words(b.n, b.sub_grid)) * 4UL;
  SoftShadRef r;
  r.stamp = base;
  r.cells = r.stamp + uint64_t(subs) * 4UL;
  r.samples = r.cells + uint64_t(n) * 4UL;
  r.queue = r.samples + uint64_t(n) * 8UL;
  r.blockers = r.queue + uint64_t(n) * 4UL;
  Vec3s points = Vec3s(r.blockers + uint64_t(subs) * 12UL);
  SoftShadStateRef saved = SoftShadStateRef(r.blockers + uint64_t(subs) * 12UL + uint64_t(n) * 12UL);
  Uints position = Uints(uint64_t(saved) + 64UL);  // the tile's step and whether its point has begun
  CrtSpansRef spans;
  spans.spans = pc.p.spans + uint64_t(tile) * uint64_t(3 * b.span_capacity) * 8UL;
  spans.capacity = b.span_capacity;
  CrtImagesRef images;
  images.descs = pc.p.descs;
  images.count = b.images;
  // The sampler: fresh at the tile's first dispatch, else as the tile's last dispatch left it.
  SoftShadState st;
  if (pc.p.resume == 0) {
    st = ss_make(b.cols, b.rows, b.sub_grid, b.coherence != 0u, b.shortcut != 0u, b.reset_distance);
    ss_clear(r, st);
  } else {
    st = saved.s;
  }
  SoftShadCounts sc;
  sc.points = 0u;
  sc.rays = 0u;
  sc.resets = 0u;
  sc.predicted_wrong = 0u;
  sc.shortcut_cells = 0u;
  sc.blocker_points = 0u;
  CrtTraceCounts tc;
  tc.rays = 0u;
  tc.blocked = 0u;
  tc.maps_walked = 0u;
  tc.clear_misses = 0u;
  tc.intervals_exhausted = 0u;
  tc.connected_hits = 0u;
  tc.hidden_everywhere = 0u;
  tc.nodes = 0u;
  tc.texels = 0u;
  tc.overflow = 0u;
  uint own_plane_cells = 0u, geometry_rays = 0u, near_rays = 0u, light_rays = 0u;
  int x0 = (b.tile_x0 + int(tile % uint(b.tiles_x))) * b.tile;
  int y0 = (b.tile_y0 + int(tile / uint(b.tiles_x))) * b.tile;
  int ww = b.window_x1 - b.window_x0;
  ViewSamplesIn samples = ViewSamplesIn(pc.p.samples);
  // One flat walk over (Hilbert step, view sample of the pixel), resumed where the tile's last
  // dispatch left it: `step` and whether its point has begun (its cells queued in the sampler).
  // A dispatch takes at most cell_budget units of work (<= 0: all): a step passed over, a point
  // started, a cell evaluated.
  int spp = b.spp;
  int steps = b.tile * b.tile * spp;
  int step = pc.p.resume == 0 ? 0 : int(position.v[0]);
  uint begun = pc.p.resume == 0 ? 0u : position.v[1];
  int budget = pc.p.cell_budget;
  int done = 0;
  while (step < steps && tc.overflow == 0u && (budget <= 0 || done < budget)) {
    int hx, hy;
    crt_hilbert_point(b.tile, step / spp, hx, hy);
    int x = x0 + hx, y = y0 + hy;
    bool inside = x >= b.window_x0 && x < b.window_x1 && y >= b.window_y0 && y < b.window_y1;
    uint slot = inside ? (uint(y - b.window_y0) * uint(ww) + uint(x - b.window_x0)) * uint(spp) + uint(step % spp) : 0u;
    GpuViewSample s;
    if (inside) s = samples.v[slot];
    if (!inside || s.object == kMissObject) {
      step += 1;  // nothing to shade
      done += 1;
    } else if (!light_faces(L, s.p)) {
      Floats(pc.p.visibility).v[slot] = 0.0f;
      Vec3s(pc.p.irradiance).v[slot] = vec3(0.0f);
      step += 1;
      done += 1;
    } else {
      if (begun == 0u) {
        // The reference's per-point samples: keyed by (seed, light, camera ray, frame).
        RngState rng = rng_keyed(pc.p.seed, uint64_t(0x52454600u + uint(pc.p.light_index)), gpu_sample_key(s),
                                 uint64_t(pc.p.frame));
        for (uint j = 0u; j < n; ++j) {
          vec2 u = stratified_cell(int(j), b.grid_cols, b.inv_cols, b.inv_rows, rng_next_2d(rng));
          Vec2s(r.samples).v[j] = u;
          points.v[j] = gpu_light_sample_area(light, u);
        }
        ss_begin(r, st, L, s.p, sc);
        begun = 1u;
        done += 1;
      }
      // penumbra's addition: on a closed mesh, light behind the point's own plane is hidden by
      // the solid itself (ng faces the camera, i.e. out of the solid); no ray.
      bool solid = b.own_plane != 0u && b.geometry == 0u && (g_objects.v[s.object].flags & kObjectClosed) != 0u;
      bool finished = false;
      while (!finished && tc.overflow == 0u && (budget <= 0 || done < budget)) {
        int j = ss_next(r, st);
        if (j < 0) {
          finished = true;
        } else {
          vec3 q = points.v[j];
          bool blocked = false, has_point = false;
          vec3 point = vec3(0.0f);
          vec3 org, dir;
          float tfar;
          shadow_segment(s.p, s.ng, q, org, dir, tfar);  // shadow_ray_to
          if (solid && dot(q - s.p, s.ng) <= 0.0f) {
            blocked = true;
            own_plane_cells += 1u;
          } else if (b.geometry != 0u) {
            RayHit hit;
            geometry_rays += 1u;
            if (trace_closest(org, dir, tfar, hit)) {
              blocked = true;
              has_point = true;
              point = org + dir * hit.t;
            }
          } else {
            // The light field (crt_light_field_start): the ray's part nearer the light than the images
            // can hold a caster, through the BVH; the images answer up to where it begins.
            bool answered = false;
            float t_end = tfar;
            float t_light = crt_light_field_start(org, dir, tfar, L.center, L.n, b.light_field);
            if (t_light < tfar) {
              RayHit hit;
              light_rays += 1u;
              vec3 from = org + dir * t_light;
              if (trace_closest(from, dir, tfar - t_light, hit)) {
                blocked = true;
                has_point = true;
                point = from + dir * hit.t;
                answered = true;
              } else if (!(t_light > 0.0f)) {
                answered = true;  // the whole segment was in it: unblocked
              }
              t_end = t_light;
            }
            // The near field (crt_near_field_length): its part of the ray through the BVH first.
            vec3 start = org;
            if (!answered && b.near_scale > 0.0f) {
              float len = min(t_end, crt_near_field_length(s.p, b.near_eye, b.near_forward, b.near_scale, b.near_light_width, tfar));
              RayHit hit;
              near_rays += 1u;
              if (trace_closest(org, dir, len, hit)) {
                blocked = true;
                has_point = true;
                point = org + dir * hit.t;
                answered = true;
              } else if (len >= t_end) {
                answered = true;  // the whole segment was near (or in the light field): unblocked
              }
              start = org + dir * len;
            }
            vec3 end = t_end < tfar ? org + dir * t_end : q;
            if (!answered)
              crt_trace(images, b.trace, start, end, b.coherence != 0u, spans, tc, blocked, has_point, point);
          }
          if (tc.overflow == 0u) ss_answer(r, st, L, s.p, j, blocked, has_point, point, sc);
          done += 1;
        }
      }
      if (finished && tc.overflow == 0u) {
        // Eq. 1 with area sampling; V = the visible fraction of the light's area (eq. 2).
        double e = 0.0LF;
        uint visible = 0u;
        for (uint j = 0u; j < n; ++j) {
          if (ss_visible(r, int(j)) != 0u) {
            visible += 1u;
            e += double(crt_cell_irradiance(s.p, s.ns, L.n, points.v[j]));
          }
        }
        float v = float(visible) / float(n);
        Floats(pc.p.visibility).v[slot] = v;
        if (b.sphere_emitter != 0UL) {
          // A sphere sampled through its central disk: its own closed form times V (coherent_rt.cpp).
          GpuLight sphere = LightRef(b.sphere_emitter).v;
          Vec3s(pc.p.irradiance).v[slot] = sphere.radiance * light_irradiance_sphere(sphere.geometry, s.p, s.ns) * v;
        } else {
          Vec3s(pc.p.irradiance).v[slot] = light.radiance * float(e * double(L.area) / double(n));
        }
        step += 1;
        begun = 0u;
      }
    }
  }
  position.v[0] = uint(step);
  position.v[1] = begun;
  saved.s = st;
  // The driver's loop limit (gpu/loop_limit.h): the host traces again with fewer steps per
  // dispatch.
  CountersRef c = CountersRef(pc.p.counters);
  if (step < steps) atomicAdd(c.c.unfinished, 1u);
  if (pn_loop_limit_hit(pc.p.canary)) {
    atomicMax(c.c.limited, 1u);
    atomicMin(c.c.limited_after, uint(done));
  }
  atomicAdd(c.c.points, uint64_t(sc.points));
  atomicAdd(c.c.rays, uint64_t(sc.rays));
  atomicAdd(c.c.resets, uint64_t(sc.resets));
  atomicAdd(c.c.predicted_wrong, uint64_t(sc.predicted_wrong));
  atomicAdd(c.c.shortcut_cells, uint64_t(sc.shortcut_cells));
  atomicAdd(c.c.blocker_points, uint64_t(sc.blocker_points));
  atomicAdd(c.c.traced, uint64_t(tc.rays));
  atomicAdd(c.c.blocked, uint64_t(tc.blocked));
  atomicAdd(c.c.maps_walked, uint64_t(tc.maps_walked));
  atomicAdd(c.c.clear_misses, uint64_t(tc.clear_misses));
  atomicAdd(c.c.intervals_exhausted, uint64_t(tc.intervals_exhausted));
  atomicAdd(c.c.connected_hits, uint64_t(tc.connected_hits));
  atomicAdd(c.c.hidden_everywhere, uint64_t(tc.hidden_everywhere));
  atomicAdd(c.c.nodes, uint64_t(tc.nodes));
  atomicAdd(c.c.texels, uint64_t(tc.texels));
  atomicAdd(c.c.own_plane_cells, uint64_t(own_plane_cells));
  atomicAdd(c.c.geometry_rays, uint64_t(geometry_rays));
  atomicAdd(c.c.near_rays, uint64_t(near_rays));
  atomicAdd(c.c.light_rays, uint64_t(light_rays));
  if (tc.overflow != 0u) atomicMax(c.c.overflow, 1u);
}
