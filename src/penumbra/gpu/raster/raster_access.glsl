// What the GPU rasterizer's kernels share (gpu/raster/raster_layout_shared.h): the input
// triangles as the CPU's RasterTriangle list numbers and sees them (raster/raster_triangle.h,
// gather_raster_triangles: object order, then mesh order), read from the bound scene; and the
// clipping of a triangle in homogeneous texel space (raster/clipping.cpp).
#ifndef PENUMBRA_GPU_RASTER_RASTER_ACCESS_GLSL
#define PENUMBRA_GPU_RASTER_RASTER_ACCESS_GLSL

#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/scene_access.glsl"
#include "penumbra/gpu/raster/raster_layout_shared.h"

layout(buffer_reference, scalar) readonly buffer RasterViewRef { RasterView v; };
layout(buffer_reference, scalar) buffer RasterStateRef { GpuRasterState s; };
layout(buffer_reference, scalar) buffer RasterTriangles { GpuRasterTriangle v[]; };
layout(buffer_reference, scalar) buffer RasterItems { GpuRasterItem v[]; };

// The object and prim of input triangle g: the last object whose first triangle is <= g
// (SceneDesc::object_triangles holds object_count + 1 prefix sums; objects without triangles
// repeat a value and are skipped).
void raster_source(uint g, out uint object, out uint prim) {
  Uints first = Uints(g_scene.object_triangles);
  uint lo = 0u, count = g_scene.object_count;  // upper_bound over first[1 .. object_count]
  while (count > 0u) {
    uint step = count / 2u;
    uint it = lo + step;
    if (first.v[it + 1u] <= g) {
      lo = it + 1u;
      count -= step + 1u;
    } else {
      count = step;
    }
  }
  object = lo;
  prim = g - first.v[lo];
}

// Whether the instance placing `object` mirrors: its world mesh lists each triangle's corners 1
// and 2 swapped against the shared mesh (SceneObject::shared_mesh).
bool object_mirrored(uint object) { return g_instances.v[g_objects.v[object].instance].mirrored != 0u; }

// The world-space corners of triangle prim of `object` in the world mesh's order
// (TriangleMesh::vertex), through the object's mesh and the instance that places it.
void raster_vertices(uint object, uint prim, out vec3 p0, out vec3 p1, out vec3 p2) {
  GpuObject o = g_objects.v[object];
  GpuMesh m = g_meshes.v[o.mesh];
  Vec3s pos = Vec3s(g_scene.positions);
  p0 = pos.v[mesh_vertex(m, prim, 0u)];
  p1 = pos.v[mesh_vertex(m, prim, 1u)];
  p2 = pos.v[mesh_vertex(m, prim, 2u)];
  GpuInstance inst = g_instances.v[o.instance];
  if (inst.identity == 0u) {
    p0 = instance_point(inst, p0);
    p1 = instance_point(inst, p1);
    p2 = instance_point(inst, p2);
  }
  if (inst.mirrored != 0u) {
    vec3 t = p1;
    p1 = p2;
    p2 = t;
  }
}

// RasterTriangle::opacity: the material's times the mesh's per-triangle opacity.
float raster_opacity(uint object, uint prim) {
  GpuObject o = g_objects.v[object];
  GpuMesh m = g_meshes.v[o.mesh];
  float a = o.opacity;
  if ((m.flags & kMeshTriangleOpacity) != 0u) a *= Floats(g_scene.triangle_opacity).v[m.first_triangle + prim];
  return a;
}

// Whether the triangle carries an alpha texture (RasterTriangle::alpha: the material's, where the
// mesh has texture coordinates).
bool raster_textured(uint object) {
  GpuObject o = g_objects.v[object];
  return object_alpha_textured(o) && (g_meshes.v[o.mesh].flags & kMeshUvs) != 0u;
}

// RasterTriangle::semi_transparent: it may stop only part of the light somewhere.
bool raster_semi_transparent(uint object, uint prim) {
  GpuObject o = g_objects.v[object];
  return raster_opacity(object, prim) < 1.0f || (raster_textured(object) && (o.flags & kObjectAlphaBlend) != 0u);
}

// The opacity of the fragment of a textured triangle at the centre of texel (x, y)
// (rasterizer.cpp FragmentAlpha, RasterTriangle::opacity_on_line): the alpha texture where the
// view's ray through the centre meets the triangle's plane; an edge-on triangle (no crossing)
// takes its first corner's.
float raster_fragment_opacity(RasterView view, uint object, uint prim, int x, int y) {
  vec3 origin, dir;
  raster_texel_ray(view, float(x) + 0.5f, float(y) + 0.5f, origin, dir);
  vec3 p0, p1, p2;
  raster_vertices(object, prim, p0, p1, p2);
  float b1, b2, s;
  if (!triangle_line_crossing(p0, p1, p2, origin, dir, b1, b2, s)) {
    b1 = 0.0f;
    b2 = 0.0f;
  }
  // surface_opacity reads the texture coordinates in the shared mesh's corner order.
  if (object_mirrored(object)) return surface_opacity(object, prim, b2, b1);
  return surface_opacity(object, prim, b1, b2);
}

// The homogeneous texel coordinates (x, y, z, w) of a world point (p - eye through the rows): texel = (x / w, y / w), z the
// linear depth (LightView::texel_projection; summed as clipping.cpp's vector transform sums it).
vec4 raster_project(RasterView v, vec3 world) {
  precise vec3 p = world - v.eye;  // texel_projection takes p - eye
  precise vec4 h = vec4(v.row0.x, v.row1.x, v.row2.x, v.row3.x) * p.x +
                   vec4(v.row0.y, v.row1.y, v.row2.y, v.row3.y) * p.y +
                   vec4(v.row0.z, v.row1.z, v.row2.z, v.row3.z) * p.z + vec4(v.off0, v.off1, v.off2, v.off3);
  return h;
}

// Signed distance of a homogeneous vertex to clip plane `plane` (>= 0 inside): near, far, and
// the guard band's left, right, top and bottom (clipping.cpp TriangleClipper::clip).
float raster_clip_distance(RasterView v, int plane, vec4 c) {
  float x_max = float(v.width) + kRasterGuardBand, y_max = float(v.height) + kRasterGuardBand;
  if (plane == 0) return c.z - v.near;
  if (plane == 1) return v.far - c.z;
  if (plane == 2) return c.x + kRasterGuardBand * c.w;
  if (plane == 3) return x_max * c.w - c.x;
  if (plane == 4) return c.y + kRasterGuardBand * c.w;
  return y_max * c.w - c.y;
}

// The outcode of a homogeneous vertex: bit p set when it lies outside plane p.
uint raster_outcode(RasterView v, vec4 c) {
  float x_max = float(v.width) + kRasterGuardBand, y_max = float(v.height) + kRasterGuardBand;
  return uint(c.z < v.near) | uint(c.z > v.far) << 1 | uint(c.x < -kRasterGuardBand * c.w) << 2 |
         uint(c.x > x_max * c.w) << 3 | uint(c.y < -kRasterGuardBand * c.w) << 4 | uint(c.y > y_max * c.w) << 5;
}

// Sutherland-Hodgman against the planes some vertex violates (clipping.cpp): poly holds the
// triangle's three vertices and `any`, the union of their outcodes; returns the clipped convex
// polygon's vertex count (0 when nothing remains), in the triangle's winding order.
int raster_clip(RasterView v, uint any, inout vec4 poly[kRasterMaxClipVertices]) {
  vec4 dst[kRasterMaxClipVertices];
  int n = 3;
  for (int p = 0; p < 6 && n > 0; ++p) {
    if ((any & (1u << uint(p))) == 0u) continue;
    int m = 0;
    for (int i = 0; i < n; ++i) {
      vec4 a = poly[i];
      vec4 b = poly[(i + 1) % n];
      float da = raster_clip_distance(v, p, a), db = raster_clip_distance(v, p, b);
      if (da >= 0.0f) dst[m++] = a;
      if ((da >= 0.0f) != (db >= 0.0f)) {
        // From the inside vertex toward the outside one, so the two triangles sharing this edge
        // compute the very same point (no crack along the clip line).
        vec4 inside = da >= 0.0f ? a : b;
        vec4 outside = da >= 0.0f ? b : a;
        float din = da >= 0.0f ? da : db, dout = da >= 0.0f ? db : da;
        precise float s = din / (din - dout);
        precise vec4 q = inside + (outside - inside) * s;
        dst[m++] = q;
      }
    }
    n = m;
    for (int i = 0; i < n; ++i) poly[i] = dst[i];
  }
  return n >= 3 ? n : 0;
}

#endif
