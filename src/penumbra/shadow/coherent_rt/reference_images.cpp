#include "penumbra/shadow/coherent_rt/reference_images.h"

#include <cmath>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/raster/rasterizer.h"
#include "penumbra/scene/scene.h"
#include "penumbra/shadow/lam/attenuation_map.h"

namespace penumbra::coherent_rt {

size_t ReferenceImage::memory_bytes() const {
  size_t b = floor.size() * sizeof(float) + links.size();
  for (int l = 0; l < pyramid.levels(); ++l) b += pyramid.level(l).size() * sizeof(DepthRange);
  for (const auto& c : connected) b += c.size();
  return b;
}

uint64_t ReferenceImage::bytes(int w, int h) {
  const uint64_t texels = static_cast<uint64_t>(w) * static_cast<uint64_t>(h);
  // Floors and links per texel; the min/max quadtree and a connectedness byte per node.
  return texels * (sizeof(float) + sizeof(uint8_t)) + MinMaxPyramid::bytes(w, h) + MinMaxPyramid::nodes(w, h);
}

uint64_t ReferenceImage::build_scratch_bytes(int w, int h) {
  return DepthMap::bytes(w, h) + static_cast<uint64_t>(w) * static_cast<uint64_t>(h) * sizeof(DepthRange);
}

namespace {
bool has_corners(const std::string& views) { return views == "corners" || views == "corners+center"; }
bool has_center(const std::string& views) { return views == "center" || views == "corners+center"; }
}  // namespace

int view_point_count(const std::string& views) { return (has_corners(views) ? 4 : 0) + (has_center(views) ? 1 : 0); }

std::vector<Vec3f> view_points(const AreaLight& light, const std::string& views) {
  std::vector<Vec3f> out;
  if (has_corners(views)) {
    Vec3f hs, ht;
    if (light.shape == LightShape::Rect) {
      hs = light.frame.s * (0.5f * light.size.x);
      ht = light.frame.t * (0.5f * light.size.y);
      for (int k = 0; k < 4; ++k) out.push_back(light.center + hs * ((k & 1) ? 1.0f : -1.0f) + ht * ((k & 2) ? 1.0f : -1.0f));
    } else {
      // A disk, or the disk (ellipse) of a sphere (ellipsoid) facing frame.n.
      const bool ellipsoid = light.shape == LightShape::Ellipsoid;
      hs = light.frame.s * (ellipsoid ? light.radii.x : light.radius);
      ht = light.frame.t * (ellipsoid ? light.radii.y : light.radius);
      out = {light.center + hs, light.center - hs, light.center + ht, light.center - ht};
    }
  }
  if (has_center(views)) out.push_back(light.center);
  if (out.empty()) throw Error("coherent-rt: views '{}' must be corners, center or corners+center", views);
  return out;
}

LightView reference_view(const Scene& scene, const AreaLight& light, Vec3f eye, int resolution) {
  const lam::ShadowRegion region = lam::fit_shadow_region(scene, light);
  if (region.empty) throw Error("coherent-rt: no object can cast a shadow from this light");
  lam::LightAxes axes = lam::light_axes(light);
  // A point at depth z and centre-view coordinate u appears at u - dx / z from the eye
  // (eq. 3 of agrawala2000 §4, the same depth for every point of the light's plane).
  const Vec3f d = eye - axes.eye;
  const float dx = dot(d, axes.right), dy = dot(d, axes.up);
  constexpr float kMaxTan = 4.0f;
  lam::ShadowRegion r = region;
  r.u0 = std::max(-kMaxTan, region.u0 - std::max(dx / region.near, dx / region.far));
  r.u1 = std::min(kMaxTan, region.u1 - std::min(dx / region.near, dx / region.far));
  r.v0 = std::max(-kMaxTan, region.v0 - std::max(dy / region.near, dy / region.far));
  r.v1 = std::min(kMaxTan, region.v1 - std::min(dy / region.near, dy / region.far));
  axes.eye = eye;
  return lam::reference_view(axes, r, resolution);
}

ReferenceImage build_reference_image(RasterTriangleView tris, const LightView& view,
                                     const ReferenceImageOptions& options, BuildTimes* times) {
  ReferenceImage img;
  img.view = view;
  const int W = view.width(), H = view.height();
  img.width = W;
  img.height = H;
  Timer timer;
  DepthMap map;
  {
    Rasterizer raster;
    raster.depth_map(tris, view, RasterFilter{}, &map);
  }
  if (times) times->raster_ms += timer.elapsed_ms();
  timer.reset();

  // Floors (biased, window depth) and walls (connectivity to the 8 neighbours).
  const size_t n = static_cast<size_t>(W) * H;
  img.floor.assign(n, kInfinity);
  img.links.assign(n, 0);
  parallel_for(H, 16, [&](size_t begin, size_t end) {
    for (int y = static_cast<int>(begin); y < static_cast<int>(end); ++y)
      for (int x = 0; x < W; ++x) {
        size_t i = map.index(x, y);
        if (map.triangle[i] == kNoTriangle) continue;
        float z = map.z[i];
        uint8_t links = 0;
        for (int k = 0; k < 8; ++k) {
          int nx = x + kNeighbourDx[k], ny = y + kNeighbourDy[k];
          if (nx < 0 || ny < 0 || nx >= W || ny >= H) continue;
          size_t j = map.index(nx, ny);
          if (map.triangle[j] == kNoTriangle) continue;
          // Symmetric: the gap is measured at the nearer of the two depths.
          float zj = map.z[j];
          float gap = options.gap_bias * view.texel_world_size(std::min(z, zj)) * (k >= 4 ? 1.41421356f : 1.0f);
          if (std::abs(z - zj) <= gap) links |= uint8_t(1u << k);
        }
        img.links[i] = links;
      }
  });
  // Floors, pushed back by the shadow bias plus, slope-scaled, the largest depth step to a
  // connected neighbour (a surface seen at a grazing angle moves that much per texel, so a
  // point anywhere in the texel lies up to about that far behind the sampled depth).
  parallel_for(H, 16, [&](size_t begin, size_t end) {
    for (int y = static_cast<int>(begin); y < static_cast<int>(end); ++y)
      for (int x = 0; x < W; ++x) {
        size_t i = map.index(x, y);
        if (map.triangle[i] == kNoTriangle) continue;
        const float z = map.z[i];
        float step = 0;
        for (int k = 0; k < 4; ++k)
          if (img.links[i] & (1u << k)) step = std::max(step, std::abs(map.z[map.index(x + kNeighbourDx[k], y + kNeighbourDy[k])] - z));
        img.floor[i] = view.window_depth(z + options.shadow_bias * view.texel_world_size(z) + options.slope_bias * step);
      }
  });
  // Texel ranges: the floor and the walls to connected neighbours.
  std::vector<DepthRange> ranges(n);
  parallel_for(H, 16, [&](size_t begin, size_t end) {
    for (int y = static_cast<int>(begin); y < static_cast<int>(end); ++y)
      for (int x = 0; x < W; ++x) {
        size_t i = static_cast<size_t>(y) * W + x;
        float f = img.floor[i];
        if (f == kInfinity) continue;
        DepthRange r{f, f};
        uint8_t links = img.links[i];
        for (int k = 0; k < 8; ++k)
          if (links & (1u << k)) {
            float g = img.floor[static_cast<size_t>(y + kNeighbourDy[k]) * W + (x + kNeighbourDx[k])];
            r.lo = std::min(r.lo, g);
            r.hi = std::max(r.hi, g);
          }
        ranges[i] = r;
      }
  });
  if (times) times->floors_ms += timer.elapsed_ms();
  timer.reset();
  img.pyramid = MinMaxPyramid(W, H, ranges);

  // Connectedness quadtree, bottom up: a node is connected when its children are and every
  // edge-adjacent pair across the children's shared borders is (agrawala2000 §5.1.1).
  const int levels = img.pyramid.levels();
  img.connected.resize(levels);
  img.connected[0].resize(n);
  for (size_t i = 0; i < n; ++i) img.connected[0][i] = img.floor[i] < kInfinity;
  auto linked = [&](int x, int y, int dx, int dy) {
    return (img.links[static_cast<size_t>(y) * W + x] >> neighbour_bit(dx, dy)) & 1u;
  };
  for (int l = 1; l < levels; ++l) {
    const int lw = img.pyramid.width(l), lh = img.pyramid.height(l);
    const int cw = img.pyramid.width(l - 1);
    const std::vector<uint8_t>& child = img.connected[l - 1];
    std::vector<uint8_t>& cur = img.connected[l];
    cur.assign(static_cast<size_t>(lw) * lh, 0);
    parallel_for(lh, 4, [&](size_t begin, size_t end) {
      for (int y = static_cast<int>(begin); y < static_cast<int>(end); ++y)
        for (int x = 0; x < lw; ++x) {
          bool ok = true;
          for (int cy = 2 * y; ok && cy < std::min(2 * y + 2, img.pyramid.height(l - 1)); ++cy)
            for (int cx = 2 * x; ok && cx < std::min(2 * x + 2, cw); ++cx) ok = child[static_cast<size_t>(cy) * cw + cx] != 0;
          if (!ok) continue;
          int x0, y0, x1, y1;
          img.pyramid.texels(l, x, y, &x0, &y0, &x1, &y1);
          const int xm = x0 + (1 << (l - 1)), ym = y0 + (1 << (l - 1));
          if (xm < x1)
            for (int ty = y0; ok && ty < y1; ++ty) ok = linked(xm - 1, ty, 1, 0);
          if (ym < y1)
            for (int tx = x0; ok && tx < x1; ++tx) ok = linked(tx, ym - 1, 0, 1);
          cur[static_cast<size_t>(y) * lw + x] = ok;
        }
    });
  }
  if (times) times->pyramid_ms += timer.elapsed_ms();
  return img;
}

}  // namespace penumbra::coherent_rt
