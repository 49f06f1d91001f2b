// The per-triangle, per-tile and per-texel work of the GPU rasterizer's stages, as functions every
// rasterizer mode calls (gpu/raster/raster_layout_shared.h: one map, raster_*.comp;
// raster_batch_layout_shared.h: many views at once, raster_batch_*.comp), so the modes cover,
// depth and resolve texels with one code:
//   raster_polygon       an input triangle seen from a view: filtered, culled, clipped (near, far,
//                        guard band) into a convex polygon in texel space with its depth values;
//   (the fill's scan of one 16 x 16-texel tile of a set-up triangle is raster_scan.glsl's, shared
//   with the modes that scan fragments: layers, lists, depth bins);
//   raster_resolve_key   a texel's nearest key into the DepthMap planes' values.
#ifndef PENUMBRA_GPU_RASTER_RASTER_STAGES_GLSL
#define PENUMBRA_GPU_RASTER_RASTER_STAGES_GLSL

#include "penumbra/gpu/raster/raster_access.glsl"

// Input triangle g (gather_raster_triangles' numbering) seen from `view`: its object and prim,
// and the convex polygon left after the filter (opacity <= 0 casts nothing; `opaque_only` skips
// semi-transparent triangles; `culling` 0 keeps both sides, 1 those facing the light, 2 those
// facing away; `object_flags`, where not 0, a mode's per-object kRasterObject* flags: skip the
// object, or keep only its triangles facing the light) and the clipping, as texel-space points t[]
// and the depth values v[] (1/w for a perspective view, z for an orthographic one) the set-up
// interpolates. Returns the vertex count (0: nothing left).
int raster_polygon(RasterView view, uint g, uint culling, bool opaque_only, uint64_t object_flags, out uint object,
                   out uint prim, out vec2 t[kRasterMaxClipVertices], out double v[kRasterMaxClipVertices]) {
  raster_source(g, object, prim);
  if (!(raster_opacity(object, prim) > 0.0f)) return 0;
  if (opaque_only && raster_semi_transparent(object, prim)) return 0;
  if (object_flags != 0UL) {  // a mode's per-object choices
    uint flags = Uints(object_flags).v[object];
    if ((flags & kRasterObjectSkip) != 0u) return 0;
    if ((flags & kRasterObjectFrontOnly) != 0u) culling = 1u;
  }
  vec3 p0, p1, p2;
  raster_vertices(object, prim, p0, p1, p2);
  if (culling != 0u) {
    // clipping.h faces_light: the light sees the side cross(p1 - p0, p2 - p0) points to.
    vec3 n = cross(p1 - p0, p2 - p0);
    bool front = view.perspective != 0u ? dot(n, view.eye - p0) > 0.0f : dot(n, view.forward) < 0.0f;
    if (front != (culling == 1u)) return 0;
  }
  vec4 poly[kRasterMaxClipVertices];
  poly[0] = raster_project(view, p0);
  poly[1] = raster_project(view, p1);
  poly[2] = raster_project(view, p2);
  uint any = 0u, all = 0x3fu;
  for (int k = 0; k < 3; ++k) {
    uint code = raster_outcode(view, poly[k]);
    any |= code;
    all &= code;
  }
  if (all != 0u) return 0;  // every vertex outside one plane
  int n = any == 0u ? 3 : raster_clip(view, any, poly);
  bool perspective = view.perspective != 0u;
  for (int k = 0; k < n; ++k) {
    precise float x = poly[k].x / poly[k].w;
    precise float y = poly[k].y / poly[k].w;
    t[k] = vec2(x, y);
    precise double d = perspective ? 1.0LF / double(poly[k].w) : double(poly[k].z);
    v[k] = d;
  }
  return n;
}

// Texel (x, y)'s nearest key (~0: empty) as the DepthMap planes hold it: linear depth, window
// depth (LightView::window_depth), the surface's opacity at the texel centre (material x triangle
// x alpha texture, as the fragment had it) and the input triangle; an empty texel gets +inf, +inf,
// 0 and kNoTriangle (0xffffffff).
void raster_resolve_key(RasterView view, uint64_t key, int x, int y, out float z, out float depth, out float opacity,
                        out uint triangle) {
  if (key == ~0UL) {
    z = pn_inf();
    depth = pn_inf();
    opacity = 0.0f;
    triangle = 0xffffffffu;
    return;
  }
  z = raster_key_depth(key);
  triangle = uint(key & 0xffffffffUL);
  uint object, prim;
  raster_source(triangle, object, prim);
  opacity = raster_textured(object) ? raster_fragment_opacity(view, object, prim, x, y) : raster_opacity(object, prim);
  float near = view.near, far = view.far;
  depth = view.perspective != 0u ? far * (z - near) / ((far - near) * z) : (z - near) / (far - near);
}

#endif
