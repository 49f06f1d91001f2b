// Method `single-sample`: parker1998, "Single Sample Soft Shadows". One shadow ray per
// view sample toward the light's centre; every occluder is surrounded by an outer object
// whose opacity falls off from the real surface outward over a width b = D t / |l - o|
// that grows linearly with the distance t from the shading point, so the penumbra has
// zero width at contact and widens with distance (paper §2-3, appendix).
//
// How it runs (docs/methods/single-sample.md). Per batch of 256 view samples: the hard
// shadow ray on Embree (rtcOccluded1M): where opaque geometry blocks it, the inner object
// is hit and s = 0. Elsewhere the outer objects: instead of growing every triangle's
// bounding volume by b_max (the paper's way; a ray near a 70k-triangle mesh would test
// thousands), a search in "cone space": the outer object of width b(t) around the ray is
// a cone from o to a disk of radius D at the light, and with `min` (the default) only the
// occluders that could lower the current minimum are visited: a BVH descent, nearest
// child first, seeded with the previous view sample's nearest triangle, whose cone
// shrinks as it goes. What is searched:
//   - candidates=contour (default): per opaque mesh, only the triangles along its contour
//     seen from the light centre (plus boundary edges; semi-transparent objects whole), an
//     approximation of the contour seen from each receiver (outer_objects.h); `band`
//     widens it to exact; `neighbours` adds each receiver's own neighbouring triangles.
//   - candidates=all: every triangle (the all-triangle minimum).
// The BVH lives in a frame centred on the light (every ray ends there), its boxes tested
// against packets of 8 neighbouring rays at once with AVX2 (4 with SSE/NEON).

#include <algorithm>
#include <array>
#include <atomic>
#include <vector>

#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/shadow/single_sample/occluders.h"
#include "penumbra/shadow/single_sample/outer_objects.h"
#include "penumbra/shadow/single_sample/simd4.h"
#include "penumbra/trace/bvh.h"
#include "penumbra/trace/ray_tracer.h"

// Eight-lane packets with AVX2, chosen at run time, on x86 with GCC or Clang.
#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#define PENUMBRA_HAVE_AVX2_DISPATCH 1
#else
#define PENUMBRA_HAVE_AVX2_DISPATCH 0
#endif
#define PENUMBRA_INLINE inline __attribute__((always_inline))
// Eight-float vectors cross function boundaries only inside the AVX2 functions.
#pragma GCC diagnostic ignored "-Wpsabi"

namespace penumbra {
namespace {

using single_sample::falloff;
using single_sample::inverse_falloff;
using namespace single_sample;  // f4, i4 and their helpers (simd4.h)

enum class Combine { Min, Multiply, Add };

// The shadow ray's frame: origin, unit direction v, two unit vectors across it, and their
// component-wise absolute values (for box extents), with the search range in t.
struct RayFrame {
  Vec3f o, v, e1, e2, av, ae1, ae2;
  float near, far;
};

// Lower bound of (perp / t)^2 over the points of box b with near <= t <= far: the box's
// extent across the ray (its projection on e1 and e2) gives the smallest distance from the
// axis, over the largest t. No sqrt, one division.
inline float box_bound2(const Bounds3f& b, const RayFrame& r) {
  return shader::ss_box_bound2(b.lo, b.hi, r.o, r.v, r.e1, r.e2, r.av, r.ae1, r.ae2, r.near, r.far);
}

// The packet search: W rays side by side in vectors F (floats) and I (ints) of W lanes:
// f4/i4 everywhere (SSE, NEON), f8/i8 where the CPU has AVX2 (chosen at run time).
constexpr int kMaxLanes = 8;

template <typename F>
struct RayFramePacket {
  F ox, oy, oz, vx, vy, vz, e1x, e1y, e1z, e2x, e2y, e2z;
  F avx, avy, avz, ae1x, ae1y, ae1z, ae2x, ae2y, ae2z, near, far;
  PENUMBRA_INLINE void set(int lane, const RayFrame& r) {
    ox[lane] = r.o.x; oy[lane] = r.o.y; oz[lane] = r.o.z;
    vx[lane] = r.v.x; vy[lane] = r.v.y; vz[lane] = r.v.z;
    e1x[lane] = r.e1.x; e1y[lane] = r.e1.y; e1z[lane] = r.e1.z;
    e2x[lane] = r.e2.x; e2y[lane] = r.e2.y; e2z[lane] = r.e2.z;
    avx[lane] = r.av.x; avy[lane] = r.av.y; avz[lane] = r.av.z;
    ae1x[lane] = r.ae1.x; ae1y[lane] = r.ae1.y; ae1z[lane] = r.ae1.z;
    ae2x[lane] = r.ae2.x; ae2y[lane] = r.ae2.y; ae2z[lane] = r.ae2.z;
    near[lane] = r.near; far[lane] = r.far;
  }
};

// A box as centre and half extent (what the packet's box test reads).
struct CenterBox {
  Vec3f c;
  float pad0 = 0;
  Vec3f h;
  float pad1 = 0;
  CenterBox() = default;
  explicit CenterBox(const Bounds3f& b) : c((b.lo + b.hi) * 0.5f), h((b.hi - b.lo) * 0.5f) {}
};

// box_bound2 of one box for the packet's rays.
template <typename F>
PENUMBRA_INLINE F box_bound2(const CenterBox& b, const RayFramePacket<F>& r) {
  const Vec3f c = b.c, h = b.h;
  F cx = c.x - r.ox, cy = c.y - r.oy, cz = c.z - r.oz;
  F tc = cx * r.vx + cy * r.vy + cz * r.vz, th = h.x * r.avx + h.y * r.avy + h.z * r.avz;
  F tmax = vmin_v(tc + th, r.far);
  F zero = splat_v<F>(0.0f);
  F dx = vmax_v(zero, vabs_v(cx * r.e1x + cy * r.e1y + cz * r.e1z) - (h.x * r.ae1x + h.y * r.ae1y + h.z * r.ae1z));
  F dy = vmax_v(zero, vabs_v(cx * r.e2x + cy * r.e2y + cz * r.e2z) - (h.x * r.ae2x + h.y * r.ae2y + h.z * r.ae2z));
  F bound = (dx * dx + dy * dy) / (tmax * tmax);
  return ((tmax <= r.near) | (tc - th >= r.far)) ? splat_v<F>(kInfinity) : bound;
}

// triangle_cone_distance2 of one triangle for the packet's rays; lanes whose ray sees a
// vertex outside [near, far] are flagged in *clip (their value is +inf: to be clipped).
template <typename F, typename I>
PENUMBRA_INLINE F triangle_distance2(const BvhTriangle& tri, const RayFramePacket<F>& r, int* clip) {
  const Vec3f* v[3] = {&tri.v0, &tri.v1, &tri.v2};
  const F one = splat_v<F>(1.0f), zero = splat_v<F>(0.0f);
  F qx[3], qy[3];
  I in_range = I{} - 1;
  for (int k = 0; k < 3; ++k) {
    F rx = v[k]->x - r.ox, ry = v[k]->y - r.oy, rz = v[k]->z - r.oz;
    F t = rx * r.vx + ry * r.vy + rz * r.vz;
    F x = rx * r.e1x + ry * r.e1y + rz * r.e1z;
    F y = rx * r.e2x + ry * r.e2y + rz * r.e2z;
    in_range &= (t >= r.near) & (t <= r.far);
    F inv = one / (in_range ? t : one);
    qx[k] = x * inv;
    qy[k] = y * inv;
  }
  F best = splat_v<F>(kInfinity);
  I pos = I{}, neg = I{};
  for (int k = 0; k < 3; ++k) {
    int k1 = k == 2 ? 0 : k + 1;
    F ex = qx[k1] - qx[k], ey = qy[k1] - qy[k];
    F side = ey * qx[k] - ex * qy[k];
    pos |= side > zero;
    neg |= side < zero;
    F len2 = ex * ex + ey * ey;
    F u = -(qx[k] * ex + qy[k] * ey) / (len2 > zero ? len2 : one);
    u = vmin_v(vmax_v(u, zero), one);
    F cx = qx[k] + u * ex, cy = qy[k] + u * ey;
    best = vmin_v(best, cx * cx + cy * cy);
  }
  *clip = mask_v(~in_range);
  best = (pos ^ neg) ? zero : best;
  return in_range ? best : splat_v<F>(kInfinity);
}

class SingleSampleSoftShadows final : public ShadowMethod {
 public:
  explicit SingleSampleSoftShadows(const ParamSet& p)
      : settings_(occluder_settings(p)), packets_(p.get_int("packet") > 1) {
#if PENUMBRA_HAVE_AVX2_DISPATCH
    __builtin_cpu_init();
    if (p.get_int("packet") == 8 && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) lanes_ = 8;
#endif
    const std::string& c = p.get_string("combine");
    combine_ = c == "min" ? Combine::Min : (c == "multiply" ? Combine::Multiply : Combine::Add);
  }

  void prepare(const ShadowContext& ctx) override {
    ScopedPhase phase(stats_, "build");
    stats_.prepare_count++;
    const Scene& scene = *ctx.scene;
    scene_ = &scene;
    // The occluders (occluders.h, shared with the GPU version): D, the light frame, the
    // candidate triangles in their BVH with their planes, the spheres, the meshes' topology.
    Occluders occ = build_occluders(scene, *ctx.light, settings_);
    diameter_ = occ.diameter;
    light_frame_ = occ.light_frame;
    light_pos_ = occ.light_pos;
    plane_eps_ = occ.plane_eps;
    objects_ = std::move(occ.objects);
    spheres_ = std::move(occ.spheres);
    planes_ = std::move(occ.planes);
    bvh_ = std::move(occ.bvh);
    const size_t all_count = occ.all_triangles;
    stats_.extra["occluder_triangles"] = bvh_.triangles().size();
    stats_.extra["occluder_fraction"] = all_count ? static_cast<double>(bvh_.triangles().size()) / all_count : 0.0;
    node_boxes_.clear();
    for (const BvhNode& n : bvh_.nodes()) node_boxes_.emplace_back(n.bounds);
    // The leaves' triangles as blocks of four for the SIMD distance test of search_single
    // (packets test one triangle against all their rays instead).
    blocks_.clear();
    leaf_block_.assign(bvh_.nodes().size(), 0);
    const bool single_rays = !(packets_ && combine_ == Combine::Min);
    for (size_t i = 0; i < bvh_.nodes().size() && single_rays; ++i) {
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
    stats_.memory_bytes = bvh_.memory_bytes() + blocks_.capacity() * sizeof(single_sample::TriangleBlock4) +
                          4 * leaf_block_.capacity() + planes_.capacity() * sizeof(Plane);
    for (const ObjectData& od : objects_)
      stats_.memory_bytes +=
          4 * (od.topology.canon.size() + od.topology.corners.size() + od.topology.vertex_first.size() +
               od.topology.vertex_tris.size()) + sizeof(Plane) * (od.planes.size() + od.fan_planes.size());
  }

  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override {
    const Vec3f l = ctx.light->center;
    scene_ = ctx.scene;
    // One pass: per batch of 256 view samples, the inner objects (the hard shadow ray
    // through the real geometry, Embree rtcOccluded1M) and then, for the rays they do not
    // block, the outer objects (the cone search), reusing the rays.
    ScopedPhase phase(stats_, "shadow rays");
    std::atomic<uint64_t> nodes{0}, tests{0}, blocked{0}, searched{0}, clipped{0}, ring{0};
    std::atomic<int64_t> hard_ns{0};
    const bool packets = packets_ && combine_ == Combine::Min && !bvh_.empty();
    parallel_for(vs.size(), 256, [&](size_t begin, size_t end) {
      Search search;
      // View samples come in scanline order: unblocked neighbours make a packet.
      Lane lanes[kMaxLanes];
      size_t index[kMaxLanes];
      int count = 0;
      auto flush = [&] {
        search_packet_any(lanes, count, search);
        for (int j = 0; j < count; ++j) {
          if (lanes[j].limit2 > 0.0f) test_ring(lanes[j], search);
          out.visibility[index[j]] = lanes[j].result();
          if (lanes[j].best != ~0u) search.hints[j] = lanes[j].best;
        }
        count = 0;
      };
      constexpr size_t kBatch = 256;
      ShadowRay rays[kBatch];
      float hard[kBatch];
      int64_t local_hard_ns = 0;
      for (size_t b = begin; b < end; b += kBatch) {
        const size_t n_batch = std::min(kBatch, end - b);
        Timer timer;
        for (size_t i = 0; i < n_batch; ++i) rays[i] = shadow_ray_to(vs.samples[b + i].p, vs.samples[b + i].ng, l);
        ctx.tracer->transmittance(std::span<const ShadowRay>(rays, n_batch), std::span<float>(hard, n_batch));
        local_hard_ns += static_cast<int64_t>(timer.elapsed_ms() * 1e6);
        for (size_t i = 0; i < n_batch; ++i) {
          const size_t k = b + i;
          if (hard[i] == 0.0f) {
            out.visibility[k] = 0.0f;  // the inner object blocks the ray
            ++search.blocked;
            continue;
          }
          Lane& lane = lanes[count];
          if (!begin_lane(vs.samples[k], rays[i], l, search, packets ? ~0u : search.hints[0], !packets, lane)) {
            out.visibility[k] = lane.result();
            continue;
          }
          ++search.searched;
          if (!packets) {
            search_single(lane, search);
            out.visibility[k] = lane.result();
            if (lane.best != ~0u) search.hints[0] = lane.best;
            continue;
          }
          index[count++] = k;
          if (count == lanes_) flush();
        }
      }
      if (count) flush();
      nodes += search.nodes;
      tests += search.tests;
      blocked += search.blocked;
      searched += search.searched;
      clipped += search.clipped;
      ring += search.ringtests;
      hard_ns += local_hard_ns;
      if (ctx.progress) ctx.progress->add(end - begin);
    });
    stats_.rays_traced += vs.size();
    stats_.texels_visited += nodes.load();
    // The hard rays' share of the pass, in thread time summed over threads.
    stats_.extra["hard_rays_thread_ms"] = hard_ns.load() * 1e-6;
    const double n = std::max<size_t>(1, vs.size());
    stats_.extra["bvh_nodes_per_ray"] = nodes.load() / n;  // a packet's visit counts once
    stats_.extra["triangle_tests_per_ray"] = tests.load() / n;
    stats_.extra["hard_blocked_fraction"] = blocked.load() / n;
    stats_.extra["searched_fraction"] = searched.load() / n;
    stats_.extra["clipped_tests_per_ray"] = clipped.load() / n;
    stats_.extra["neighbour_tests_per_ray"] = ring.load() / n;
    stats_.extra["packet_lanes"] = packets ? lanes_ : 1;
  }

 private:
  // Per-thread search state. `hints` carry the nearest triangle from one view sample (or
  // packet lane) to the next.
  struct Search {
    struct alignas(32) StackChunk {
      char bytes[32];
    };
    std::vector<StackChunk> packet_stack;  // entries of search_packet's type
    std::vector<std::pair<float, uint32_t>> stack;
    uint32_t hints[kMaxLanes];
    Search() { std::fill(hints, hints + kMaxLanes, ~0u); }
    static constexpr int kMaxRing = 64;
    uint32_t ring[kMaxRing];
    int ring_count = 0;
    uint64_t nodes = 0, tests = 0, blocked = 0, searched = 0, clipped = 0, ringtests = 0;
  };
  // One shadow ray's search. With `min`, limit2 = (k tau)^2 holds the current s (an opaque
  // triangle at squared distance d2 < limit2 sets limit2 = d2; no trigonometry); with the
  // other rules s accumulates and limit2 = k^2 (only tau < 1 matters).
  struct Lane {
    const ViewSample* sample = nullptr;
    RayFrame r;       // in the light frame
    Vec3f p_local;    // the receiver, in the light frame
    float k2 = 1.0f;  // (D / |l - o|)^2: tau^2 = d2 / k2
    float limit2 = 0.0f;
    float s = 1.0f;
    bool is_min = true;
    uint32_t best = ~0u;  // the BVH triangle that set limit2
    float result() const { return is_min ? falloff(std::sqrt(limit2 / k2)) : s; }
  };

  void combine(float& s, float si) const {
    switch (combine_) {
      case Combine::Min: s = std::min(s, si); break;                           // paper's choice
      case Combine::Multiply: s *= si; break;                                  // s = s1 s2
      case Combine::Add: s = std::max(0.0f, s - (1.0f - si)); break;           // s = 1 - ((1-s1) + (1-s2))
    }
  }

  // The triangles sharing a welded vertex with the receiver's own triangle (without it)
  // that could lower the lane's s, when the receiver lies on a mesh whose other triangles
  // are not all in the BVH. A neighbour's plane with the ray's origin on its positive side
  // that the ray leaves (leaves_plane) cannot: that prunes most neighbours of a receiver
  // that faces the light, from the precomputed planes alone.
  void gather_ring(const Lane& lane, Search& search) const {
    search.ring_count = 0;
    const ViewSample& vsample = *lane.sample;
    const ObjectData& od = objects_[vsample.object];
    const single_sample::MeshTopology& topo = od.topology;
    for (int c = 0; c < 3; ++c) {
      uint32_t v = topo.corners[3 * vsample.prim + c];
      for (uint32_t i = topo.vertex_first[v]; i < topo.vertex_first[v + 1]; ++i) {
        uint32_t t = topo.vertex_tris[i];
        if (t == vsample.prim || leaves_plane(lane.r, od.fan_planes[i], lane.limit2)) continue;
        bool dup = false;
        for (int j = 0; j < search.ring_count; ++j) dup |= search.ring[j] == t;
        if (!dup && search.ring_count < Search::kMaxRing) search.ring[search.ring_count++] = t;
      }
    }
  }

  // The receiver's own triangle, and triangles in its plane (the rest of a ground plane or
  // a leaf), are no occluders of it.
  bool excluded(const Lane& lane, const BvhTriangle& t, const Plane& plane) const {
    return t.object == lane.sample->object &&
           (t.prim == lane.sample->prim || std::abs(dot(plane.n, lane.p_local) - plane.d) < plane_eps_);
  }

  // True when no point of the plane is nearer than limit2 to the ray in cone space: the
  // ray's origin lies on one side and the ray leaves the plane (n . v >= 0, n toward the
  // origin's side), so every point of the plane is seen at least asin(n . v) off the ray:
  // perp / t >= tan(asin(n . v)) >= n . v.
  static bool leaves_plane(const RayFrame& r, const Plane& plane, float limit2) {
    return shader::ss_leaves_plane(r.o, r.v, plane, limit2);
  }

  // A triangle at squared cone distance d2 < lane.limit2 (BVH index `index`, ~0u for one
  // outside the BVH). Returns false when the ray is fully blocked (s = 0).
  bool accept(Lane& lane, const BvhTriangle& t, const Plane& plane, uint32_t index, float d2) const {
    if (excluded(lane, t, plane)) return true;
    if (lane.is_min) {
      if (t.opacity >= 1.0f) {
        lane.limit2 = d2;
        lane.best = index;
        return d2 > 0.0f;
      }
      float si = shader::ss_occluder_transmission(t.opacity, d2, lane.k2);
      lane.limit2 = std::min(lane.limit2, lane.k2 * sqr(inverse_falloff(si)));
      return true;
    }
    combine(lane.s, shader::ss_occluder_transmission(t.opacity, d2, lane.k2));
    return lane.s > 0.0f;
  }

  // Tests one triangle against one ray (scalar path). Returns false when s = 0.
  bool test_one(Lane& lane, const BvhTriangle& t, const Plane& plane, uint32_t index, Search& search) const {
    ++search.tests;
    const RayFrame& r = lane.r;
    float d2 = single_sample::triangle_cone_distance2(r.o, r.v, r.e1, r.e2, r.near, r.far, t.v0, t.v1, t.v2);
    return d2 >= lane.limit2 || accept(lane, t, plane, index, d2);
  }

  // Sets up a ray: its frames, the analytic spheres, the triangles around the receiver and
  // the hint. Returns false when nothing is left to search (lane.result() is final).
  // The receiver's neighbourhood on its own mesh: self-shadowing of smooth surfaces comes
  // from the triangles around the receiver, which the contour set lacks. Returns false
  // when s = 0. (Packets test it after their descent, when limit2 prunes more.)
  bool test_ring(Lane& lane, Search& search) const {
    const ViewSample& vsample = *lane.sample;
    search.ring_count = 0;
    if (vsample.object >= objects_.size() || !objects_[vsample.object].ring) return true;
    gather_ring(lane, search);
    if (search.ring_count == 0) return true;
    const SceneObject& obj = scene_->objects[vsample.object];
    const ObjectData& od = objects_[vsample.object];
    // A neighbour wholly below the receiver's own plane, with the ray's origin above that
    // plane and leaving it steeply (leaves_plane of the receiver's triangle), is seen at
    // least asin(n . v) off the ray too: the convex neighbours that their own planes
    // cannot rule out.
    const Plane& own = od.planes[vsample.prim];
    const bool own_leaves = leaves_plane(lane.r, own, lane.limit2) && dot(own.n, lane.r.o) > own.d;
    for (int j = 0; j < search.ring_count; ++j) {
      const uint32_t prim = search.ring[j];
      BvhTriangle t{to_light_space(obj.mesh.vertex(prim, 0)), to_light_space(obj.mesh.vertex(prim, 1)),
                    to_light_space(obj.mesh.vertex(prim, 2)), vsample.object, prim, 1.0f};  // opaque object
      if (own_leaves && dot(own.n, t.v0) <= own.d && dot(own.n, t.v1) <= own.d && dot(own.n, t.v2) <= own.d)
        continue;
      ++search.ringtests;
      if (!test_one(lane, t, od.planes[prim], ~0u, search)) return false;
    }
    return true;
  }

  // `ray` is the hard shadow ray of the view sample toward the light centre l (its origin
  // offset off the surface, unit direction).
  bool begin_lane(const ViewSample& vsample, const ShadowRay& ray, Vec3f l, Search& search, uint32_t hint,
                  bool ring_now, Lane& lane) const {
    lane.sample = &vsample;
    lane.is_min = combine_ == Combine::Min;
    lane.s = 1.0f;
    lane.best = ~0u;
    lane.k2 = 1.0f;
    const Vec3f o = ray.org;
    const float light_dist = length(l - o);
    if (!(light_dist > 0)) {
      lane.limit2 = lane.k2;  // s = 1
      return false;
    }
    const Vec3f v_world = ray.dir;
    RayFrame& r = lane.r;
    r.o = to_light_space(o);
    r.v = light_frame_.to_local(v_world);
    coordinate_system(r.v, &r.e1, &r.e2);
    auto vabs = [](Vec3f a) { return Vec3f(std::abs(a.x), std::abs(a.y), std::abs(a.z)); };
    r.av = vabs(r.v);
    r.ae1 = vabs(r.e1);
    r.ae2 = vabs(r.e2);
    r.near = 1e-6f * light_dist;
    r.far = light_dist;
    lane.p_local = to_light_space(vsample.p);
    const float k = diameter_ / light_dist;  // b(t) = k t
    lane.k2 = k * k;
    if (!(lane.k2 > 0)) {  // D = 0: a point light, the hard shadow alone
      lane.is_min = false;
      return false;
    }
    for (const AnalyticSphere& sp : spheres_) {
      float si = single_sample::sphere_transmission(o, v_world, light_dist, sp.shape.center, sp.shape.radius, diameter_);
      combine(lane.s, 1.0f - sp.opacity * (1.0f - si));
    }
    lane.limit2 = lane.is_min && lane.s < 1.0f ? lane.k2 * sqr(inverse_falloff(lane.s)) : lane.k2;
    if (lane.s <= 0.0f || bvh_.empty()) return false;
    search.ring_count = 0;
    if (ring_now && !test_ring(lane, search)) return false;
    // Coherence: the previous view sample's nearest triangle is usually near this ray
    // too; testing it first gives a tight limit before the descent (min only: the other
    // rules must see each triangle once). Testing it again in its leaf changes nothing.
    // (Packets test their lanes' hints together in search_packet.)
    if (lane.is_min && hint < bvh_.triangles().size())
      if (!test_one(lane, bvh_.triangles()[hint], planes_[hint], hint, search)) return false;
    return true;
  }

  // The descent for one ray, any combination rule.
  void search_single(Lane& lane, Search& search) const {
    const auto& nodes = bvh_.nodes();
    const auto& tris = bvh_.triangles();
    const RayFrame& r = lane.r;
    const uint32_t receiver = lane.sample->object;
    auto in_ring = [&](const BvhTriangle& t) {
      if (t.object != receiver) return false;
      for (int j = 0; j < search.ring_count; ++j)
        if (search.ring[j] == t.prim) return true;
      return false;
    };
    auto& stack = search.stack;
    stack.clear();
    stack.push_back({box_bound2(nodes[0].bounds, r), 0});
    while (!stack.empty()) {
      auto [bound, index] = stack.back();
      stack.pop_back();
      if (bound >= lane.limit2) continue;
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
          for (uint32_t j = 0; j < 4 && 4 * b + j < n.count; ++j) {
            const uint32_t i = n.first + 4 * b + j;
            if (clip & (1 << j)) {
              // Straddles the ray's origin plane: clip it, unless it is the receiver's own
              // triangle or coplanar with it (the ground under a ground receiver), or the
              // ray leaves its plane too steeply.
              if (excluded(lane, tris[i], planes_[i]) || leaves_plane(r, planes_[i], lane.limit2)) continue;
              d2[j] = single_sample::triangle_cone_distance2(r.o, r.v, r.e1, r.e2, r.near, r.far, block.vertex(j, 0),
                                                             block.vertex(j, 1), block.vertex(j, 2));
            }
            if (d2[j] >= lane.limit2) continue;
            if (!lane.is_min && search.ring_count && in_ring(tris[i])) continue;  // counted once
            if (!accept(lane, tris[i], planes_[i], i, d2[j])) return;
          }
        }
        continue;
      }
      // Nearest child last on the stack, so it is searched first.
      float b0 = box_bound2(nodes[n.first].bounds, r), b1 = box_bound2(nodes[n.first + 1].bounds, r);
      if (b0 < b1) {
        if (b1 < lane.limit2) stack.push_back({b1, n.first + 1});
        if (b0 < lane.limit2) stack.push_back({b0, n.first});
      } else {
        if (b0 < lane.limit2) stack.push_back({b0, n.first});
        if (b1 < lane.limit2) stack.push_back({b1, n.first + 1});
      }
    }
  }

  // The descent for up to W rays at once (`min` only): a node is opened when it could lower
  // any lane's s; W rays are tested against one box or one triangle per step.
  template <typename F, typename I>
  PENUMBRA_INLINE void search_packet(Lane* lanes, int count, Search& search) const {
    constexpr int W = sizeof(F) / sizeof(float);
    const auto& nodes = bvh_.nodes();
    const auto& tris = bvh_.triangles();
    RayFramePacket<F> r;
    F limit2 = splat_v<F>(0.0f);  // unused lanes: nothing is below 0
    I object, prim;               // the receivers, for excluded() on four or eight lanes
    F px, py, pz;
    for (int j = 0; j < W; ++j) {
      const Lane& lane = lanes[j < count ? j : 0];
      r.set(j, lane.r);
      if (j < count) limit2[j] = lane.limit2;
      object[j] = static_cast<int>(lane.sample->object);
      prim[j] = static_cast<int>(lane.sample->prim);
      px[j] = lane.p_local.x;
      py[j] = lane.p_local.y;
      pz[j] = lane.p_local.z;
    }
    const float plane_eps = plane_eps_;
    // One triangle against the four rays; the lanes it could lower go one by one.
    auto test = [&](uint32_t i) {
      const Plane& pl = planes_[i];
      const BvhTriangle& t = tris[i];
      // Lanes where the triangle is the receiver's own or lies in its plane (the ground
      // under a ground receiver) are excluded before any distance is computed.
      int active = mask_v(limit2 > 0.0f);
      I same = object == static_cast<int>(t.object);
      if (mask_v(same)) {
        F height = pl.n.x * px + pl.n.y * py + pl.n.z * pz - pl.d;
        active &= ~mask_v(same & ((prim == static_cast<int>(t.prim)) | (vabs_v(height) < plane_eps)));
        if (!active) return;
      }
      int clip;
      F d2 = triangle_distance2<F, I>(t, r, &clip);
      search.tests += count;
      clip &= active;
      if (clip) {
        // Lanes that would clip: drop those where the ray leaves the triangle's plane too
        // steeply (leaves_plane), on all lanes at once.
        F side = pl.n.x * r.ox + pl.n.y * r.oy + pl.n.z * r.oz - pl.d;
        F nv = pl.n.x * r.vx + pl.n.y * r.vy + pl.n.z * r.vz;
        nv = side < 0.0f ? -nv : nv;
        clip &= ~mask_v((nv >= 0.0f) & (nv * nv >= limit2));
      }
      int hit = (mask_v(d2 < limit2) & active) | clip;
      if (!hit) return;
      for (int j = 0; j < count; ++j) {
        if (!(hit & (1 << j))) continue;
        Lane& lane = lanes[j];
        float dj = d2[j];
        if (clip & (1 << j)) {
          if (!(limit2[j] > 0.0f)) continue;
          const RayFrame& rj = lane.r;
          ++search.clipped;
          dj = single_sample::triangle_cone_distance2(rj.o, rj.v, rj.e1, rj.e2, rj.near, rj.far, tris[i].v0,
                                                      tris[i].v1, tris[i].v2);
          if (dj >= limit2[j]) continue;
        }
        lane.limit2 = limit2[j];
        accept(lane, tris[i], planes_[i], i, dj);
        limit2[j] = lane.limit2;
      }
    };
    // The previous packet's nearest triangles first (coherence; see begin_lane).
    for (int j = 0; j < W; ++j) {
      uint32_t h = search.hints[j];
      bool seen = h >= tris.size();
      for (int q = 0; q < j; ++q) seen |= search.hints[q] == h;
      if (!seen) test(h);
    }
    struct Entry {
      F bound;
      uint32_t node;
    };
    // The stack lives in the Search (no allocation per packet), typed here.
    static_assert(alignof(Entry) <= alignof(Search::StackChunk) && sizeof(Entry) % sizeof(Search::StackChunk) == 0);
    constexpr size_t kChunks = sizeof(Entry) / sizeof(Search::StackChunk);
    auto& storage = search.packet_stack;
    if (storage.size() < 64 * kChunks) storage.resize(64 * kChunks);
    Entry* stack_base = reinterpret_cast<Entry*>(storage.data());
    size_t top = 0;
    auto push = [&](F bound, uint32_t node) {
      if ((top + 1) * kChunks > storage.size()) {
        storage.resize(2 * storage.size());
        stack_base = reinterpret_cast<Entry*>(storage.data());
      }
      stack_base[top++] = Entry{bound, node};
    };
    push(box_bound2(node_boxes_[0], r), 0);
    while (top > 0) {
      Entry e = stack_base[--top];
      if (!mask_v(e.bound < limit2)) continue;
      ++search.nodes;
      const BvhNode& n = nodes[e.node];
      if (n.leaf()) {
        for (uint32_t i = n.first; i < n.first + n.count; ++i) test(i);
        continue;
      }
      F b0 = box_bound2(node_boxes_[n.first], r), b1 = box_bound2(node_boxes_[n.first + 1], r);
      bool open0 = mask_v(b0 < limit2), open1 = mask_v(b1 < limit2);
      // The child nearer to some lane last on the stack, so it is searched first.
      if (hmin_v(b0) < hmin_v(b1)) {
        if (open1) push(b1, n.first + 1);
        if (open0) push(b0, n.first);
      } else {
        if (open0) push(b0, n.first);
        if (open1) push(b1, n.first + 1);
      }
    }
    for (int j = 0; j < count; ++j) lanes[j].limit2 = limit2[j];
  }

  // The packet search compiled for 4 lanes (the baseline ISA) and, on x86, for 8 lanes
  // with AVX2 (every helper inlined into the target-specific function).
  __attribute__((flatten)) void search_packet4(Lane* lanes, int count, Search& search) const {
    search_packet<f4, i4>(lanes, count, search);
  }
#if PENUMBRA_HAVE_AVX2_DISPATCH
  __attribute__((target("avx2,fma"), flatten)) void search_packet8(Lane* lanes, int count, Search& search) const {
    search_packet<f8, i8>(lanes, count, search);
  }
#endif
  void search_packet_any(Lane* lanes, int count, Search& search) const {
#if PENUMBRA_HAVE_AVX2_DISPATCH
    if (lanes_ == 8) return search_packet8(lanes, count, search);
#endif
    search_packet4(lanes, count, search);
  }

  static float sqr(float x) { return x * x; }


  Vec3f to_light_space(Vec3f x) const { return light_frame_.to_local(x - light_pos_); }
  OccluderSettings settings_;
  bool packets_;
  int lanes_ = 4;  // rays per packet: 8 with AVX2
  float plane_eps_ = 1e-4f;
  Combine combine_ = Combine::Min;
  TriangleBvh bvh_;
  std::vector<single_sample::TriangleBlock4> blocks_;
  std::vector<uint32_t> leaf_block_;  // per BVH node: its first block (leaves)
  std::vector<Plane> planes_;         // per BVH triangle: triangle_plane
  std::vector<CenterBox> node_boxes_;  // per BVH node: its box as centre and half extent
  std::vector<ObjectData> objects_;
  const Scene* scene_ = nullptr;
  Frame light_frame_;
  Vec3f light_pos_;
  std::vector<AnalyticSphere> spheres_;
  float diameter_ = 1.0f;
};

// One light's instance, all of it per triangle of the scene (at most every one is an
// occluder; a mesh has at most three vertices a triangle): the occluder triangles (grown by
// doubling, then kept by the BVH), the BVH's build, their planes, the nodes' boxes and first
// blocks; the blocks of four for single-ray search (packet=1 or a rule other than min); with
// candidates=contour the meshes' topology and contour build, and with neighbours each
// triangle's plane four times (its own, and once in each corner's vertex fan) and the
// welded positions.
MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q) {
  const uint64_t triangles = q.triangles, vertices = 3 * q.triangles;
  const int leaf = p.get_int("leaf_size");
  const uint64_t nodes = TriangleBvh::node_bound(triangles, leaf);
  uint64_t bytes = 2 * triangles * sizeof(BvhTriangle) + TriangleBvh::build_bytes(triangles, leaf) +
                   2 * triangles * sizeof(Plane) + nodes * (2 * sizeof(CenterBox) + sizeof(uint32_t));
  if (!(p.get_int("packet") > 1 && p.get_string("combine") == "min"))
    bytes += 2 * (triangles / 4 + nodes) * sizeof(single_sample::TriangleBlock4);
  if (p.get_string("candidates") != "all") {
    bytes += single_sample::contour_bytes(triangles, vertices);
    if (p.get_bool("neighbours")) bytes += 4 * triangles * sizeof(Plane) + vertices * sizeof(Vec3f);
  }
  MemoryTally tally;
  tally.add(bytes, kTrianglesSetting);
  return tally.estimate();
}

const MethodRegistration registration({
    "single-sample",
    "parker1998 single sample soft shadows: one ray to the light centre, occluders with soft outer objects",
    {{"combine", ParamType::String, "min",
      "how several occluders combine: min (the paper's choice, never too dark), multiply, add",
      {"min", "multiply", "add"}},
     {"diameter", ParamType::String, "equal-area",
      "light diameter D of a rect or ellipsoid light: 'equal-area' (disk of the same area as the rect or the "
      "ellipsoid's central ellipse) or 'diagonal' (the rect's diagonal, the ellipsoid's longest axis)",
      {"equal-area", "diagonal"}},
     {"diameter_scale", ParamType::Float, 1.0, "multiplies D (widens or narrows every penumbra)", {}, 0.0, 100.0},
     {"candidates", ParamType::String, "contour",
      "occluder triangles searched: 'contour' (those along each opaque mesh's contour seen from the light "
      "centre, the receiver's neighbours, boundary edges, transparent objects) or 'all' (every triangle: the "
      "exact minimum)",
      {"contour", "all"}},
     {"band", ParamType::Float, 0.0,
      "with candidates=contour, also the triangles whose plane passes within band x D of the light centre "
      "(1: exact for rays that miss a closed mesh, slower)",
      {}, 0.0, 1.0},
     {"neighbours", ParamType::Bool, false,
      "with candidates=contour, a receiver on a mesh also tests the triangles sharing a vertex with its own (the "
      "all-triangle search's self-shadowing from local bumps; about 10-20% slower on the bunny)",
      {}},
     {"leaf_size", ParamType::Int, 4, "triangles per leaf of the cone-search BVH", {}, 1, 64},
     {"packet", ParamType::Int, 8,
      "rays of neighbouring view samples searched together (SIMD; `min` only; the same result): 8 (where the "
      "CPU has AVX2, else 4), 4, or 1 (one at a time)",
      {}, 1, 8}},
    [](const ParamSet& p) { return std::make_unique<SingleSampleSoftShadows>(p); },
    /*samples_light=*/false,
    memory,
    /*tile_exact=*/true,
    // A textured light counts as its mean colour: the light is its centre, size or outline.
    /*uniform_light=*/true,
    // A ray from each point toward the centre, the light's diameter its cone: no disk to split.
    /*sphere_through_disk=*/false,
});

}  // namespace
}  // namespace penumbra
