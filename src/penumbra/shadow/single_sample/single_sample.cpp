// Method `single-sample`: parker1998, "Single Sample Soft Shadows". One shadow ray per
// view sample toward the light's centre; every occluder is surrounded by an outer object
// whose opacity falls off from the real surface outward over a width b = D t / |l - o|
// that grows linearly with the distance t from the shading point, so the penumbra has
// zero width at contact and widens with distance (paper §2-3, appendix).
//
// How it runs on Embree: first the hard shadow ray (rtcOccluded1M streams): where it is
// blocked by opaque geometry the inner object is hit and s = 0. Elsewhere the outer
// objects are searched. Growing every triangle's bounding volume by b_max (the paper's
// way) makes a ray near a 70k-triangle mesh test thousands of triangles; instead the
// search walks a BVH in "cone space": the outer object of width b(t) around the ray is a
// cone from o to a disk of radius D at the light, and with the default `min` combination
// only occluders that could lower the current minimum are visited, so the cone shrinks as
// the search goes (nearest-first order). Node test: a bounding sphere (centre at t_c, d_c
// from the axis, radius r) holds no point with perp / t below (d_c - r) / (t_c + r).
#include <algorithm>
#include <atomic>
#include <vector>

#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/shadow/single_sample/outer_objects.h"
#include "penumbra/trace/bvh.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {
namespace {

using single_sample::falloff;
using single_sample::inverse_falloff;

enum class Combine { Min, Multiply, Add };

class SingleSampleSoftShadows final : public ShadowMethod {
 public:
  explicit SingleSampleSoftShadows(const ParamSet& p)
      : equal_area_(p.get_string("diameter") == "equal-area"), diameter_scale_(p.get_float("diameter_scale")) {
    const std::string& c = p.get_string("combine");
    combine_ = c == "min" ? Combine::Min : (c == "multiply" ? Combine::Multiply : Combine::Add);
  }

  void prepare(const ShadowContext& ctx) override {
    ScopedPhase phase(stats_, "build");
    stats_.prepare_count++;
    const Scene& scene = *ctx.scene;
    bvh_ = TriangleBvh(TriangleBvh::gather(scene, /*skip_analytic_spheres=*/true));
    spheres_.clear();
    for (size_t o = 0; o < scene.objects.size(); ++o)
      if (scene.objects[o].sphere) spheres_.push_back({*scene.objects[o].sphere, static_cast<uint32_t>(o),
                                                       scene.objects[o].material.opacity});
    const AreaLight& l = *ctx.light;
    // parker1998 uses the light's diameter D. A rect has none: its diagonal over-states
    // the penumbra, the diameter of the disk of equal area matches its mean width.
    diameter_ = (l.shape == LightShape::Rect && equal_area_) ? 2.0f * std::sqrt(l.area() / kPi) : l.diameter();
    diameter_ *= diameter_scale_;
    Bounds3f b = scene.bounds();
    scene_scale_ = 1.0f + std::max(max_component(vmax(b.hi, -b.hi)), max_component(vmax(b.lo, -b.lo)));
    stats_.memory_bytes = bvh_.memory_bytes();
  }

  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override {
    const Vec3f l = ctx.light->center;
    std::vector<float> hard(vs.size());
    {
      // The inner objects: the hard shadow ray through the real geometry.
      ScopedPhase phase(stats_, "hard rays");
      parallel_for(vs.size(), 1024, [&](size_t begin, size_t end) {
        constexpr size_t kBatch = 256;
        ShadowRay rays[kBatch];
        for (size_t b = begin; b < end; b += kBatch) {
          size_t n = std::min(kBatch, end - b);
          for (size_t i = 0; i < n; ++i) rays[i] = shadow_ray_to(vs.samples[b + i].p, vs.samples[b + i].ng, l);
          ctx.tracer->transmittance(std::span<const ShadowRay>(rays, n), std::span<float>(hard.data() + b, n));
        }
      });
      stats_.rays_traced += vs.size();
    }
    ScopedPhase phase(stats_, "outer objects");
    std::atomic<uint64_t> nodes{0}, blocked{0};
    parallel_for(vs.size(), 256, [&](size_t begin, size_t end) {
      std::vector<std::pair<float, uint32_t>> stack;
      stack.reserve(128);
      uint64_t local_nodes = 0, local_blocked = 0;
      for (size_t k = begin; k < end; ++k) {
        if (hard[k] == 0.0f) {
          out.visibility[k] = 0.0f;
          ++local_blocked;
          continue;
        }
        out.visibility[k] = transmission(vs.samples[k], l, stack, &local_nodes);
      }
      nodes += local_nodes;
      blocked += local_blocked;
      if (ctx.progress) ctx.progress->add(end - begin);
    });
    stats_.texels_visited += nodes.load();
    stats_.extra["bvh_nodes_per_ray"] = vs.size() ? static_cast<double>(nodes.load()) / vs.size() : 0.0;
    stats_.extra["hard_blocked_fraction"] = vs.size() ? static_cast<double>(blocked.load()) / vs.size() : 0.0;
  }

 private:
  struct AnalyticSphere {
    SphereShape shape;
    uint32_t object;
    float opacity;
  };

  void combine(float& s, float si) const {
    switch (combine_) {
      case Combine::Min: s = std::min(s, si); break;                           // paper's choice
      case Combine::Multiply: s *= si; break;                                  // s = s1 s2
      case Combine::Add: s = std::max(0.0f, s - (1.0f - si)); break;           // s = 1 - ((1-s1) + (1-s2))
    }
  }

  float transmission(const ViewSample& vsample, Vec3f l, std::vector<std::pair<float, uint32_t>>& stack,
                     uint64_t* nodes_visited) const {
    Vec3f o = offset_ray_origin(vsample.p, vsample.ng, l - vsample.p);
    Vec3f to_l = l - o;
    float light_dist = length(to_l);
    if (light_dist <= 0) return 1.0f;
    Vec3f v = to_l / light_dist;
    Vec3f e1, e2;
    coordinate_system(v, &e1, &e2);
    const float k = diameter_ / light_dist;  // b(t) = k t
    const float near = 1e-6f * light_dist, far = light_dist;
    float s = 1.0f;

    for (const AnalyticSphere& sp : spheres_) {
      float si = single_sample::sphere_transmission(o, v, light_dist, sp.shape.center, sp.shape.radius, diameter_);
      combine(s, 1.0f - sp.opacity * (1.0f - si));
      if (s <= 0.0f) return 0.0f;
    }
    if (bvh_.empty()) return s;

    // Nodes are visited while they could hold a point with perp / t < limit = k tau_max:
    // with `min`, tau_max shrinks to the tau that would lower s; otherwise only tau < 1
    // matters. (Recomputed only when s changes: inverse_falloff costs an asin and a sin.)
    float limit = k * (combine_ == Combine::Min ? inverse_falloff(s) : 1.0f);
    auto node_bound = [&](const BvhNode& n) {  // lower bound of perp / t inside the node
      Vec3f rel = n.sphere_center - o;
      float t_c = dot(rel, v);
      if (t_c + n.sphere_radius <= near || t_c - n.sphere_radius >= far) return kInfinity;
      float d_c = std::sqrt(std::max(0.0f, length_squared(rel) - t_c * t_c));
      return std::max(0.0f, d_c - n.sphere_radius) / std::max(near, t_c + n.sphere_radius);
    };
    const float plane_eps = 1e-4f * scene_scale_;
    const auto& nodes = bvh_.nodes();
    const auto& tris = bvh_.triangles();
    stack.clear();
    stack.push_back({node_bound(nodes[0]), 0});
    while (!stack.empty()) {
      auto [bound, index] = stack.back();
      stack.pop_back();
      if (bound >= limit) continue;
      ++*nodes_visited;
      const BvhNode& n = nodes[index];
      if (n.leaf()) {
        for (uint32_t i = n.first; i < n.first + n.count; ++i) {
          const BvhTriangle& t = tris[i];
          // The receiver's own triangle, and triangles in its plane (the rest of a
          // ground plane or a leaf), are not occluders of it.
          if (t.object == vsample.object) {
            if (t.prim == vsample.prim) continue;
            Vec3f tn = cross(t.v1 - t.v0, t.v2 - t.v0);
            float len = length(tn);
            if (len > 0 && std::abs(dot(tn / len, vsample.p - t.v0)) < plane_eps) continue;
          }
          float dist = single_sample::triangle_cone_distance(o, v, e1, e2, near, far, t.v0, t.v1, t.v2);
          float tau = dist / k;
          if (tau >= 1.0f) continue;
          combine(s, 1.0f - t.opacity * (1.0f - falloff(tau)));
          if (s <= 0.0f) return 0.0f;
          if (combine_ == Combine::Min) limit = k * inverse_falloff(s);
        }
        continue;
      }
      // Nearest child last on the stack, so it is searched first.
      float b0 = node_bound(nodes[n.first]), b1 = node_bound(nodes[n.first + 1]);
      if (b0 < b1) {
        if (b1 < limit) stack.push_back({b1, n.first + 1});
        if (b0 < limit) stack.push_back({b0, n.first});
      } else {
        if (b0 < limit) stack.push_back({b0, n.first});
        if (b1 < limit) stack.push_back({b1, n.first + 1});
      }
    }
    return s;
  }

  bool equal_area_;
  float diameter_scale_;
  Combine combine_ = Combine::Min;
  TriangleBvh bvh_;
  std::vector<AnalyticSphere> spheres_;
  float diameter_ = 1.0f;
  float scene_scale_ = 1.0f;
};

const MethodRegistration registration({
    "single-sample",
    "parker1998 single sample soft shadows: one ray to the light centre, occluders with soft outer objects",
    {{"combine", ParamType::String, "min",
      "how several occluders combine: min (the paper's choice, never too dark), multiply, add",
      {"min", "multiply", "add"}},
     {"diameter", ParamType::String, "equal-area",
      "light diameter D of a rect light: 'equal-area' (disk of the same area) or 'diagonal'",
      {"equal-area", "diagonal"}},
     {"diameter_scale", ParamType::Float, 1.0, "multiplies D (widens or narrows every penumbra)", {}, 0.0, 100.0}},
    [](const ParamSet& p) { return std::make_unique<SingleSampleSoftShadows>(p); },
});

}  // namespace
}  // namespace penumbra
