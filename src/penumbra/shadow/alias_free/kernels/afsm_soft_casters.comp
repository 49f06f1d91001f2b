#version 460
// afsm on the GPU, sintorn2008 §4.1 (alias_free.cpp AliasFreeSoft::evaluate, "casters" and
// "regions"; influence_region.cpp): one thread per input triangle, for one depth slab (pc.p.slab).
// A triangle that can block light (opacity > 0, some vertex in front of the light's sample plane,
// nearer than the slab's farthest listed sample) gets its influence region on the slab's far plane
// (§4.3, per slab as the CPU's split_by_depth): the
// light samples' bounding rectangle projected through each vertex onto that plane, into the
// light's image. Every view sample the triangle can shadow from a light sample projects into its
// convex hull (gpu/raster/conservative_cover.glsl), stored for the cover pass. A region that does not close (a vertex at or behind the light's plane, or stretched
// beyond kMaxStretch) covers the whole image, as on the CPU.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/conservative_cover.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"
#include "penumbra/shadow/alias_free/kernels/afsm_soft_access.glsl"
#include "penumbra/trace/ray_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { AfsmSoftParams p; } pc;
layout(buffer_reference, scalar) writeonly buffer CastersOut { AfsmSoftCaster v[]; };

const float kMaxStretch = 1e4f;  // influence_region.cpp

void main() {
  uint g = pn_thread_index();
  if (g >= pc.p.count) return;
  Uints rows = Uints(pc.p.rows);
  rows.v[g] = 0u;
  scene_bind(pc.p.scene);
  uint object, prim;
  raster_source(g, object, prim);
  if (!(raster_opacity(object, prim) > 0.0f)) return;
  vec3 v[3];
  raster_vertices(object, prim, v[0], v[1], v[2]);
  AfsmSoftLight light = AfsmLightRef(pc.p.light).l;
  // (An empty slab's far bits are 0: every caster is deeper, none is kept.)
  float far_depth = uintBitsToFloat(afsm_slabs(pc.p.view).s.far_bits[pc.p.slab]) * (1.0f + 1e-4f) + 1e-6f;
  float z[3];
  for (int k = 0; k < 3; ++k) z[k] = dot(v[k] - light.c, light.axis);
  // Entirely on or behind the light's sample plane, or deeper than every listed sample of the slab: blocks none.
  if (on_or_behind_light_plane(z[0], v[0]) && on_or_behind_light_plane(z[1], v[1]) && on_or_behind_light_plane(z[2], v[2]))
    return;
  if (!(min(z[0], min(z[1], z[2])) < far_depth)) return;
  RasterView view = RasterViewRef(pc.p.view).v;
  vec2 pts[kConservativeHullPoints];
  int n = 0;
  for (int k = 0; k < 3 && n >= 0; ++k) {
    for (int j = 0; j < 4; ++j) {
      float ux = (j & 1) == 0 ? light.lo_x : light.hi_x, uy = (j & 2) == 0 ? light.lo_y : light.hi_y;
      vec3 q = light.c + light.ls * ux + light.lt * uy;
      float zq = dot(q - light.c, light.axis);
      float ahead = z[k] - zq, reach = far_depth - zq;
      if (!(ahead > 0.0f) || !(reach < kMaxStretch * ahead)) {
        n = -1;  // unbounded
        break;
      }
      vec4 h = raster_project(view, q + (v[k] - q) * (reach / ahead));
      vec2 t = h.xy / h.w;
      if (!(h.w > 0.0f) || isinf(t.x) || isnan(t.x) || isinf(t.y) || isnan(t.y)) {
        n = -1;
        break;
      }
      pts[n++] = t;
    }
  }
  int ix0 = 0, ix1 = view.width, iy0 = 0, iy1 = view.height;
  Vec2s polygon = Vec2s(pc.p.polygons);
  uint base = g * uint(kConservativeHullPoints);
  if (n < 0) {
    // The whole image.
    n = 4;
    pts[0] = vec2(0.0f, 0.0f);
    pts[1] = vec2(float(view.width), 0.0f);
    pts[2] = vec2(float(view.width), float(view.height));
    pts[3] = vec2(0.0f, float(view.height));
  } else {
    n = conservative_hull(pts, n);
    float x0 = pn_inf(), x1 = -pn_inf(), y0 = pn_inf(), y1 = -pn_inf();
    for (int k = 0; k < n; ++k) {
      x0 = min(x0, pts[k].x);
      x1 = max(x1, pts[k].x);
      y0 = min(y0, pts[k].y);
      y1 = max(y1, pts[k].y);
    }
    if (!conservative_box(x0, x1, y0, y1, view.width, view.height, kAfsmCoverSlack, ix0, ix1, iy0, iy1)) return;
  }
  // Only the texels that hold the slab's lists (the CPU's `restrict`, by the slab's bounding box).
  AfsmSlabsRef slabs = afsm_slabs(pc.p.view);
  uint b = 4u * pc.p.slab;
  ix0 = max(ix0, int(~slabs.s.box[b]));
  iy0 = max(iy0, int(~slabs.s.box[b + 1u]));
  ix1 = min(ix1, int(slabs.s.box[b + 2u]));
  iy1 = min(iy1, int(slabs.s.box[b + 3u]));
  if (ix0 >= ix1 || iy0 >= iy1) return;
  // and not the rows at either end whose texels [ix0, ix1) hold none of them (a slab of a tilted
  // receiver is a band across the view: a region meets it in a few of its rows).
  Uints first = Uints(pc.p.first);
  uint slab_base = pc.p.slab * uint(view.width) * uint(view.height);
  while (iy0 < iy1) {
    uint row = slab_base + uint(iy0) * uint(view.width);
    if (first.v[row + uint(ix0)] != first.v[row + uint(ix1)]) break;
    ++iy0;
  }
  while (iy0 < iy1) {
    uint row = slab_base + uint(iy1 - 1) * uint(view.width);
    if (first.v[row + uint(ix0)] != first.v[row + uint(ix1)]) break;
    --iy1;
  }
  if (iy0 >= iy1) return;
  for (int k = 0; k < n; ++k) polygon.v[base + uint(k)] = pts[k];
  AfsmSoftCaster c;
  c.v0 = v[0];
  c.rows = uint(iy1 - iy0);
  c.v1 = v[1];
  c.x0 = ix0;
  c.v2 = v[2];
  c.x1 = ix1;
  c.normal = cross(v[1] - v[0], v[2] - v[0]);
  c.y0 = iy0;
  c.count = uint(n);
  CastersOut(pc.p.casters).v[g] = c;
  rows.v[g] = c.rows;
}
