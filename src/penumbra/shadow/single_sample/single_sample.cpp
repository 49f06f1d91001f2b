// Method `single-sample`: parker1998, "Single Sample Soft Shadows". One shadow ray per
// view sample toward the light's centre; every occluder is surrounded by an outer object
// whose opacity falls off from the real surface outward over a width b = D t / |l - o|
// that grows linearly with the distance t from the shading point, so the penumbra has
// zero width at contact and widens with distance (paper §2-3, appendix).
//
// How it runs (docs/methods/single-sample.md): first the hard shadow ray on Embree
// (rtcOccluded1M streams): where opaque geometry blocks it the inner object is hit and
// s = 0. Elsewhere the outer objects are searched. Growing every triangle's bounding
// volume by b_max (the paper's way) makes a ray near a 70k-triangle mesh test thousands
// of triangles; instead the search walks a BVH in "cone space": the outer object of width
// b(t) around the ray is a cone from o to a disk of radius D at the light, and with the
// default `min` combination only occluders that could lower the current minimum are
// visited, so the cone shrinks as the search goes (nearest-first order, seeded with the
// previous view sample's nearest triangle). With `candidates=contour` (default) the BVH
// holds only the triangles along each opaque mesh's contour seen from the light centre,
// plus, per receiver on a mesh, the triangles around its own triangle (outer_objects.h).

#include <algorithm>
#include <array>
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

struct Plane {
  Vec3f n;  // unit normal
  float d;  // dot(n, x) = d on the plane
};

// The shadow ray's frame: origin, unit direction v, two unit vectors across it, and their
// component-wise absolute values (for box extents), with the search range in t.
struct RayFrame {
  Vec3f o, v, e1, e2, av, ae1, ae2;
  float near, far;
  float limit2_hint = kInfinity;
};

// Lower bound of (perp / t)^2 over the points of box b with near <= t <= far: the box's
// extent across the ray (its projection on e1 and e2) gives the smallest distance from the
// axis, over the largest t. No sqrt, one division.
inline float box_bound2(const Bounds3f& b, const RayFrame& r) {
  Vec3f c = (b.lo + b.hi) * 0.5f - r.o, h = (b.hi - b.lo) * 0.5f;
  float tc = dot(c, r.v), th = dot(h, r.av);
  float tmax = std::min(tc + th, r.far);
  if (tmax <= r.near || tc - th >= r.far) return kInfinity;
  float dx = std::max(0.0f, std::abs(dot(c, r.e1)) - dot(h, r.ae1));
  float dy = std::max(0.0f, std::abs(dot(c, r.e2)) - dot(h, r.ae2));
  float cyl = (dx * dx + dy * dy) / (tmax * tmax);
#ifdef PERSPECTIVE_BOUND
  if (tc - th > r.near && cyl < r.limit2_hint) {
    // All eight corners in front of the origin: the box projects (perspective, onto t = 1)
    // into the convex hull of its projected corners.
    float lo_x = kInfinity, hi_x = -kInfinity, lo_y = kInfinity, hi_y = -kInfinity;
    Vec3f base = b.lo - r.o, ext = b.hi - b.lo;
    for (int i = 0; i < 8; ++i) {
      Vec3f p = base + Vec3f((i & 1) ? ext.x : 0.0f, (i & 2) ? ext.y : 0.0f, (i & 4) ? ext.z : 0.0f);
      float inv = 1.0f / dot(p, r.v);
      float x = dot(p, r.e1) * inv, y = dot(p, r.e2) * inv;
      lo_x = std::min(lo_x, x); hi_x = std::max(hi_x, x);
      lo_y = std::min(lo_y, y); hi_y = std::max(hi_y, y);
    }
    float px = std::max({0.0f, lo_x, -hi_x}), py = std::max({0.0f, lo_y, -hi_y});
    return std::max(cyl, px * px + py * py);
  }
#endif
  return cyl;
}

class SingleSampleSoftShadows final : public ShadowMethod {
 public:
  explicit SingleSampleSoftShadows(const ParamSet& p)
      : equal_area_(p.get_string("diameter") == "equal-area"),
        diameter_scale_(p.get_float("diameter_scale")),
        contour_only_(p.get_string("candidates") == "contour"),
        leaf_size_(p.get_int("leaf_size")) {
    const std::string& c = p.get_string("combine");
    combine_ = c == "min" ? Combine::Min : (c == "multiply" ? Combine::Multiply : Combine::Add);
  }

  void prepare(const ShadowContext& ctx) override {
    ScopedPhase phase(stats_, "build");
    stats_.prepare_count++;
    const Scene& scene = *ctx.scene;
    scene_ = &scene;
    const AreaLight& l = *ctx.light;
    std::vector<BvhTriangle> tris = TriangleBvh::gather(scene, /*skip_analytic_spheres=*/true);
    const size_t all_count = tris.size();
    objects_.assign(scene.objects.size(), {});
    if (contour_only_) {
      // Only the triangles along each opaque mesh's contour seen from the light centre
      // (outer_objects.h: the nearest point in cone space of a surface the ray misses
      // lies on that contour). Semi-transparent objects keep every triangle: a ray may
      // cross them and still see the light.
      std::vector<BvhTriangle> kept;
      size_t first = 0;
      for (size_t o = 0; o < scene.objects.size(); ++o) {
        const SceneObject& obj = scene.objects[o];
        if (obj.sphere) continue;
        size_t count = obj.mesh.triangle_count();
        bool opaque = true;
        for (size_t t = first; t < first + count; ++t) opaque &= tris[t].opacity >= 1.0f;
        if (opaque) {
          ObjectData& od = objects_[o];
          od.topology = single_sample::build_topology(obj.mesh);
          od.ring = true;
          od.first = static_cast<uint32_t>(first);
          std::vector<uint8_t> keep = single_sample::contour_triangles(obj.mesh, od.topology, l.center);
          for (size_t t = 0; t < count; ++t)
            if (keep[t]) kept.push_back(tris[first + t]);
        } else {
          kept.insert(kept.end(), tris.begin() + first, tris.begin() + first + count);
        }
        first += count;
      }
      ring_tris_ = std::move(tris);  // every triangle, indexed by object first + prim
      tris = std::move(kept);
    } else {
      ring_tris_.clear();
    }
    stats_.extra["occluder_triangles"] = tris.size();
    stats_.extra["occluder_fraction"] = all_count ? static_cast<double>(tris.size()) / all_count : 0.0;
    // The search runs in a frame centred on the light with z toward the scene: every
    // shadow ray ends at its origin and runs roughly along -z, and the contour triangles
    // lie edge-on to the light, so boxes aligned with this frame are thin across the rays
    // (world-axis boxes of the same slivers are not).
    Vec3f toward = scene.bounds().center() - l.center;
    light_frame_ = length_squared(toward) > 0 ? Frame::from_z(toward) : Frame::from_z(-l.frame.n);
    light_pos_ = l.center;
    auto to_light = [&](BvhTriangle& t) {
      t.v0 = to_light_space(t.v0);
      t.v1 = to_light_space(t.v1);
      t.v2 = to_light_space(t.v2);
    };
    for (BvhTriangle& t : tris) to_light(t);
    for (BvhTriangle& t : ring_tris_) to_light(t);
    bvh_ = TriangleBvh(std::move(tris), leaf_size_);
    planes_.clear();
    for (const BvhTriangle& t : bvh_.triangles()) planes_.push_back(triangle_plane(t));
    // The leaves' triangles as blocks of four for the SIMD distance test.
    blocks_.clear();
    leaf_block_.assign(bvh_.nodes().size(), 0);
    for (size_t i = 0; i < bvh_.nodes().size(); ++i) {
      const BvhNode& n = bvh_.nodes()[i];
      if (!n.leaf()) continue;
      leaf_block_[i] = static_cast<uint32_t>(blocks_.size());
      for (uint32_t b = 0; b * 4 < n.count; ++b) {
        single_sample::TriangleBlock4 block;
        for (uint32_t lane = 0; lane < 4; ++lane) {
          const BvhTriangle& t = bvh_.triangles()[n.first + std::min(4 * b + lane, n.count - 1)];
          block.set(lane, t.v0, t.v1, t.v2);
        }
        blocks_.push_back(block);
      }
    }
    spheres_.clear();
    for (size_t o = 0; o < scene.objects.size(); ++o)
      if (scene.objects[o].sphere) spheres_.push_back({*scene.objects[o].sphere, static_cast<uint32_t>(o),
                                                       scene.objects[o].material.opacity});
    // parker1998 uses the light's diameter D. A rect has none: its diagonal over-states
    // the penumbra, the diameter of the disk of equal area matches its mean width.
    diameter_ = (l.shape == LightShape::Rect && equal_area_) ? 2.0f * std::sqrt(l.area() / kPi) : l.diameter();
    diameter_ *= diameter_scale_;
    Bounds3f b = scene.bounds();
    scene_scale_ = 1.0f + std::max(max_component(vmax(b.hi, -b.hi)), max_component(vmax(b.lo, -b.lo)));
    stats_.memory_bytes = bvh_.memory_bytes() + ring_tris_.capacity() * sizeof(BvhTriangle) +
                          blocks_.capacity() * sizeof(single_sample::TriangleBlock4) + 4 * leaf_block_.capacity();
    for (const ObjectData& od : objects_)
      stats_.memory_bytes += 4 * (od.topology.canon.size() + od.topology.vertex_first.size() +
                                  od.topology.vertex_tris.size()) + 12 * od.topology.edges.size();
  }

  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override {
    const Vec3f l = ctx.light->center;
    scene_ = ctx.scene;
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
    std::atomic<uint64_t> nodes{0}, tests{0}, blocked{0};
    parallel_for(vs.size(), 256, [&](size_t begin, size_t end) {
      Search search;
      search.stack.reserve(128);
      for (size_t k = begin; k < end; ++k) {
        if (hard[k] == 0.0f) {
          out.visibility[k] = 0.0f;
          ++search.blocked;
          continue;
        }
        out.visibility[k] = transmission(vs.samples[k], l, search);
      }
      nodes += search.nodes;
      tests += search.tests;
      blocked += search.blocked;
      if (ctx.progress) ctx.progress->add(end - begin);
    });
    stats_.texels_visited += nodes.load();
    const double n = std::max<size_t>(1, vs.size());
    stats_.extra["bvh_nodes_per_ray"] = nodes.load() / n;
    stats_.extra["triangle_tests_per_ray"] = tests.load() / n;
    stats_.extra["hard_blocked_fraction"] = blocked.load() / n;
  }

 private:
  struct AnalyticSphere {
    SphereShape shape;
    uint32_t object;
    float opacity;
  };
  struct ObjectData {
    single_sample::MeshTopology topology;
    uint32_t first = 0;  // the object's first triangle in ring_tris_
    bool ring = false;   // receivers on it test the triangles around their own
  };
  // Per-thread search state; `hint` carries the nearest triangle from one view sample to
  // the next (they come in scanline order).
  struct Search {
    std::vector<std::pair<float, uint32_t>> stack;
    uint32_t hint = ~0u;
    static constexpr int kMaxRing = 64;
    uint32_t ring[kMaxRing];
    int ring_count = 0;
    uint64_t nodes = 0, tests = 0, blocked = 0, clipped = 0;
  };

  void combine(float& s, float si) const {
    switch (combine_) {
      case Combine::Min: s = std::min(s, si); break;                           // paper's choice
      case Combine::Multiply: s *= si; break;                                  // s = s1 s2
      case Combine::Add: s = std::max(0.0f, s - (1.0f - si)); break;           // s = 1 - ((1-s1) + (1-s2))
    }
  }

  // The triangles sharing a welded vertex with the receiver's own triangle (without it),
  // when the receiver lies on a mesh whose other triangles are not all in the BVH.
  void gather_ring(const ViewSample& vsample, Search& search) const {
    search.ring_count = 0;
    if (vsample.object >= objects_.size() || !objects_[vsample.object].ring) return;
    const single_sample::MeshTopology& topo = objects_[vsample.object].topology;
    const TriangleMesh& m = scene_->objects[vsample.object].mesh;
    for (int c = 0; c < 3; ++c) {
      uint32_t v = topo.canon[m.indices[3 * vsample.prim + c]];
      for (uint32_t i = topo.vertex_first[v]; i < topo.vertex_first[v + 1]; ++i) {
        uint32_t t = topo.vertex_tris[i];
        if (t == vsample.prim) continue;
        bool dup = false;
        for (int j = 0; j < search.ring_count; ++j) dup |= search.ring[j] == t;
        if (!dup && search.ring_count < Search::kMaxRing) search.ring[search.ring_count++] = t;
      }
    }
  }

  float transmission(const ViewSample& vsample, Vec3f l, Search& search) const {
    Vec3f o = offset_ray_origin(vsample.p, vsample.ng, l - vsample.p);
    Vec3f to_l = l - o;
    float light_dist = length(to_l);
    if (light_dist <= 0) return 1.0f;
    const Vec3f v_world = to_l / light_dist;
    RayFrame r;  // in the light frame
    r.o = to_light_space(o);
    r.v = light_frame_.to_local(v_world);
    coordinate_system(r.v, &r.e1, &r.e2);
    const Vec3f p_local = to_light_space(vsample.p);
    auto vabs = [](Vec3f a) { return Vec3f(std::abs(a.x), std::abs(a.y), std::abs(a.z)); };
    r.av = vabs(r.v);
    r.ae1 = vabs(r.e1);
    r.ae2 = vabs(r.e2);
    r.near = 1e-6f * light_dist;
    r.far = light_dist;
    const float k = diameter_ / light_dist;  // b(t) = k t
    const float k2 = k * k;
    const bool is_min = combine_ == Combine::Min;
    float s = 1.0f;

    for (const AnalyticSphere& sp : spheres_) {
      float si = single_sample::sphere_transmission(o, v_world, light_dist, sp.shape.center, sp.shape.radius, diameter_);
      combine(s, 1.0f - sp.opacity * (1.0f - si));
      if (s <= 0.0f) return 0.0f;
    }
    if (bvh_.empty()) return s;

    // Nodes are visited while they could hold a point with (perp / t)^2 < limit2 =
    // (k tau_max)^2: with `min`, tau_max is the tau that would lower s (an opaque triangle
    // at distance d sets limit2 = d^2 directly, no trigonometry); otherwise only tau < 1
    // matters. With `min`, s is derived from limit2 at the end.
    float limit2 = is_min ? k2 * sqr(inverse_falloff(s)) : k2;
    const float plane_eps = 1e-4f * scene_scale_;
    const auto& nodes = bvh_.nodes();
    const auto& tris = bvh_.triangles();
    // Returns false when the ray is fully blocked (s = 0).
    // A triangle at squared cone distance d2 < limit2: lowers s unless it is the
    // receiver's own triangle or lies in its plane (the rest of a ground plane or a leaf
    // is no occluder of it). Returns false when the ray is fully blocked (s = 0).
    auto excluded = [&](const BvhTriangle& t, const Plane& plane) {
      return t.prim == vsample.prim ||
             std::abs(dot(plane.n, p_local) - plane.d) < plane_eps;
    };
    auto accept = [&](const BvhTriangle& t, float d2) {
      if (t.object == vsample.object && excluded(t, triangle_plane(t))) return true;
      if (is_min) {
        if (t.opacity >= 1.0f) {
          limit2 = d2;
          return d2 > 0.0f;
        }
        float si = 1.0f - t.opacity * (1.0f - falloff(std::sqrt(d2 / k2)));
        limit2 = std::min(limit2, k2 * sqr(inverse_falloff(si)));
        return true;
      }
      combine(s, 1.0f - t.opacity * (1.0f - falloff(std::sqrt(d2 / k2))));
      return s > 0.0f;
    };
    auto test_triangle = [&](const BvhTriangle& t) {
      ++search.tests;
      float d2 = single_sample::triangle_cone_distance2(r.o, r.v, r.e1, r.e2, r.near, r.far, t.v0, t.v1, t.v2);
      return d2 >= limit2 || accept(t, d2);
    };
    auto result = [&] { return is_min ? falloff(std::sqrt(limit2 / k2)) : s; };

    // The receiver's neighbourhood on its own mesh (self-shadowing of smooth surfaces
    // comes from the triangles around the receiver, which the contour set lacks).
    search.ring_count = 0;
    if (!ring_tris_.empty()) {
      gather_ring(vsample, search);
      const uint32_t first = objects_.size() > vsample.object ? objects_[vsample.object].first : 0;
      for (int j = 0; j < search.ring_count; ++j)
        if (!test_triangle(ring_tris_[first + search.ring[j]])) return 0.0f;
    }
    // Coherence: the previous view sample's nearest triangle is usually near this ray
    // too; testing it first gives a tight limit before the descent (min only: the other
    // rules must see each triangle once).
    uint32_t seeded = ~0u;
    if (is_min && search.hint < tris.size()) {
      seeded = search.hint;
      if (!test_triangle(tris[seeded])) return 0.0f;
    }
    auto in_ring = [&](const BvhTriangle& t) {
      if (t.object != vsample.object) return false;
      for (int j = 0; j < search.ring_count; ++j)
        if (search.ring[j] == t.prim) return true;
      return false;
    };
    search.stack.clear();
    search.stack.push_back({box_bound2(nodes[0].bounds, r), 0});
    while (!search.stack.empty()) {
      auto [bound, index] = search.stack.back();
      search.stack.pop_back();
      if (bound >= limit2) continue;
      ++search.nodes;
      const BvhNode& n = nodes[index];
      if (n.leaf()) {
        // Four triangles at a time; the rare ones that could lower s go one by one.
        const uint32_t first_block = leaf_block_[index];
        for (uint32_t b = 0; b * 4 < n.count; ++b) {
          float d2[4];
          const single_sample::TriangleBlock4& block = blocks_[first_block + b];
          int clip = single_sample::block_cone_distance2_unclipped(block, r.o, r.v, r.e1, r.e2, r.near, r.far, d2);
          search.tests += std::min<uint32_t>(4, n.count - 4 * b);
          for (uint32_t lane = 0; lane < 4 && 4 * b + lane < n.count; ++lane) {
            const uint32_t i = n.first + 4 * b + lane;
            if (clip & (1 << lane)) {
              // Straddles the ray's origin plane: clip it, unless it is the receiver's own
              // triangle or coplanar with it (the ground under a ground receiver).
              if (tris[i].object == vsample.object && excluded(tris[i], planes_[i])) continue;
              ++search.clipped;
              d2[lane] = single_sample::triangle_cone_distance2(r.o, r.v, r.e1, r.e2, r.near, r.far, block.vertex(lane, 0),
                                                                block.vertex(lane, 1), block.vertex(lane, 2));
            }
            if (d2[lane] >= limit2) continue;
            if (i == seeded) continue;
            if (!is_min && search.ring_count && in_ring(tris[i])) continue;  // counted once
            if (!accept(tris[i], d2[lane])) {
              search.hint = i;
              return 0.0f;
            }
            if (is_min) search.hint = i;
          }
        }
        continue;
      }
      // Nearest child last on the stack, so it is searched first.
      r.limit2_hint = limit2;
      float b0 = box_bound2(nodes[n.first].bounds, r), b1 = box_bound2(nodes[n.first + 1].bounds, r);
      if (b0 < b1) {
        if (b1 < limit2) search.stack.push_back({b1, n.first + 1});
        if (b0 < limit2) search.stack.push_back({b0, n.first});
      } else {
        if (b0 < limit2) search.stack.push_back({b0, n.first});
        if (b1 < limit2) search.stack.push_back({b1, n.first + 1});
      }
    }
    return result();
  }

  static float sqr(float x) { return x * x; }
  Vec3f to_light_space(Vec3f x) const { return light_frame_.to_local(x - light_pos_); }
  // The unit normal and offset of t's plane (zero for a triangle without area).
  static Plane triangle_plane(const BvhTriangle& t) {
    Vec3f n = cross(t.v1 - t.v0, t.v2 - t.v0);
    float len = length(n);
    if (!(len > 0)) return {Vec3f(0.0f), kInfinity};
    n = n / len;
    return {n, dot(n, t.v0)};
  }

  bool equal_area_;
  float diameter_scale_;
  bool contour_only_;
  int leaf_size_;
  Combine combine_ = Combine::Min;
  TriangleBvh bvh_;
  std::vector<single_sample::TriangleBlock4> blocks_;
  std::vector<uint32_t> leaf_block_;  // per BVH node: its first block (leaves)
  std::vector<Plane> planes_;         // per BVH triangle: triangle_plane
  std::vector<BvhTriangle> ring_tris_;
  std::vector<ObjectData> objects_;
  const Scene* scene_ = nullptr;
  Frame light_frame_;
  Vec3f light_pos_;
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
     {"diameter_scale", ParamType::Float, 1.0, "multiplies D (widens or narrows every penumbra)", {}, 0.0, 100.0},
     {"candidates", ParamType::String, "contour",
      "occluder triangles searched: 'contour' (those along each opaque mesh's contour seen from the light "
      "centre, the receiver's neighbours, boundary edges, transparent objects) or 'all' (every triangle: the "
      "exact minimum)",
      {"contour", "all"}},
     {"leaf_size", ParamType::Int, 4, "triangles per leaf of the cone-search BVH", {}, 1, 64}},
    [](const ParamSet& p) { return std::make_unique<SingleSampleSoftShadows>(p); },
});

}  // namespace
}  // namespace penumbra
