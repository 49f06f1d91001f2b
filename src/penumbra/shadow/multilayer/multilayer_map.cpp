#include "penumbra/shadow/multilayer/multilayer_map.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "penumbra/core/parallel.h"
#include "penumbra/raster/shadow_view.h"
#include "penumbra/shadow/multilayer/multilayer_view_shared.h"
#include "penumbra/trace/ray_shared.h"

namespace penumbra::multilayer {

partitions::GuardSamples partition_guards(const ParamSet& p) {
  return p.get_bool("push_back") ? partitions::GuardSamples::OnlyToFit : partitions::GuardSamples::AtTheMargin;
}

MultilayerSettings multilayer_settings(const ParamSet& p, bool transparent) {
  MultilayerSettings s;
  s.view.resolution = p.get_int("resolution");
  s.view.max_fov = p.get_float("max_fov");
  s.view.push_back = p.get_bool("push_back");
  s.fit_shadowable = p.get_bool("fit_shadowable");
  s.z_thresh = p.get_float("z_thresh");
  s.z_thresh_texels = p.get_float("z_thresh_texels");
  s.self_bias = p.get_float("self_bias");
  s.open_self_bias = p.get_float("open_self_bias");
  s.near_field = p.get_float("near_field");
  s.trace_unresolved = p.get_string("unresolved") == "trace";
  if (!transparent) {
    s.layers = p.get_int("layers");
  } else {
    s.compression.resets = p.get_int("resets");
    s.compression.error = p.get_float("error");
    s.stop_below = p.get_float("stop_below");
  }
  return s;
}

PushBackPlan plan_push_back(const AreaLight& light, const LightView& centre, const Bounds3f& casters,
                            const ViewOptions& options, std::span<const Bounds3f> caster_boxes) {
  PushBackPlan plan;
  plan.dir = light.frame.n;
  plan.up = light.frame.t;
  plan.fit.resolution = options.resolution;
  plan.fit.max_fov = options.max_fov;
  // The half angle of the fitted window: its widest edge from the axis.
  const float edge = std::max({std::abs(centre.window_left()), std::abs(centre.window_right()),
                               std::abs(centre.window_bottom()), std::abs(centre.window_top())}) /
                     centre.near();
  plan.half_fov_deg = degrees(std::atan(edge));
  if (!options.push_back) return plan;
  plan.push_back = light.extent_radius() / edge;  // eq. 4: light_radius / tan(fov / 2)
  plan.eye = light.center - plan.dir * plan.push_back;
  plan.outline = light.outline(32);
  plan.z_c = -kInfinity;
  if (!caster_boxes.empty()) {
    plan.z_c = kInfinity;
    for (const Bounds3f& b : caster_boxes)
      for (int c = 0; c < 8; ++c) plan.z_c = std::min(plan.z_c, dot(b.corner(c) - plan.eye, plan.dir));
  }
  float z_light = kInfinity;
  for (Vec3f q : plan.outline) z_light = std::min(z_light, dot(q - plan.eye, plan.dir));
  plan.crossings = plan.z_c > z_light;
  // Nothing on or behind the light's plane can stand between a receiver and a point of the light
  // (the segment lies in front of it, trace/ray_shared.h on_or_behind_light_plane), so the map
  // starts just past it, the light centre's ray offset beyond. In a room lit from just below its
  // ceiling, the ceiling was otherwise every texel's nearest layer, no quadtree node could be
  // skipped, and mlsm took 7,000 times the reference's time; a ceiling flush with the light
  // covered every ray (docs/methods/multilayer.md, "Casters behind the light"). The outline,
  // which the window must hold and which the fit ignores nearer than min_near, moves along its
  // rays from the eye to just past that: the same texels. (The segments to the light are clipped
  // at the near plane: depth_image_project.)
  const float margin = shader::ray_offset_epsilon(light.center);
  plan.fit.min_near = z_light + margin;
  const float to_past_near = (z_light + 2 * margin) / z_light;
  for (Vec3f& q : plan.outline) q = plan.eye + (q - plan.eye) * to_past_near;
  plan.frame = shadow_view_frame(plan.eye, plan.dir, plan.up, casters, {}, plan.fit);
  return plan;
}

float segments_held_beyond(const PushBackPlan& plan, const LightView& view, bool push_back) {
  if (!push_back) return kInfinity;
  const float edge = std::max({std::abs(view.window_left()), std::abs(view.window_right()),
                               std::abs(view.window_bottom()), std::abs(view.window_top())}) /
                     view.near();
  const bool capped = edge >= std::tan(radians(0.5f * plan.fit.max_fov)) * (1 - 1e-4f);
  if (!capped) return kInfinity;
  return plan.crossings ? plan.z_c : plan.fit.min_near;
}

CentreView light_centre_view(const AreaLight& light, std::span<const Vec3f> receivers, const Bounds3f& casters,
                             const ViewOptions& options, std::span<const Bounds3f> caster_boxes) {
  ShadowViewFit fit;
  fit.resolution = options.resolution;
  fit.max_fov = options.max_fov;
  CentreView out;
  out.view = fit_shadow_view(light.center, light.frame.n, light.frame.t, receivers, casters, fit);
  const PushBackPlan plan = plan_push_back(light, out.view, casters, options, caster_boxes);
  out.half_fov_deg = plan.half_fov_deg;
  if (!options.push_back) return out;
  out.push_back = plan.push_back;
  // Room for every point at once (light_centre_view_bytes): growing by doubling would hold
  // up to three times as many while copying.
  size_t crossings = plan.outline.size();
  if (plan.crossings) {
    crossings = 0;
    for (Vec3f r : receivers) crossings += dot(r - plan.eye, plan.dir) > plan.z_c ? plan.outline.size() : 0;
  }
  std::vector<Vec3f> points;
  points.reserve(receivers.size() + crossings);
  points.assign(receivers.begin(), receivers.end());
  if (!plan.crossings) {
    for (Vec3f q : plan.outline) points.push_back(q);
  } else {
    // The segments' crossings of depth z_c, for every receiver beyond it.
    for (Vec3f r : receivers) {
      const float zr = dot(r - plan.eye, plan.dir);
      if (!(zr > plan.z_c)) continue;
      for (Vec3f q : plan.outline) points.push_back(shader::ml_segment_crossing(r, zr, q, plan.eye, plan.dir, plan.z_c));
    }
  }
  // The light itself must not be clipped by the near plane: fit keeps near in front of the
  // casters and receivers; with the light's outline among the receivers it is in front of
  // the light too (at depth ~d).
  out.view = fit_shadow_view(plan.eye, plan.dir, plan.up, points, casters, plan.fit);
  out.segments_held_beyond = segments_held_beyond(plan, out.view, true);
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

std::vector<CasterCandidate> caster_candidates(const Scene& scene, const AreaLight& light) {
  std::vector<CasterCandidate> out;
  const std::vector<Vec3f> outline = light.outline(16);
  for (const SceneObject& o : scene.objects) {
    if (o.mesh.positions.empty()) continue;
    CasterCandidate c;
    c.box = o.mesh.bounds();
    if (planar(o.mesh, &c.n, &c.d)) {
      // A plane shadows only what lies on the side away from (part of) the light.
      c.side = dot(c.n, light.center) - c.d;
      c.tol = -1e-4f * std::abs(c.side);
      bool straddles = false;
      for (Vec3f q : outline) straddles |= shader::ml_behind_plane(c.n, c.d, c.side, c.tol, q);
      c.needs_receiver_behind = !straddles;
    }
    out.push_back(c);
  }
  return out;
}

std::vector<Bounds3f> caster_boxes(const Scene& scene, const AreaLight& light, std::span<const Vec3f> receivers) {
  std::vector<Bounds3f> casters;
  for (const CasterCandidate& c : caster_candidates(scene, light)) {
    bool behind = !c.needs_receiver_behind;
    for (size_t i = 0; i < receivers.size() && !behind; ++i)
      behind = shader::ml_behind_plane(c.n, c.d, c.side, c.tol, receivers[i]);
    if (behind) casters.push_back(c.box);
  }
  return casters;
}

std::vector<float> flat_points(std::span<const Vec3f> points) {
  std::vector<float> out;
  out.reserve(3 * points.size());
  for (Vec3f p : points) out.insert(out.end(), {p.x, p.y, p.z});
  return out;
}

std::vector<float> flat_boxes(std::span<const Bounds3f> boxes) {
  std::vector<float> out;
  out.reserve(6 * boxes.size());
  for (const Bounds3f& b : boxes) out.insert(out.end(), {b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z});
  return out;
}

std::vector<Vec3f> shadowable_receivers(std::span<const Bounds3f> casters, const AreaLight& light,
                                       std::span<const Vec3f> receivers) {
  const std::vector<float> outline = flat_points(light.outline(16));
  const std::vector<float> boxes = flat_boxes(casters);
  const int n_outline = static_cast<int>(outline.size() / 3), n_boxes = static_cast<int>(casters.size());
  std::vector<uint8_t> keep(receivers.size(), 0);
  parallel_for(receivers.size(), 1024, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; ++i)
      keep[i] = shader::ml_shadowable(receivers[i], light.center, outline.data(), n_outline, boxes.data(), n_boxes);
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
  const uint64_t map = (texels + 1) * sizeof(uint32_t) + layers * sizeof(TransparentLayer) + texels /* truncated */ +
                       MinMaxPyramid::bytes(w, h);
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
                            int k, OpaqueLayerMap* out, bool unknown_beyond_full) {
  LayerOptions options;
  options.layers = k;
  rasterizer.layered_depth_map(triangles, view, options, &out->layers);
  // Over window depth, which is affine along a projected segment (the walker's contract);
  // the layers are compared in linear depth at the texels (xie2007 §6.1).
  const LayeredDepthMap& m = out->layers;
  if (!unknown_beyond_full) {
    out->pyramid = MinMaxPyramid(m, DepthKind::Window);
  } else {
    std::vector<DepthRange> ranges(static_cast<size_t>(m.width) * m.height);
    parallel_for(ranges.size(), 16384, [&](size_t begin, size_t end) {
      for (size_t i = begin; i < end; ++i) {
        const int n = m.counts[i];
        if (n == 0) continue;  // empty range
        const DepthSample* s = m.samples.data() + i * m.max_layers;  // nearest first
        ranges[i] = {s[0].depth, n >= m.max_layers ? shader::kMlBeyondFullTexel : s[n - 1].depth};
      }
    });
    out->pyramid = MinMaxPyramid(m.width, m.height, ranges);
  }
  const DepthRange root = out->pyramid.root();
  out->z_min = root.empty() ? kInfinity : view.linear_depth_from_window(root.lo);
}

void build_transparent_map(Rasterizer& rasterizer, RasterTriangleView triangles, const LightView& view,
                           const CompressionOptions& options, TransparentMap* out, bool unknown_beyond_full) {
  const int w = view.width(), h = view.height();
  const size_t texels = static_cast<size_t>(w) * h;
  // Compressed layers per texel, written by the visitor (one call per texel, any thread,
  // so each texel's vector is written by one thread only), then packed into flat storage.
  std::vector<std::vector<TransparentLayer>> per_texel(texels);
  TransparentLayerMap& m = out->layers;
  std::vector<uint8_t> truncated_texels(unknown_beyond_full ? texels : 0, 0);  // window_ranges' flags
  std::atomic<size_t> fragments{0};
  rasterizer.visit_fragments(triangles, view, RasterFilter{}, [&](int x, int y, std::span<const Fragment> f) {
    if (f.empty()) return;
    fragments += f.size();
    const size_t i = static_cast<size_t>(y) * w + x;
    bool truncated = false;
    compress_fragments(f, options, &per_texel[i], &truncated);
    if (unknown_beyond_full) truncated_texels[i] = truncated ? 1 : 0;
  });
  m.width = w;
  m.height = h;
  m.offsets.assign(texels + 1, 0);
  for (size_t i = 0; i < texels; ++i) m.offsets[i + 1] = m.offsets[i] + static_cast<uint32_t>(per_texel[i].size());
  m.layers.resize(m.offsets[texels]);
  parallel_for(texels, 4096, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; ++i) std::copy(per_texel[i].begin(), per_texel[i].end(), m.layers.begin() + m.offsets[i]);
  });
  float z_min = kInfinity;
  for (const DepthRange& r : m.texel_ranges())
    if (!r.empty()) z_min = std::min(z_min, r.lo);
  out->pyramid = MinMaxPyramid(w, h, m.window_ranges(view, truncated_texels));
  out->z_min = z_min;
  out->fragments = fragments.load();
}

}  // namespace penumbra::multilayer
