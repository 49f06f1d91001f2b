// Method `ssv-rt`: soft shadow volumes for ray tracing (Laine, Aila, Assarsson, Lehtinen,
// Akenine-Moller, SIGGRAPH 2005). Exact visibility of a fixed set of N light samples (the set
// afsm uses, shadow/light_samples.h, so both agree with Embree rays to those points sample for
// sample) with one shadow ray per view sample instead of N:
//   prepare (once per light, §3.1): the casters' potential silhouette edges with respect to
//     the whole light, boundary edges of open meshes included (silhouette_edges.h), in a
//     bounding volume hierarchy (trace/bvh.h, over each edge's box);
//   per view sample o (§3.2-3.3): the edges whose penumbra wedge contains o. The wedge of an
//     edge is the set of points from which the edge covers part of the light, i.e. o is in
//     the wedge iff the edge meets the pyramid from o over the light's samples; the hierarchy
//     is walked with that pyramid (the paper walks a hierarchy of wedges with the point: the
//     same (point, edge) pairs, without bounding the unbounded wedges), skipping nodes whose
//     triangles the point sees all from one side (no silhouette from it there). Each such edge
//     updates the integer depth complexity of the light samples its projection sweeps
//     (depth_complexity.h), relative to one reference sample whose absolute depth complexity
//     one Embree ray gives by counting the surfaces it crosses (§3.3). A sample is visible
//     iff its depth complexity is 0; V = visible / N.
// Alpha-textured casters (issue 20) have no silhouette edges of their own (a mask's holes
// are not bounded by edges): they are left out of the edges and of the reference ray's count
// and tested per light sample instead, each segment from o where it meets the triangle
// (their own hierarchy, walked with the same pyramid), so V stays sample-exact.
// Restrictions: semi-transparent casters count as opaque (the depth complexity counts
// surfaces; zero-opacity triangles are left out); every light is sampled on the plane of its
// samples (rect, disk; sphere and ellipsoid on their central disk/ellipse, as afsm).
// docs/methods/ssv-rt.md.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <vector>

#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/raster/raster_triangle.h"
#include "penumbra/shadow/light_samples.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/shadow/soft_shadow_volumes/crossing_kernel.h"
#include "penumbra/shadow/soft_shadow_volumes/depth_complexity.h"
#include "penumbra/shadow/soft_shadow_volumes/silhouette_edges.h"
#include "penumbra/trace/bvh.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {
namespace {

// Edges per leaf: 8 measured 13% faster than 4 on the bunny (fewer nodes to test), 16 no better.
constexpr int kLeafSize = 8;

struct Plane {
  Vec3f n;
  float d;  // n . x + d >= 0 inside
};

// Whether the box lies wholly on the negative side of the plane (its most positive corner).
inline bool outside(const Bounds3f& b, const Plane& p) {
  const Vec3f c{p.n.x >= 0 ? b.hi.x : b.lo.x, p.n.y >= 0 ? b.hi.y : b.lo.y, p.n.z >= 0 ? b.hi.z : b.lo.z};
  return dot(p.n, c) + p.d < 0;
}

// A hierarchy node's bound on the facing of its edges' triangles (§3.2: only edges that are
// silhouettes from the point matter), so that a whole subtree is skipped where the point sees
// all of its triangles from the front, or all from behind: then no edge in it is a silhouette
// from the point. The triangles' unit normals N (oriented so that an edge's two triangles
// agree: k_e = 0 iff N_A . (o - x) and N_B . (o - x) have one sign) lie within `spread` of the
// unit `axis`; their points lie in `box`. For every such plane through x in the box,
//   N . (o - x) >= axis . o - max_box(axis . x) - spread |o - x|,
// and symmetrically from above: one bound decides the whole node.
struct NodeFacing {
  Vec3f axis{0.0f};
  float spread = 0;
  Bounds3f box;
  bool cullable = false;  // false with a boundary or degenerate edge, or normals all around
  // From the above, for the test: the range of axis . x over the box, its centre and
  // half-diagonal.
  float h_lo = 0, h_hi = 0;
  Vec3f centre{0.0f};
  float half_diagonal = 0;
};

class SoftShadowVolumes final : public ShadowMethod {
 public:
  explicit SoftShadowVolumes(const ParamSet&) {}

  void prepare(const ShadowContext& ctx) override {
    ScopedPhase phase(stats_, "silhouettes");
    stats_.prepare_count++;
    const AreaLight& light = *ctx.light;
    edges_ = ssv::potential_silhouettes(*ctx.scene, ssv::light_region(light));
    std::vector<BvhTriangle> boxes(edges_.size());
    for (size_t i = 0; i < edges_.size(); ++i) {
      boxes[i].v0 = edges_[i].a;
      boxes[i].v1 = boxes[i].v2 = edges_[i].b;
      boxes[i].prim = static_cast<uint32_t>(i);
    }
    bvh_ = TriangleBvh(std::move(boxes), kLeafSize);
    // The edges in the hierarchy's leaf order (a leaf's edges side by side), with their
    // quick facing test.
    {
      std::vector<ssv::SilhouetteEdge> ordered;
      ordered.reserve(edges_.size());
      for (const BvhTriangle& t : bvh_.triangles()) ordered.push_back(edges_[t.prim]);
      edges_ = std::move(ordered);
    }
    facing_.resize(edges_.size());
    for (size_t i = 0; i < edges_.size(); ++i) facing_[i] = ssv::edge_facing(edges_[i]);
    build_node_facing();
    opacity_.clear();
    std::vector<BvhTriangle> textured;
    for (size_t o = 0; o < ctx.scene->objects.size(); ++o) {
      const SceneObject& obj = ctx.scene->objects[o];
      const TriangleMesh& m = obj.mesh;
      // Alpha-textured objects: zero here (the reference ray does not count them), listed
      // for the per-sample test.
      const bool alpha_textured = obj.material.alpha_textured();
      std::vector<float> alpha(m.triangle_count(), alpha_textured ? 0.0f : obj.material.opacity);
      for (size_t t = 0; t < m.triangle_opacity.size() && t < alpha.size(); ++t) alpha[t] *= m.triangle_opacity[t];
      opacity_.push_back(std::move(alpha));
      if (alpha_textured) {
        std::vector<RasterTriangle> tris;
        append_raster_triangles(m, obj.material, static_cast<uint32_t>(o), &tris);
        for (const RasterTriangle& t : tris) {
          if (!(t.opacity > 0)) continue;
          textured.push_back({t.p[0], t.p[1], t.p[2], t.object, static_cast<uint32_t>(textured_.size()), t.opacity});
          textured_.push_back(t);
        }
      }
    }
    textured_bvh_ = textured.empty() ? TriangleBvh() : TriangleBvh(std::move(textured));
    stats_.extra["alpha_textured_triangles"] = textured_.size();
    stats_.extra["silhouette_edges"] = edges_.size();
  }

  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override {
    const AreaLight& light = *ctx.light;
    const int n = std::max(1, ctx.light_samples);
    const LightSamples samples = make_light_samples(light, n, ctx.seed, ctx.light_index, ctx.frame);
    // The samples' bounding rectangle on the light's plane, a little larger (rounding): the
    // base of every point's pyramid.
    float x0 = kInfinity, x1 = -kInfinity, y0 = kInfinity, y1 = -kInfinity;
    for (Vec2f u : samples.local) {
      x0 = std::min(x0, u.x), x1 = std::max(x1, u.x), y0 = std::min(y0, u.y), y1 = std::max(y1, u.y);
    }
    const float pad = 1e-3f * std::max(1.0f, std::max(x1 - x0, y1 - y0));
    x0 -= pad, x1 += pad, y0 -= pad, y1 += pad;
    const float R = samples.radius;
    const Vec3f corners[4] = {samples.center + samples.s * (R * x0) + samples.t * (R * y0),
                              samples.center + samples.s * (R * x1) + samples.t * (R * y0),
                              samples.center + samples.s * (R * x1) + samples.t * (R * y1),
                              samples.center + samples.s * (R * x0) + samples.t * (R * y1)};
    const Vec3f rect_centre = (corners[0] + corners[2]) * 0.5f;

    std::atomic<uint64_t> edge_tests{0}, edge_updates{0}, crossings{0};
    {
      ScopedPhase phase(stats_, "evaluate");
      parallel_for(vs.size(), 16, [&](size_t begin, size_t end) {
        // Padded with zeros (samples at o, which never cross) for the SIMD kernel.
        const size_t padded = ssv::padded_samples(static_cast<size_t>(n));
        std::vector<float> x(padded, 0.0f), y(padded, 0.0f), z(padded, 0.0f);
        std::vector<int32_t> depth(padded);
        std::vector<uint8_t> masked(padded);  // blocked by an alpha-textured caster
        std::vector<uint32_t> stack;
        uint64_t tests = 0, updates = 0, hits = 0;
        for (size_t k = begin; k < end; ++k) {
          const ViewSample& s = vs.samples[k];
          // Points behind the light's plane see none of it (as afsm and rays to the samples).
          if (!(dot(s.p - light.center, light.frame.n) > 0)) {
            out.visibility[k] = 0.0f;
            continue;
          }
          // The ray origin of afsm (alias_free.cpp): off the surface along ng, out of a
          // closed mesh, else toward the light, so both decide the receiver's own surface alike.
          const Vec3f o =
              offset_ray_origin(s.p, s.ng, ctx.scene->objects[s.object].closed ? s.ng : light.center - s.p);
          for (int i = 0; i < n; ++i) {
            x[i] = samples.points[i].x - o.x;
            y[i] = samples.points[i].y - o.y;
            z[i] = samples.points[i].z - o.z;
          }
          // §3.3: the reference sample's absolute depth complexity, from one ray.
          const Vec3f r = samples.points[0] - o;
          const int32_t d_ref = surfaces_crossed(*ctx.tracer, o, samples.points[0], &hits);
          std::fill(depth.begin(), depth.end(), d_ref);
          // The pyramid from o over the samples' rectangle: four planes through o and the
          // light's plane (edges beyond the light change nothing).
          Plane planes[5];
          for (int j = 0; j < 4; ++j) {
            Vec3f nn = cross(corners[j] - o, corners[(j + 1) % 4] - o);
            if (dot(nn, rect_centre - o) < 0) nn = -nn;
            planes[j] = {nn, -dot(nn, o)};
          }
          planes[4] = {light.frame.n, -dot(light.frame.n, light.center)};  // o's side: in front
          const ssv::SampleOffsets offsets{x.data(), y.data(), z.data(), n};
          const float o_size = std::max(std::abs(o.x), std::max(std::abs(o.y), std::abs(o.z)));
          const std::vector<BvhNode>& nodes = bvh_.nodes();
          stack.clear();
          if (!nodes.empty()) stack.push_back(0);
          while (!stack.empty()) {
            const uint32_t stack_top = stack.back();
            const BvhNode& node = nodes[stack_top];
            stack.pop_back();
            bool cut = false;
            for (const Plane& p : planes) cut = cut || outside(node.bounds, p);
            if (cut || sees_all_alike(node_facing_[stack_top], o)) continue;
            if (!node.leaf()) {
              stack.push_back(node.first);
              stack.push_back(node.first + 1);
              continue;
            }
            for (uint32_t i = node.first; i < node.first + node.count; ++i) {
              ++tests;
              // §3.2: an edge that is no silhouette from o changes nothing.
              if (ssv::surely_not_silhouette(facing_[i], o, o_size)) continue;
              if (ssv::add_edge_crossings(edges_[i], o, r, offsets, depth.data())) ++updates;
            }
          }
          // Alpha-textured casters: each light sample's segment, where it meets one. A receiver
          // that is itself alpha-textured is neither in the edges nor in the reference count, so
          // its own surface is decided as Embree decides it: the segments to the samples behind
          // its plane start on that side (no correction below).
          const bool textured_receiver = ctx.scene->objects[s.object].material.alpha_textured();
          const Origins origins{o, textured_receiver ? offset_ray_origin(s.p, s.ng, s.p - light.center) : o, s.p,
                                dot(s.ng, light.center - s.p) >= 0 ? s.ng : -s.ng};
          if (!textured_bvh_.empty()) {
            std::fill(masked.begin(), masked.end(), 0);
            stack.clear();
            stack.push_back(0);
            const std::vector<BvhNode>& tnodes = textured_bvh_.nodes();
            while (!stack.empty()) {
              const BvhNode& node = tnodes[stack.back()];
              stack.pop_back();
              bool cut = false;
              for (const Plane& p : planes) cut = cut || outside(node.bounds, p);
              if (cut) continue;
              if (!node.leaf()) {
                stack.push_back(node.first);
                stack.push_back(node.first + 1);
                continue;
              }
              for (uint32_t i = node.first; i < node.first + node.count; ++i)
                mask_samples(textured_[textured_bvh_.triangles()[i].prim], origins, samples, n, masked.data());
            }
            for (int i = 0; i < n; ++i) depth[i] += masked[i];
          }
          // The receiver's own surface, decided as a shadow ray from the offset origin
          // (shadow_ray_to) decides it: Embree starts each ray on the side of the surface its
          // light sample is on. On a closed mesh a sample behind the tangent plane starts inside
          // the object: blocked (afsm §3.3's rule per light sample). On an open one that ray
          // does not cross the surface which the ray from o (on the light centre's side) does:
          // one surface less.
          const bool closed = ctx.scene->objects[s.object].closed;
          const bool centre_side = dot(s.ng, light.center - s.p) >= 0;
          int visible = 0;
          for (int i = 0; i < n; ++i) {
            const bool front = dot(s.ng, samples.points[i] - s.p) >= 0;
            if (closed) visible += depth[i] == 0 && front;
            else visible += depth[i] - (front != centre_side && !textured_receiver) == 0;
          }
          out.visibility[k] = static_cast<float>(visible) / static_cast<float>(n);
        }
        edge_tests += tests;
        edge_updates += updates;
        crossings += hits;
        if (ctx.progress) ctx.progress->add(end - begin);
      });
    }
    stats_.rays_traced += vs.size();
    stats_.extra["light_samples"] = n;
    stats_.extra["edge_tests"] = edge_tests.load();
    stats_.extra["edge_updates"] = edge_updates.load();
    stats_.extra["reference_crossings"] = crossings.load();
  }

 private:
  // Bottom-up over the hierarchy (children come after their parent in bvh_.nodes()).
  void build_node_facing() {
    const std::vector<BvhNode>& nodes = bvh_.nodes();
    node_facing_.assign(nodes.size(), NodeFacing{});
    for (size_t k = nodes.size(); k-- > 0;) {
      const BvhNode& node = nodes[k];
      NodeFacing& f = node_facing_[k];
      std::vector<Vec3f> normals;
      f.cullable = true;
      if (node.leaf()) {
        for (uint32_t i = node.first; i < node.first + node.count; ++i) {
          const ssv::SilhouetteEdge& e = edges_[i];
          const ssv::EdgeFacing& ef = facing_[i];
          for (Vec3f p : {e.a, e.b, e.w[0]}) f.box.extend(p);
          if (e.triangles == 2) f.box.extend(e.w[1]);
          if (!ef.two_sided || !(ef.scale[0] > 0) || !(ef.scale[1] > 0)) {
            f.cullable = false;
            continue;
          }
          // n_0 and -n_1 (EdgeFacing orients both by (a, b, w): opposite for a consistent pair).
          normals.push_back(ef.n[0] / ef.scale[0]);
          normals.push_back(-ef.n[1] / ef.scale[1]);
        }
        Vec3f sum(0.0f);
        for (Vec3f n : normals) sum = sum + n;
        const float len = length(sum);
        if (!(len > 1e-3f * static_cast<float>(normals.size()))) f.cullable = false;
        if (!f.cullable) continue;
        f.axis = sum / len;
        for (Vec3f n : normals) f.spread = std::max(f.spread, length(n - f.axis));
      } else {
        const NodeFacing& l = node_facing_[node.first];
        const NodeFacing& r = node_facing_[node.first + 1];
        f.box = l.box;
        f.box.extend(r.box);
        const Vec3f sum = l.axis + r.axis;
        const float len = length(sum);
        f.cullable = l.cullable && r.cullable && len > 1e-3f;
        if (!f.cullable) continue;
        f.axis = sum / len;
        f.spread = std::max(l.spread + length(l.axis - f.axis), r.spread + length(r.axis - f.axis));
      }
      // Normals more than 90 degrees apart: no side is common to all.
      if (f.spread >= 1.0f) f.cullable = false;
      if (!f.cullable) continue;
      f.h_lo = kInfinity, f.h_hi = -kInfinity;
      for (int i = 0; i < 8; ++i) {
        const float h = dot(f.axis, f.box.corner(i));
        f.h_lo = std::min(f.h_lo, h);
        f.h_hi = std::max(f.h_hi, h);
      }
      f.centre = f.box.center();
      f.half_diagonal = 0.5f * length(f.box.diagonal());
    }
  }

  // Whether o sees every triangle of the node from the same side (NodeFacing), with a margin
  // far above the rounding, so that add_edge_crossings would find k_e = 0 for each edge.
  static bool sees_all_alike(const NodeFacing& f, Vec3f o) {
    if (!f.cullable) return false;
    const float reach = length(o - f.centre) + f.half_diagonal;
    const float ao = dot(f.axis, o);
    const float margin = 1e-4f * (reach + std::abs(ao) + 1.0f);
    return ao - f.h_hi - f.spread * reach > margin || ao - f.h_lo + f.spread * reach < -margin;
  }

  // The number of surfaces the segment from o to q crosses (one closest-hit query per
  // surface, each starting past the last hit; shadow_ray_to's end short of the light).
  int32_t surfaces_crossed(const RayTracer& tracer, Vec3f o, Vec3f q, uint64_t* hits) const {
    const Vec3f d = q - o;
    const float dist = length(d);
    if (!(dist > 0)) return 0;
    Ray ray;
    ray.org = o;
    ray.dir = d / dist;
    ray.tnear = 0.0f;
    ray.tfar = dist * (1.0f - 1e-5f);
    int32_t count = 0;
    Hit hit;
    for (int guard = 0; guard < 4096 && tracer.intersect(ray, &hit); ++guard) {
      ++*hits;
      if (opacity_[hit.object][hit.prim] > 0) ++count;
      // Past this surface: the next one further along (a ray through a shared edge counts
      // the surface once).
      ray.tnear = std::nextafter(hit.t, kInfinity) + 1e-6f * hit.t;
      if (!(ray.tnear < ray.tfar)) break;
    }
    return count;
  }

  // Where the segments to the light samples start for the alpha-textured casters: `front` for
  // the samples on the side of the receiver's plane (through p, ng pointing to the light's
  // centre) the centre is on, `back` for the others (the same point unless the receiver is
  // itself alpha-textured).
  struct Origins {
    Vec3f front, back, p, ng;
    bool front_side(Vec3f q) const { return dot(ng, q - p) >= 0; }
  };
  // Sets masked[i] for the light samples whose segment from its origin meets t where t's alpha
  // texture is solid (the segment ends at the sample). Only the samples inside
  // the box of t's shadow on the light's plane (its corners projected from the front origin,
  // padded) are tested.
  static void mask_samples(const RasterTriangle& t, const Origins& from, const LightSamples& samples, int n,
                           uint8_t* masked) {
    const Vec3f o = from.front;
    float x0 = -kInfinity, x1 = kInfinity, y0 = -kInfinity, y1 = kInfinity;
    {
      const float h = dot(samples.n, samples.center - o);
      float bx0 = kInfinity, bx1 = -kInfinity, by0 = kInfinity, by1 = -kInfinity;
      bool bounded = true;
      for (int k = 0; k < 3 && bounded; ++k) {
        const Vec3f d = t.p[k] - o;
        const float dn = dot(samples.n, d);
        bounded = h != 0 && dn != 0 && (h / dn) > 0;  // the corner's ray from o reaches the plane
        if (!bounded) break;
        const Vec3f q = o + d * (h / dn) - samples.center;
        const float u = dot(q, samples.s) / samples.radius, v = dot(q, samples.t) / samples.radius;
        bx0 = std::min(bx0, u), bx1 = std::max(bx1, u), by0 = std::min(by0, v), by1 = std::max(by1, v);
      }
      if (bounded) {
        const float pad = 1e-3f * (1.0f + std::max(bx1 - bx0, by1 - by0));
        x0 = bx0 - pad, x1 = bx1 + pad, y0 = by0 - pad, y1 = by1 + pad;
      }
    }
    const bool two = !(from.back == from.front);
    for (int i = 0; i < n; ++i) {
      if (masked[i]) continue;
      const Vec2f l = samples.local[i];
      if (l.x < x0 || l.x > x1 || l.y < y0 || l.y > y1) continue;
      const Vec3f q = samples.points[i];
      const Vec3f origin = !two || from.front_side(q) ? from.front : from.back;
      if (t.opacity_on_segment(origin, q - origin) > 0) masked[i] = 1;
    }
  }

  std::vector<RasterTriangle> textured_;  // the alpha-textured casters
  TriangleBvh textured_bvh_;               // over textured_ (prim = index into it)
  std::vector<ssv::SilhouetteEdge> edges_;  // in bvh_'s leaf order
  std::vector<ssv::EdgeFacing> facing_;      // the same order
  std::vector<NodeFacing> node_facing_;      // per node of bvh_
  TriangleBvh bvh_;
  std::vector<std::vector<float>> opacity_;  // per object, per triangle
};

// One light's instance: the silhouette edges (at most every edge: 3/2 per triangle of a
// closed mesh, silhouette_edges.h) and their hierarchy, the larger of what finding them holds
// and what building the hierarchy holds (the edges twice while they are put in leaf order,
// their boxes, the build's nodes and scratch, the facing planes); the opacity per triangle;
// per evaluate, the light samples; per worker thread, the samples relative to a point and
// their depth complexities.
MemoryEstimate memory(const ParamSet&, const MemoryQuery& q) {
  MemoryTally tally;
  const uint64_t edges = static_cast<uint64_t>(ssv::kEdgesPerTriangle * static_cast<double>(q.triangles));
  const uint64_t finding = edges * (ssv::kSilhouetteBuildBytesPerEdge + ssv::kSilhouetteResultBytesPerEdge);
  const uint64_t hierarchy = edges * (2 * sizeof(ssv::SilhouetteEdge) + sizeof(BvhTriangle) + sizeof(ssv::EdgeFacing)) +
                             TriangleBvh::build_bytes(edges, kLeafSize) +
                             TriangleBvh::node_bound(edges, kLeafSize) * sizeof(NodeFacing);
  tally.add(std::max(finding, hierarchy) + q.triangles * sizeof(float), kTrianglesSetting);
  const uint64_t n = static_cast<uint64_t>(std::max(1, q.light_samples));
  tally.add(light_samples_bytes(static_cast<int>(n)) +
                static_cast<uint64_t>(q.threads) * ssv::padded_samples(n) * 4 * sizeof(float),
            kLightSamplesSetting);
  return tally.estimate();
}

const MethodRegistration registration({
    "ssv-rt",
    "soft shadow volumes for ray tracing (Laine et al. 2005): exact visibility of --spp fixed light samples, one ray "
    "per point",
    {},
    [](const ParamSet& p) { return std::make_unique<SoftShadowVolumes>(p); },
    /*samples_light=*/true,
    memory,
    // Each view sample's V depends on that sample and the frame's light samples alone.
    /*tile_exact=*/true,
});

}  // namespace
}  // namespace penumbra
