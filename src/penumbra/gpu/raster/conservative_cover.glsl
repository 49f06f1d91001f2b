// Conservative rasterization in compute (raster/conservative.h on the GPU; sintorn2008 §3.2 and
// §4.1 need every texel a convex polygon touches, not only those whose centre it covers): the
// texel rows a polygon's bounding box spans, and per row the columns whose closed square meets
// the polygon, by the CPU's separating-axis test (per polygon edge, the square's corner farthest
// inside it). In float, so the polygon is grown by `slack` texels against rounding (the CPU grows
// it by 1e-5 in double): extra texels cost work, never coverage. Also the convex hull of a few
// points (Andrew's monotone chain, influence_region.cpp convex_hull) for regions given as points.
#ifndef PENUMBRA_GPU_RASTER_CONSERVATIVE_COVER_GLSL
#define PENUMBRA_GPU_RASTER_CONSERVATIVE_COVER_GLSL

#include "penumbra/gpu/kernel_common.glsl"

// The texels [ix0, ix1) x [iy0, iy1) of a width x height image whose closed squares meet the box
// [x0, x1] x [y0, y1] grown by slack (conservative.cpp set_up); false when none.
bool conservative_box(float x0, float x1, float y0, float y1, int width, int height, float slack, out int ix0,
                      out int ix1, out int iy0, out int iy1) {
  // Square [i, i+1] meets [x0, x1] iff i <= x1 and i + 1 >= x0.
  ix0 = int(clamp(ceil(x0 - slack - 1.0f), 0.0f, float(width)));
  ix1 = int(clamp(floor(x1 + slack) + 1.0f, 0.0f, float(width)));
  iy0 = int(clamp(ceil(y0 - slack - 1.0f), 0.0f, float(height)));
  iy1 = int(clamp(floor(y1 + slack) + 1.0f, 0.0f, float(height)));
  return ix0 < ix1 && iy0 < iy1;
}

// The columns [lo, hi] of row y, within [x0, x1), whose squares meet the convex polygon of n
// vertices at poly.v[base ..] (either winding; n = 1 or 2: a point or a segment) grown by slack
// (conservative.cpp cover); false when none.
bool conservative_row_span(Vec2s poly, uint base, int n, int y, int x0, int x1, float slack, out int lo, out int hi) {
  float area = 0.0f;
  for (int e = 0; e < n; ++e) {
    vec2 a = poly.v[base + uint(e)], b = poly.v[base + uint((e + 1) % n)];
    area += a.x * b.y - a.y * b.x;
  }
  float sgn = area < 0.0f ? -1.0f : 1.0f;
  float x_lo = float(x0), x_hi = float(x1 - 1);
  for (int e = 0; e < n && x_lo <= x_hi; ++e) {
    vec2 a = poly.v[base + uint(e)], b = poly.v[base + uint((e + 1) % n)];
    float nx = -sgn * (b.y - a.y), ny = sgn * (b.x - a.x);
    // Column x is inside this edge when nx x + K >= 0 (the best corner, relative to a).
    float K = ny * (float(y) + (ny > 0.0f ? 1.0f : 0.0f) - a.y) + nx * ((nx > 0.0f ? 1.0f : 0.0f) - a.x) +
              slack * (abs(nx) + abs(ny));
    if (nx > 0.0f) x_lo = max(x_lo, ceil(-K / nx));
    else if (nx < 0.0f) x_hi = min(x_hi, floor(K / -nx));
    else if (K < 0.0f) x_hi = x_lo - 1.0f;
  }
  lo = int(x_lo);
  hi = int(x_hi);
  return x_lo <= x_hi;
}

// The most points conservative_hull takes.
const int kConservativeHullPoints = 12;

// The convex hull of the n points p[0, n) (n <= kConservativeHullPoints), counter-clockwise, in
// place; returns its vertex count (1 or 2 for coincident or collinear points).
int conservative_hull(inout vec2 p[kConservativeHullPoints], int n) {
  // Sorted by x, then y (insertion sort: a dozen points).
  for (int i = 1; i < n; ++i) {
    vec2 v = p[i];
    int j = i - 1;
    while (j >= 0 && (p[j].x > v.x || (p[j].x == v.x && p[j].y > v.y))) {
      p[j + 1] = p[j];
      --j;
    }
    p[j + 1] = v;
  }
  if (n < 3) return n;
  vec2 hull[2 * kConservativeHullPoints];
  int k = 0;
  for (int i = 0; i < n; ++i) {  // lower hull
    while (k >= 2 && (hull[k - 1].x - hull[k - 2].x) * (p[i].y - hull[k - 2].y) -
                             (hull[k - 1].y - hull[k - 2].y) * (p[i].x - hull[k - 2].x) <= 0.0f)
      --k;
    hull[k++] = p[i];
  }
  for (int i = n - 2, t = k + 1; i >= 0; --i) {  // upper hull
    while (k >= t && (hull[k - 1].x - hull[k - 2].x) * (p[i].y - hull[k - 2].y) -
                             (hull[k - 1].y - hull[k - 2].y) * (p[i].x - hull[k - 2].x) <= 0.0f)
      --k;
    hull[k++] = p[i];
  }
  k = max(k - 1, 1);  // the last point repeats the first
  for (int i = 0; i < k; ++i) p[i] = hull[i];
  return k;
}

#endif
