#include "penumbra/shadow/multilayer/multilayer_map.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "penumbra/core/parallel.h"
#include "penumbra/raster/shadow_view.h"

namespace penumbra::multilayer {

CentreView light_centre_view(const AreaLight& light, std::span<const Vec3f> receivers, const Bounds3f& casters,
                             const ViewOptions& options) {
  ShadowViewFit fit;
  fit.resolution = options.resolution;
  fit.max_fov = options.max_fov;
  const Vec3f dir = light.frame.n, up = light.frame.t;
  CentreView out;
  out.view = fit_shadow_view(light.center, dir, up, receivers, casters, fit);
  const LightView& v = out.view;
  // The half angle of the fitted window: its widest edge from the axis.
  const float edge = std::max({std::abs(v.window_left()), std::abs(v.window_right()), std::abs(v.window_bottom()),
                               std::abs(v.window_top())}) / v.near();
  out.half_fov_deg = degrees(std::atan(edge));
  if (!options.push_back) return out;
  out.push_back = light.extent_radius() / edge;  // eq. 4: light_radius / tan(fov / 2)
  const Vec3f eye = light.center - dir * out.push_back;
  std::vector<Vec3f> points(receivers.begin(), receivers.end());
  for (Vec3f q : light.outline(32)) points.push_back(q);
  // The light itself must not be clipped by the near plane: fit keeps near in front of the
  // casters and receivers; with the light's outline among the receivers it is in front of
  // the light too (at depth ~d).
  out.view = fit_shadow_view(eye, dir, up, points, casters, fit);
  return out;
}

size_t OpaqueLayerMap::memory_bytes() const {
  size_t pyr = 0;
  for (int l = 0; l < pyramid.levels(); ++l) pyr += pyramid.level(l).size() * sizeof(DepthRange);
  return layers.counts.size() + layers.samples.size() * sizeof(DepthSample) + pyr;
}

size_t TransparentMap::memory_bytes() const {
  size_t pyr = 0;
  for (int l = 0; l < pyramid.levels(); ++l) pyr += pyramid.level(l).size() * sizeof(DepthRange);
  return layers.memory_bytes() + pyr;
}

void build_opaque_layer_map(Rasterizer& rasterizer, std::span<const RasterTriangle> triangles, const LightView& view,
                            int k, OpaqueLayerMap* out) {
  LayerOptions options;
  options.layers = k;
  rasterizer.layered_depth_map(triangles, view, options, &out->layers);
  // Over window depth, which is affine along a projected segment (the walker's contract);
  // the layers are compared in linear depth at the texels (xie2007 §6.1).
  out->pyramid = MinMaxPyramid(out->layers, DepthKind::Window);
  const DepthRange root = out->pyramid.root();
  out->z_min = root.empty() ? kInfinity : view.linear_depth_from_window(root.lo);
}

void build_transparent_map(Rasterizer& rasterizer, std::span<const RasterTriangle> triangles, const LightView& view,
                           const CompressionOptions& options, TransparentMap* out) {
  const int w = view.width(), h = view.height();
  const size_t texels = static_cast<size_t>(w) * h;
  // Compressed layers per texel, written by the visitor (one call per texel, any thread,
  // so each texel's vector is written by one thread only), then packed into flat storage.
  std::vector<std::vector<TransparentLayer>> per_texel(texels);
  std::atomic<size_t> fragments{0};
  rasterizer.visit_fragments(triangles, view, RasterFilter{}, [&](int x, int y, std::span<const Fragment> f) {
    if (f.empty()) return;
    fragments += f.size();
    std::vector<TransparentLayer>& dst = per_texel[static_cast<size_t>(y) * w + x];
    compress_fragments(f, options, &dst);
  });
  TransparentLayerMap& m = out->layers;
  m.width = w;
  m.height = h;
  m.offsets.assign(texels + 1, 0);
  for (size_t i = 0; i < texels; ++i) m.offsets[i + 1] = m.offsets[i] + static_cast<uint32_t>(per_texel[i].size());
  m.layers.resize(m.offsets[texels]);
  parallel_for(texels, 4096, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; ++i) std::copy(per_texel[i].begin(), per_texel[i].end(), m.layers.begin() + m.offsets[i]);
  });
  std::vector<DepthRange> ranges = m.texel_ranges();
  float z_min = kInfinity;
  for (DepthRange& r : ranges) {
    if (r.empty()) continue;
    z_min = std::min(z_min, r.lo);
    r = {view.window_depth(r.lo), view.window_depth(r.hi)};
  }
  out->pyramid = MinMaxPyramid(w, h, ranges);
  out->z_min = z_min;
  out->fragments = fragments.load();
}

}  // namespace penumbra::multilayer
