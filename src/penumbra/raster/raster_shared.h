// The rasterizer's exact arithmetic in the common subset of C++ and GLSL (core/shader_compat.h):
// the triangle set-up (snapping to 1/256 texel, int64 edge functions with the top-left fill rule,
// the depth plane in double), the coverage test at a texel centre, the depth at a texel centre,
// the order of fragments as one 64-bit key, the ray through a texel centre and the line-triangle
// crossing that alpha textures are looked up at. The CPU rasterizer (rasterizer.cpp) and the GPU's
// (gpu/raster/) call these same functions, so both cover the same centres and, where the GPU
// does not fuse what PN_PRECISE marks, store the same depths (docs/raster.md, "The GPU
// rasterizer").
#ifndef PENUMBRA_RASTER_RASTER_SHARED_H
#define PENUMBRA_RASTER_RASTER_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// Vertices are snapped to 1/256 texel. With the guard band every snapped coordinate stays below
// 2^23 in magnitude, edge coefficients below 2^24 and edge-function values below 2^49: exact in
// int64, so coverage is decided without rounding and the fill rule holds exactly.
PN_CONST int kRasterSubpixel = 256;
PN_CONST int kRasterHalfTexel = 128;
// How far (in texels) geometry may reach beyond each side of the image before it is clipped
// (clipping.h): with images of at most 16384 texels this keeps the bounds above.
PN_CONST float kRasterGuardBand = 16384.0f;
// A triangle clipped against six planes can gain one vertex per plane.
PN_CONST int kRasterMaxClipVertices = 9;
// The CPU rasterizer's default tile (Rasterizer(64), what every map of the shadow-map family
// uses): where its scan starts a span, which raster_plane_value needs to sum the depth plane in
// the CPU's order.
PN_CONST int kRasterCpuTile = 64;

// A triangle ready to scan, 80 bytes (also the GPU's record: gpu/raster/raster_layout_shared.h):
//   bytes  0-23 c0 c1 c2 (int64)   24-35 a0 a1 a2   36-47 b0 b1 b2
//   bytes 48-63 x0 y0 x1 y1        64-75 v0 dvdx dvdy   76-79 source
// Three edge functions E = a X + b Y + c over snapped texel coordinates (X, Y in 1/256 texel),
// positive inside, with the fill-rule bias folded into c so that "E >= 0 for all three" is the
// coverage test; the texels [x0, x1) x [y0, y1) (inside the image) whose centres can be covered;
// the plane of the interpolated depth quantity v (1/z for a perspective view, z for an
// orthographic one, both affine in texel space): v0 at the centre of texel (x0, y0), dvdx and
// dvdy per texel; source: the index of the input triangle.
struct RasterSetup {
  int64_t c0;
  int64_t c1;
  int64_t c2;
  int a0;
  int a1;
  int a2;
  int b0;
  int b1;
  int b2;
  int x0;
  int y0;
  int x1;
  int y1;
  float v0;
  float dvdx;
  float dvdy;
  uint source;
};

PN_INLINE int64_t raster_floor_div(int64_t a, int64_t b) {
  return a >= int64_t(0) ? a / b : -((-a + b - int64_t(1)) / b);
}
PN_INLINE int64_t raster_ceil_div(int64_t a, int64_t b) { return -raster_floor_div(-a, b); }

// A texel-space coordinate in 1/256 texel, rounded half away from zero: a pure function of the
// value, so shared vertices snap alike.
PN_INLINE int raster_snap(float x) {
  double d = double(x) * double(256.0f);
  return int(d + (d >= double(0.0f) ? double(0.5f) : double(-0.5f)));
}

// The edge from snapped vertex (xi, yi) to (xj, yj): E(P) = cross(V_j - V_i, P - V_i) =
// dx (Py - Yi) - dy (Px - Xi). Top-left rule: a centre exactly on an edge belongs to the
// triangle only if the edge is a top edge (horizontal, interior below) or a left edge, so each
// centre on an edge shared by two triangles is covered by exactly one of them.
PN_INLINE void raster_edge(int xi, int yi, int xj, int yj, PN_OUT(int) a, PN_OUT(int) b, PN_OUT(int64_t) c) {
  int dx = xj - xi;
  int dy = yj - yi;
  a = -dy;
  b = dx;
  c = int64_t(dy) * int64_t(xi) - int64_t(dx) * int64_t(yi);
  bool top_left = dy < 0 || (dy == 0 && dx > 0);
  if (!top_left) c = c - int64_t(1);
}

// Sets up one triangle of (unsnapped) texel-space vertices p0..p2 and depth values v0..v2 for a
// width x height image. False when it covers no texel centre of the image. `source` is left to
// the caller.
PN_INLINE bool raster_set_up(vec2 p0, vec2 p1, vec2 p2, double v0, double v1, double v2, int width, int height,
                             PN_OUT(RasterSetup) t) {
  int X0 = raster_snap(p0.x);
  int Y0 = raster_snap(p0.y);
  int X1 = raster_snap(p1.x);
  int Y1 = raster_snap(p1.y);
  int X2 = raster_snap(p2.x);
  int Y2 = raster_snap(p2.y);
  int64_t area = int64_t(X1 - X0) * int64_t(Y2 - Y0) - int64_t(Y1 - Y0) * int64_t(X2 - X0);
  if (area == int64_t(0)) return false;  // degenerate after snapping: covers no sample
  int minX = min(X0, min(X1, X2));
  int maxX = max(X0, max(X1, X2));
  int minY = min(Y0, min(Y1, Y2));
  int maxY = max(Y0, max(Y1, Y2));
  // Texels whose centre (256 i + 128) lies in the snapped bounding box.
  int64_t sub = int64_t(kRasterSubpixel);
  t.x0 = int(max(int64_t(0), raster_ceil_div(int64_t(minX - kRasterHalfTexel), sub)));
  t.x1 = int(min(int64_t(width), raster_floor_div(int64_t(maxX - kRasterHalfTexel), sub) + int64_t(1)));
  t.y0 = int(max(int64_t(0), raster_ceil_div(int64_t(minY - kRasterHalfTexel), sub)));
  t.y1 = int(min(int64_t(height), raster_floor_div(int64_t(maxY - kRasterHalfTexel), sub) + int64_t(1)));
  if (t.x0 >= t.x1 || t.y0 >= t.y1) return false;
  // Orient so the interior is on the positive side of every edge. In a y-down image a positive
  // area is a clockwise-looking triangle, for which "top" edges run in +x and "left" edges in -y.
  if (area > int64_t(0)) {
    raster_edge(X0, Y0, X1, Y1, t.a0, t.b0, t.c0);
    raster_edge(X1, Y1, X2, Y2, t.a1, t.b1, t.c1);
    raster_edge(X2, Y2, X0, Y0, t.a2, t.b2, t.c2);
  } else {
    raster_edge(X0, Y0, X2, Y2, t.a0, t.b0, t.c0);
    raster_edge(X2, Y2, X1, Y1, t.a1, t.b1, t.c1);
    raster_edge(X1, Y1, X0, Y0, t.a2, t.b2, t.c2);
  }
  // Depth plane from the unsnapped vertices: the depth at a texel centre is the true plane's,
  // whatever the snapping did to coverage.
  double ux = double(p1.x) - double(p0.x);
  double uy = double(p1.y) - double(p0.y);
  double wx = double(p2.x) - double(p0.x);
  double wy = double(p2.y) - double(p0.y);
  PN_PRECISE double det = ux * wy - uy * wx;
  PN_PRECISE double gx = double(0.0f);
  PN_PRECISE double gy = double(0.0f);
  if (det != double(0.0f)) {
    double dv1 = v1 - v0;
    double dv2 = v2 - v0;
    gx = (dv1 * wy - dv2 * uy) / det;
    gy = (dv2 * ux - dv1 * wx) / det;
  }
  PN_PRECISE double at = v0 + gx * (double(t.x0) + double(0.5f) - double(p0.x)) +
                         gy * (double(t.y0) + double(0.5f) - double(p0.y));
  t.v0 = float(at);
  t.dvdx = float(gx);
  t.dvdy = float(gy);
  return true;
}

// The three edge functions at the centre of texel (x, y), exactly. One texel to the right adds
// a * 256 to each, one row down b * 256 (raster_step_x / raster_step_y): a scan adds instead of
// multiplying, with the same integers.
struct RasterEdges {
  int64_t e0;
  int64_t e1;
  int64_t e2;
};
PN_INLINE RasterEdges raster_edges_at(RasterSetup t, int x, int y) {
  int64_t px = int64_t(x) * int64_t(kRasterSubpixel) + int64_t(kRasterHalfTexel);
  int64_t py = int64_t(y) * int64_t(kRasterSubpixel) + int64_t(kRasterHalfTexel);
  RasterEdges e;
  e.e0 = int64_t(t.a0) * px + int64_t(t.b0) * py + t.c0;
  e.e1 = int64_t(t.a1) * px + int64_t(t.b1) * py + t.c1;
  e.e2 = int64_t(t.a2) * px + int64_t(t.b2) * py + t.c2;
  return e;
}
PN_INLINE RasterEdges raster_step_x(RasterSetup t, RasterEdges e) {
  e.e0 += int64_t(t.a0) * int64_t(kRasterSubpixel);
  e.e1 += int64_t(t.a1) * int64_t(kRasterSubpixel);
  e.e2 += int64_t(t.a2) * int64_t(kRasterSubpixel);
  return e;
}
PN_INLINE RasterEdges raster_step_y(RasterSetup t, RasterEdges e) {
  e.e0 += int64_t(t.b0) * int64_t(kRasterSubpixel);
  e.e1 += int64_t(t.b1) * int64_t(kRasterSubpixel);
  e.e2 += int64_t(t.b2) * int64_t(kRasterSubpixel);
  return e;
}
// Whether the centre is covered: all three edge functions >= 0 (the fill rule is in c).
PN_INLINE bool raster_inside(RasterEdges e) { return e.e0 >= int64_t(0) && e.e1 >= int64_t(0) && e.e2 >= int64_t(0); }
PN_INLINE bool raster_covers(RasterSetup t, int x, int y) { return raster_inside(raster_edges_at(t, x, y)); }

// The depth plane at the centre of texel (x, y), summed as rasterizer.cpp's scan sums it along a
// span that starts at column span_x0: v0 + dvdx (span_x0 - x0), then the row, then the column
// within the span.
PN_INLINE float raster_plane_value(RasterSetup t, int x, int y, int span_x0) {
  PN_PRECISE float vx0 = t.v0 + t.dvdx * float(span_x0 - t.x0);
  PN_PRECISE float vrow = vx0 + t.dvdy * float(y - t.y0);
  PN_PRECISE float v = vrow + t.dvdx * float(x - span_x0);
  return v;
}

// v -> linear depth, kept inside [near, far] (a centre covered only thanks to snapping, or float
// error, can extrapolate a hair beyond the clipped triangle).
PN_INLINE float raster_linear_depth(float v, float near, float far, bool perspective) {
  float z = perspective ? (v > 0.0f ? 1.0f / v : far) : v;
  return min(max(z, near), far);
}

// A float's bits made monotonic as an unsigned integer (negative depths occur in orthographic
// views with near < 0), and back.
PN_INLINE uint raster_order_bits(float z) {
  uint bits = floatBitsToUint(z);
  return (bits & 0x80000000u) != 0u ? ~bits : (bits | 0x80000000u);
}
PN_INLINE float raster_order_float(uint bits) {
  return uintBitsToFloat((bits & 0x80000000u) != 0u ? (bits & 0x7fffffffu) : ~bits);
}
// Fragments order by (z, triangle) as one unsigned 64-bit key: ties in z keep triangle (input)
// order. The smallest key of a texel is its nearest surface, whatever order fragments come in
// (the GPU's atomicMin).
PN_INLINE uint64_t raster_depth_key(float z, uint triangle) {
  return (uint64_t(raster_order_bits(z)) << 32) | uint64_t(triangle);
}
PN_INLINE float raster_key_depth(uint64_t key) { return raster_order_float(uint(key >> 32)); }

// A LightView as kernels and shared functions see it, 160 bytes (scalar layout; light_view.h's
// conventions; LightView::shared() writes it):
//   bytes   0-63  texel_projection (of p - eye), rows 0-3, each (vec3 row, float offset)
//   bytes  64-79  eye, near   80-95 right, far   96-111 up, width   112-127 forward, height
//   bytes 128-143 the window l, r, b, t   144-147 perspective (1) or orthographic (0)
//   bytes 148-159 (unused, 0)
struct RasterView {
  vec3 row0;
  float off0;
  vec3 row1;
  float off1;
  vec3 row2;
  float off2;
  vec3 row3;
  float off3;
  vec3 eye;
  float near;
  vec3 right;
  float far;
  vec3 up;
  int width;
  vec3 forward;
  int height;
  float l;
  float r;
  float b;
  float t;
  uint perspective;
  uint pad0;
  uint pad1;
  uint pad2;
};

// LightView::texel_ray: the ray through texel-space point (x, y); origin + z dir lies at linear
// depth z.
PN_INLINE void raster_texel_ray(RasterView v, float x, float y, PN_OUT(vec3) origin, PN_OUT(vec3) dir) {
  float u = v.l + (v.r - v.l) * x / float(v.width);
  float w = v.t - (v.t - v.b) * y / float(v.height);
  if (v.perspective != 0u) {
    origin = v.eye;
    dir = v.right * (u / v.near) + v.up * (w / v.near) + v.forward;
  } else {
    origin = v.eye + v.right * u + v.up * w;
    dir = v.forward;
  }
}

// The terms of triangle_line_crossing that depend on the triangle (p0, p1, p2) and the line's
// origin only: set up once for many lines from one point (afsm: a view sample's light samples
// through one caster).
struct TriangleLineSetup {
  vec3 e1;  // p1 - p0
  vec3 e2;  // p2 - p0
  vec3 tv;  // origin - p0
  vec3 qv;  // cross(tv, e1)
};
PN_INLINE TriangleLineSetup triangle_line_setup(vec3 p0, vec3 p1, vec3 p2, vec3 origin) {
  TriangleLineSetup t;
  t.e1 = p1 - p0;
  t.e2 = p2 - p0;
  t.tv = origin - p0;
  t.qv = cross(t.tv, t.e1);
  return t;
}
// triangle_line_crossing for the line origin + s dir of a set-up triangle and origin.
PN_INLINE bool triangle_line_setup_crossing(TriangleLineSetup t, vec3 dir, PN_OUT(float) b1, PN_OUT(float) b2,
                                            PN_OUT(float) s) {
  vec3 pv = cross(dir, t.e2);
  float det = dot(t.e1, pv);
  b1 = 0.0f;
  b2 = 0.0f;
  s = 0.0f;
  if (det == 0.0f) return false;
  float inv = 1.0f / det;
  b1 = dot(t.tv, pv) * inv;
  b2 = dot(dir, t.qv) * inv;
  s = dot(t.e2, t.qv) * inv;
  return true;
}

// Where the line origin + s dir meets the plane of triangle (p0, p1, p2): its barycentrics
// (b1, b2) and s (Moller-Trumbore's solution; inside the triangle iff b1, b2 >= 0 and
// b1 + b2 <= 1). False when the line is parallel to the plane (RasterTriangle::line_crossing).
PN_INLINE bool triangle_line_crossing(vec3 p0, vec3 p1, vec3 p2, vec3 origin, vec3 dir, PN_OUT(float) b1,
                                      PN_OUT(float) b2, PN_OUT(float) s) {
  return triangle_line_setup_crossing(triangle_line_setup(p0, p1, p2, origin), dir, b1, b2, s);
}

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::RasterSetup) == 80);
static_assert(sizeof(penumbra::shader::RasterView) == 160);
#endif

#endif  // PENUMBRA_RASTER_RASTER_SHARED_H
