#include "penumbra/shadow/coherent_rt/reference_images.h"

#include <cmath>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/raster/rasterizer.h"
#include "penumbra/scene/scene.h"
#include "penumbra/shadow/coherent_rt/reference_images_shared.h"
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
  return reference_view(fit_shadow_region(scene, light), light, eye, resolution);
}

LightView reference_view(const ShadowRegion& region, const AreaLight& light, Vec3f eye, int resolution) {
  if (region.empty) throw Error("coherent-rt: no object can cast a shadow from this light");
  LightAxes axes = light_axes(light);
  // A point at depth z and centre-view coordinate u appears at u - dx / z from the eye
  // (eq. 3 of agrawala2000 §4, the same depth for every point of the light's plane).
  const Vec3f d = eye - axes.eye;
  const float dx = dot(d, axes.right), dy = dot(d, axes.up);
  constexpr float kMaxTan = 4.0f;
  ShadowRegion r = region;
  r.u0 = std::max(-kMaxTan, region.u0 - std::max(dx / region.near, dx / region.far));
  r.u1 = std::min(kMaxTan, region.u1 - std::min(dx / region.near, dx / region.far));
  r.v0 = std::max(-kMaxTan, region.v0 - std::max(dy / region.near, dy / region.far));
  r.v1 = std::min(kMaxTan, region.v1 - std::min(dy / region.near, dy / region.far));
  axes.eye = eye;
  return lam::reference_view(axes, r, resolution);
}

std::vector<uint8_t> objects_closed(const Scene& scene) {
  std::vector<uint8_t> closed(scene.objects.size());
  for (size_t i = 0; i < closed.size(); ++i) closed[i] = scene.objects[i].closed ? 1 : 0;
  return closed;
}

ReferenceImage build_reference_image(RasterTriangleView tris, const LightView& view,
                                     const ReferenceImageOptions& options, std::span<const uint8_t> object_closed,
                                     BuildTimes* times) {
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

  // Floors (biased, window depth) and walls (connectivity to the 8 neighbours): each texel by
  // reference_images_shared.h's functions, which the GPU's kernels run too.
  const size_t n = static_cast<size_t>(W) * H;
  img.floor.assign(n, kInfinity);
  img.links.assign(n, 0);
  const shader::CrtTexels texels{map.z.data(), map.triangle.data(), img.links.data(), img.floor.data(), W, H};
  const shader::CrtBuildOptions build{options.gap_bias, options.shadow_bias, options.slope_bias,
                                      options.open_shadow_bias};
  auto closed_at = [&](size_t i) {
    const uint32_t object = tris[map.triangle[i]].object;
    return object < object_closed.size() && object_closed[object] != 0;
  };
  const shader::RasterView& v = view.shared();
  parallel_for(H, 16, [&](size_t begin, size_t end) {
    for (int y = static_cast<int>(begin); y < static_cast<int>(end); ++y)
      for (int x = 0; x < W; ++x)
        if (map.triangle[map.index(x, y)] != kNoTriangle)
          img.links[map.index(x, y)] = static_cast<uint8_t>(shader::crt_links_of(texels, v, options.gap_bias, x, y));
  });
  parallel_for(H, 16, [&](size_t begin, size_t end) {
    for (int y = static_cast<int>(begin); y < static_cast<int>(end); ++y)
      for (int x = 0; x < W; ++x)
        if (map.triangle[map.index(x, y)] != kNoTriangle)
          img.floor[map.index(x, y)] = shader::crt_floor_of(texels, v, build, x, y, closed_at(map.index(x, y)));
  });
  // Texel ranges: the floor and the walls to connected neighbours.
  std::vector<DepthRange> ranges(n);
  parallel_for(H, 16, [&](size_t begin, size_t end) {
    for (int y = static_cast<int>(begin); y < static_cast<int>(end); ++y)
      for (int x = 0; x < W; ++x) {
        const Vec2f r = shader::crt_range_of(texels, x, y);
        ranges[static_cast<size_t>(y) * W + x] = {r.x, r.y};
      }
  });
  if (times) times->floors_ms += timer.elapsed_ms();
  timer.reset();
  img.pyramid = MinMaxPyramid(W, H, ranges);

  // Connectedness quadtree, bottom up: a node is connected when its children are and every
  // edge-adjacent pair across the children's shared borders is (agrawala2000 §5.1.1).
  const int levels = img.pyramid.levels();
  const shader::DepthPyramidLevels pyramid_levels(img.pyramid);
  img.connected.resize(levels);
  img.connected[0].resize(n);
  for (size_t i = 0; i < n; ++i) img.connected[0][i] = img.floor[i] < kInfinity;
  for (int l = 1; l < levels; ++l) {
    const int lw = img.pyramid.width(l), lh = img.pyramid.height(l);
    std::vector<uint8_t>& cur = img.connected[l];
    cur.assign(static_cast<size_t>(lw) * lh, 0);
    parallel_for(lh, 4, [&](size_t begin, size_t end) {
      for (int y = static_cast<int>(begin); y < static_cast<int>(end); ++y)
        for (int x = 0; x < lw; ++x)
          cur[static_cast<size_t>(y) * lw + x] = shader::crt_node_connected_of(texels, img.connected, pyramid_levels, l, x, y);
    });
  }
  if (times) times->pyramid_ms += timer.elapsed_ms();
  return img;
}

}  // namespace penumbra::coherent_rt
