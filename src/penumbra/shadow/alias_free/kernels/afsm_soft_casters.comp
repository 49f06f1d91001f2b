#version 460
// afsm on the GPU, sintorn2008 §4.1 (alias_free.cpp AliasFreeSoft::evaluate, "casters" and
// "regions"; influence_region.cpp): one thread per input triangle. A triangle that can block
// light (opacity > 0, some vertex in front of the light's sample plane, nearer than the farthest
// listed sample) gets its influence region on the far plane at the farthest listed sample: the
// light samples' bounding rectangle projected through each vertex onto that plane, into the
// light's image. Every view sample the triangle can shadow from a light sample projects into its
// convex hull (gpu/raster/conservative_cover.glsl), stored for the cover pass. A region that does not close (a vertex at or behind the light's plane, or stretched
// beyond kMaxStretch) covers the whole image, as on the CPU.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/conservative_cover.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"
#include "penumbra/shadow/alias_free/kernels/afsm_soft_access.glsl"

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
  float far_depth = uintBitsToFloat(light.far_bits) * (1.0f + 1e-4f) + 1e-6f;
  float z[3];
  for (int k = 0; k < 3; ++k) z[k] = dot(v[k] - light.c, light.axis);
  // Entirely behind the light's sample plane, or deeper than every listed sample: blocks none.
  if (z[0] <= 0.0f && z[1] <= 0.0f && z[2] <= 0.0f) return;
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
