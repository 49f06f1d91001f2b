// Internal to the raster layer: transforming a world-space triangle into homogeneous texel
// space and clipping it to the near and far planes and the guard band (shared by the
// rasterizer and conservative rasterization).
#pragma once

#include "penumbra/raster/light_view.h"
#include "penumbra/raster/raster_shared.h"
#include "penumbra/raster/raster_triangle.h"

namespace penumbra::raster_internal {

// Homogeneous texel coordinates: texel = (x / w, y / w); z is the linear depth. All four are
// affine in the world point, so linear interpolation along an edge is exact.
struct ClipVertex {
  float x, y, z, w;
};

// How far (in texels) geometry may reach beyond each side of the image before it is clipped.
// With images of at most 16384 texels this keeps snapped coordinates below 2^23 and every
// edge-function product below 2^49 (raster_shared.h; the GPU rasterizer clips alike).
inline constexpr float kGuardBand = shader::kRasterGuardBand;

// A triangle clipped to a convex polygon can gain one vertex per plane.
inline constexpr int kMaxClipVertices = shader::kRasterMaxClipVertices;

// Transforms triangles into homogeneous texel space and clips them against
// near <= z <= far and the guard band; built once per render.
class TriangleClipper {
 public:
  explicit TriangleClipper(const LightView& view);
  // Returns the number of vertices of the clipped convex polygon (0 when nothing remains),
  // written to out in the triangle's winding order.
  int clip(const RasterTriangle& t, ClipVertex out[kMaxClipVertices]) const;

 private:
  // The columns of LightView::texel_projection as 4-wide vectors (GCC/Clang vector
  // extensions): a vertex transform is then 3 multiply-adds instead of 28 scalar operations.
  typedef float Float4 __attribute__((vector_size(16)));
  Float4 col_[4];
  Vec3f eye_;  // texel_projection takes p - eye
  float near_, far_, x_max_, y_max_;
};

// Whether the light sees the side t's normal cross(p1 - p0, p2 - p0) points to.
inline bool faces_light(const RasterTriangle& t, const LightView& view) {
  Vec3f n = cross(t.p[1] - t.p[0], t.p[2] - t.p[0]);
  if (view.is_perspective()) return dot(n, view.eye() - t.p[0]) > 0;
  return dot(n, view.forward()) < 0;
}

}  // namespace penumbra::raster_internal
