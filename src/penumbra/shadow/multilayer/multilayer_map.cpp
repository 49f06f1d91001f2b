#include "penumbra/shadow/multilayer/multilayer_map.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "penumbra/core/parallel.h"
#include "penumbra/raster/shadow_view.h"

namespace penumbra::multilayer {

CentreView light_centre_view(const AreaLight& light, std::span<const Vec3f> receivers, const Bounds3f& casters,
                             const ViewOptions& options, std::span<const Bounds3f> caster_boxes) {
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
  const std::vector<Vec3f> outline = light.outline(32);
  float z_c = -kInfinity;
  if (!caster_boxes.empty()) {
    z_c = kInfinity;
    for (const Bounds3f& b : caster_boxes)
      for (int c = 0; c < 8; ++c) z_c = std::min(z_c, dot(b.corner(c) - eye, dir));
  }
  float z_light = kInfinity;
  for (Vec3f q : outline) z_light = std::min(z_light, dot(q - eye, dir));
  // Room for every point at once (light_centre_view_bytes): growing by doubling would hold
  // up to three times as many while copying.
  size_t crossings = outline.size();
  if (z_c > z_light) {
    crossings = 0;
    for (Vec3f r : receivers) crossings += dot(r - eye, dir) > z_c ? outline.size() : 0;
  }
  std::vector<Vec3f> points;
  points.reserve(receivers.size() + crossings);
  points.assign(receivers.begin(), receivers.end());
  if (!(z_c > z_light)) {
    for (Vec3f q : outline) points.push_back(q);
  } else {
    // The segments' crossings of depth z_c, for every receiver beyond it.
    for (Vec3f r : receivers) {
      const float zr = dot(r - eye, dir);
      if (!(zr > z_c)) continue;
      for (Vec3f q : outline) {
        const float zq = dot(q - eye, dir);
        const float t = (zr - z_c) / (zr - zq);
        points.push_back(r + (q - r) * t);
      }
    }
  }
  // The light itself must not be clipped by the near plane: fit keeps near in front of the
  // casters and receivers; with the light's outline among the receivers it is in front of
  // the light too (at depth ~d).
  out.view = fit_shadow_view(eye, dir, up, points, casters, fit);
  return out;
}

namespace {

// Whether every vertex of the mesh lies on one plane (within 1e-5 of its size); *n, *d: the
// plane dot(n, x) = d.
bool planar(const TriangleMesh& m, Vec3f* n, float* d) {
  const Bounds3f b = m.bounds();
  const float eps = 1e-5f * std::max(1e-12f, length(b.diagonal()));
  for (size_t t = 0; 3 * t + 2 < m.indices.size(); ++t) {
    const Vec3f a = m.positions[m.indices[3 * t]], e1 = m.positions[m.indices[3 * t + 1]] - a,
                e2 = m.positions[m.indices[3 * t + 2]] - a;
    const Vec3f c = cross(e1, e2);
    if (length(c) <= eps * eps) continue;
    *n = normalize(c);
    *d = dot(*n, a);
    for (Vec3f p : m.positions)
      if (std::abs(dot(*n, p) - *d) > eps) return false;
    return true;
  }
  return false;
}

}  // namespace

std::vector<Bounds3f> caster_boxes(const Scene& scene, const AreaLight& light, std::span<const Vec3f> receivers) {
  std::vector<Bounds3f> casters;
  for (const SceneObject& o : scene.objects) {
    Vec3f n;
    float d = 0;
    if (o.mesh.positions.empty()) continue;
    if (planar(o.mesh, &n, &d)) {
      // A plane shadows only what lies on the side away from (part of) the light.
      const float side = dot(n, light.center) - d;
      bool behind = false;
      const float tol = -1e-4f * std::abs(side);
      for (Vec3f q : light.outline(16)) behind |= (dot(n, q) - d) * side < tol;  // light straddles the plane
      for (size_t i = 0; i < receivers.size() && !behind; ++i) behind = (dot(n, receivers[i]) - d) * side < tol;
      if (!behind) continue;
    }
    casters.push_back(o.mesh.bounds());
  }
  return casters;
}

std::vector<Vec3f> shadowable_receivers(std::span<const Bounds3f> casters, const AreaLight& light,
                                       std::span<const Vec3f> receivers) {
  const std::vector<Vec3f> outline = light.outline(16);
  std::vector<uint8_t> keep(receivers.size(), 0);
  parallel_for(receivers.size(), 1024, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; ++i) {
      const Vec3f p = receivers[i];
      const Vec3f a = normalize(light.center - p);
      Vec3f u, v;
      coordinate_system(a, &u, &v);
      auto window = [&](Vec3f x, float* wx, float* wy) {
        const Vec3f dx = x - p;
        const float z = dot(dx, a);
        if (!(z > 1e-6f)) return false;
        *wx = dot(dx, u) / z;
        *wy = dot(dx, v) / z;
        return true;
      };
      float lx0 = kInfinity, lx1 = -kInfinity, ly0 = kInfinity, ly1 = -kInfinity;
      bool ok = true;
      for (Vec3f q : outline) {
        float x = 0, y = 0;
        if (!window(q, &x, &y)) { ok = false; break; }
        lx0 = std::min(lx0, x), lx1 = std::max(lx1, x), ly0 = std::min(ly0, y), ly1 = std::max(ly1, y);
      }
      if (!ok) { keep[i] = 1; continue; }
      for (const Bounds3f& box : casters) {
        float bx0 = kInfinity, bx1 = -kInfinity, by0 = kInfinity, by1 = -kInfinity;
        bool front = true;
        for (int c = 0; c < 8 && front; ++c) {
          float x = 0, y = 0;
          front = window(box.corner(c), &x, &y);
          bx0 = std::min(bx0, x), bx1 = std::max(bx1, x), by0 = std::min(by0, y), by1 = std::max(by1, y);
        }
        if (!front || (bx0 <= lx1 && lx0 <= bx1 && by0 <= ly1 && ly0 <= by1)) {
          keep[i] = 1;
          break;
        }
      }
    }
  });
  std::vector<Vec3f> out;
  for (size_t i = 0; i < receivers.size(); ++i)
    if (keep[i]) out.push_back(receivers[i]);
  if (out.empty()) out.assign(receivers.begin(), receivers.end());
  return out;
}

uint64_t light_centre_view_bytes(uint64_t receivers, uint64_t outline_points) {
  return receivers * (1 + outline_points) * sizeof(Vec3f);
}

uint64_t TransparentMap::build_bytes(int w, int h, int layers_per_texel) {
  const uint64_t texels = static_cast<uint64_t>(w) * static_cast<uint64_t>(h);
  const uint64_t layers = texels * static_cast<uint64_t>(layers_per_texel);
  const uint64_t map = (texels + 1) * sizeof(uint32_t) + layers * sizeof(TransparentLayer) + MinMaxPyramid::bytes(w, h);
  const uint64_t per_texel = texels * sizeof(std::vector<TransparentLayer>) + 2 * layers * sizeof(TransparentLayer);
  return map + per_texel + texels * sizeof(DepthRange);
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

void build_opaque_layer_map(Rasterizer& rasterizer, RasterTriangleView triangles, const LightView& view,
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

void build_transparent_map(Rasterizer& rasterizer, RasterTriangleView triangles, const LightView& view,
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
