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
#include "penumbra/shadow/soft_shadow_volumes/edge_hierarchy.h"
#include "penumbra/shadow/soft_shadow_volumes/silhouette_edges.h"
#include "penumbra/trace/bvh.h"
#include "penumbra/trace/ray_shared.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {
namespace {

// The casters tested per light sample: TriangleBvh's default.
constexpr int kPartialLeafSize = 4;

struct Plane {
  Vec3f n;
  float d;  // n . x + d >= 0 inside
};

// Whether the box lies wholly on the negative side of the plane (its most positive corner).
inline bool outside(const Bounds3f& b, const Plane& p) {
  const Vec3f c{p.n.x >= 0 ? b.hi.x : b.lo.x, p.n.y >= 0 ? b.hi.y : b.lo.y, p.n.z >= 0 ? b.hi.z : b.lo.z};
  return dot(p.n, c) + p.d < 0;
}

class SoftShadowVolumes final : public ShadowMethod {
 public:
  explicit SoftShadowVolumes(const ParamSet&) {}

  void prepare(const ShadowContext& ctx) override {
    ScopedPhase phase(stats_, "silhouettes");
    stats_.prepare_count++;
    const AreaLight& light = *ctx.light;
    hierarchy_.build(*ctx.scene, light);
    // The casters that stop only part of the light somewhere (alpha-textured, or opacity < 1)
    // are left out of the edges and of the reference ray's count, and tested per light sample
    // (their own hierarchy): what is left is opaque, which the depth complexity counts.
    counted_.clear();
    partial_.clear();
    textures_ = TriangleTextures::of(*ctx.scene);
    std::vector<BvhTriangle> partial;
    for (size_t o = 0; o < ctx.scene->objects.size(); ++o) {
      const SceneObject& obj = ctx.scene->objects[o];
      std::vector<RasterTriangle> tris;
      append_raster_triangles(obj.mesh, obj.material.opacity, static_cast<uint32_t>(o), &tris);
      std::vector<uint8_t> counted(tris.size(), 0);
      for (size_t i = 0; i < tris.size(); ++i) {
        const RasterTriangle& t = tris[i];
        if (!(t.opacity > 0)) continue;
        if (!ssv::stops_part_of_the_light(t.opacity, obj.material)) {
          counted[i] = 1;
          continue;
        }
        partial.push_back({t.p[0], t.p[1], t.p[2], t.object, static_cast<uint32_t>(partial_.size()), t.opacity});
        partial_.push_back(t);
      }
      counted_.push_back(std::move(counted));
    }
    partial_bvh_ = partial.empty() ? TriangleBvh() : TriangleBvh(std::move(partial), kPartialLeafSize);
    stats_.extra["partial_casters"] = partial_.size();
    stats_.extra["silhouette_edges"] = hierarchy_.edges.size();
  }

  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override {
    const AreaLight& light = *ctx.light;
    const int n = std::max(1, ctx.light_samples);
    const LightSamples samples = make_light_samples(light, n, ctx.seed, ctx.light_index, ctx.frame);
    const ssv::PyramidBase base = ssv::pyramid_base(samples);
    const Vec3f* corners = base.corners;
    const Vec3f rect_centre = base.centre;

    std::atomic<uint64_t> edge_tests{0}, edge_updates{0}, crossings{0}, passes{0};
    {
      ScopedPhase phase(stats_, "evaluate");
      parallel_for(vs.size(), 16, [&](size_t begin, size_t end) {
        // Padded with zeros (samples at o, which never cross) for the SIMD kernel.
        const size_t padded = ssv::padded_samples(static_cast<size_t>(n));
        std::vector<float> x(padded, 0.0f), y(padded, 0.0f), z(padded, 0.0f);
        std::vector<int32_t> depth(padded);
        std::vector<float> transmittance(padded);  // through the casters tested per light sample
        std::vector<uint32_t> side[2];              // the light samples in front of / behind the receiver
        std::vector<uint32_t> stack;
        Counts counts;
        for (size_t k = begin; k < end; ++k) {
          const ViewSample& s = vs.samples[k];
          // Points behind the light's plane see none of it (as afsm and rays to the samples).
          if (!(dot(s.p - light.center, light.frame.n) > 0)) {
            out.visibility[k] = 0.0f;
            continue;
          }
          // A shadow ray leaves the receiver on the side its light point lies on (ray_shared.h
          // leaves_front), so the light samples are decided in two groups, each from its own
          // origin (the receiver's own surface is then never crossed): those in front of the
          // receiver's plane, and those behind it. On a closed mesh a ray to a sample behind the
          // tangent plane starts inside the object: blocked (afsm §3.3's rule per light sample).
          // An open surface lit from both sides (a thin two-sided leaf) pays for two groups.
          const Vec3f n_unit = shader::offset_normal(s.ng);
          side[0].clear();
          side[1].clear();
          for (int i = 0; i < n; ++i) side[shader::leaves_front(n_unit, samples.points[i] - s.p) ? 0 : 1].push_back(i);
          const bool closed = ctx.scene->objects[s.object].closed;
          double visible = 0;
          for (int g = 0; g < (closed ? 1 : 2); ++g) {
            if (side[g].empty()) continue;
            const Vec3f o = offset_ray_origin(s.p, s.ng, g == 0 ? s.ng : -s.ng);
            visible += visible_from(*ctx.tracer, *ctx.scene, o, samples, side[g], corners, rect_centre, light,
                                    {x.data(), y.data(), z.data(), depth.data(), transmittance.data()}, stack, counts);
          }
          out.visibility[k] = static_cast<float>(visible / n);
        }
        edge_tests += counts.tests;
        edge_updates += counts.updates;
        crossings += counts.hits;
        passes += counts.passes;
        if (ctx.progress) ctx.progress->add(end - begin);
      });
    }
    stats_.rays_traced += passes.load();
    stats_.extra["light_samples"] = n;
    stats_.extra["edge_tests"] = edge_tests.load();
    stats_.extra["edge_updates"] = edge_updates.load();
    stats_.extra["reference_crossings"] = crossings.load();
    stats_.extra["sample_groups"] = passes.load();
  }

 private:
  struct Counts {
    uint64_t tests = 0, updates = 0, hits = 0, passes = 0;
  };
  // A thread's arrays of one group of light samples (each padded_samples(n) long).
  struct Scratch {
    float *x, *y, *z;
    int32_t* depth;
    float* transmittance;
  };

  // §3.2-3.3 from the origin o for the light samples `group` (indices into samples): the sum of
  // their transmittances, 0 for each sample some opaque surface blocks (depth complexity > 0),
  // the product of (1 - opacity) over the partial casters its segment crosses otherwise.
  double visible_from(const RayTracer& tracer, const Scene& scene, Vec3f o, const LightSamples& samples,
                      const std::vector<uint32_t>& group,
                      const Vec3f corners[4], Vec3f rect_centre, const AreaLight& light, const Scratch& a,
                      std::vector<uint32_t>& stack, Counts& counts) const {
    const int m = static_cast<int>(group.size());
    const size_t padded = ssv::padded_samples(static_cast<size_t>(m));
    for (int j = 0; j < m; ++j) {
      const Vec3f q = samples.points[group[j]];
      a.x[j] = q.x - o.x, a.y[j] = q.y - o.y, a.z[j] = q.z - o.z;
    }
    for (size_t j = m; j < padded; ++j) a.x[j] = a.y[j] = a.z[j] = 0.0f;
    ++counts.passes;
    // §3.3: the reference sample's absolute depth complexity, from one ray.
    const Vec3f ref = samples.points[group[0]];
    const Vec3f r = ref - o;
    std::fill(a.depth, a.depth + padded, surfaces_crossed(tracer, scene, o, ref, &counts.hits));
    // The pyramid from o over the samples' rectangle: four planes through o and the light's
    // plane (edges beyond the light change nothing).
    Plane planes[5];
    for (int j = 0; j < 4; ++j) {
      Vec3f nn = cross(corners[j] - o, corners[(j + 1) % 4] - o);
      if (dot(nn, rect_centre - o) < 0) nn = -nn;
      planes[j] = {nn, -dot(nn, o)};
    }
    planes[4] = {light.frame.n, -dot(light.frame.n, light.center)};  // o's side: in front
    const ssv::SampleOffsets offsets{a.x, a.y, a.z, m};
    const float o_size = std::max(std::abs(o.x), std::max(std::abs(o.y), std::abs(o.z)));
    const std::vector<BvhNode>& nodes = hierarchy_.bvh.nodes();
    stack.clear();
    if (!nodes.empty()) stack.push_back(0);
    while (!stack.empty()) {
      const uint32_t stack_top = stack.back();
      const BvhNode& node = nodes[stack_top];
      stack.pop_back();
      bool cut = false;
      for (const Plane& p : planes) cut = cut || outside(node.bounds, p);
      if (cut || ssv::sees_all_alike(hierarchy_.node_facing[stack_top], o)) continue;
      if (!node.leaf()) {
        stack.push_back(node.first);
        stack.push_back(node.first + 1);
        continue;
      }
      for (uint32_t i = node.first; i < node.first + node.count; ++i) {
        ++counts.tests;
        // §3.2: an edge that is no silhouette from o changes nothing.
        if (ssv::surely_not_silhouette(hierarchy_.facing[i], o, o_size)) continue;
        if (ssv::add_edge_crossings(hierarchy_.edges[i], o, r, offsets, a.depth)) ++counts.updates;
      }
    }
    // The partial casters: each light sample's segment, where it meets one.
    std::fill(a.transmittance, a.transmittance + m, 1.0f);
    if (!partial_bvh_.empty()) {
      stack.clear();
      stack.push_back(0);
      const std::vector<BvhNode>& pnodes = partial_bvh_.nodes();
      while (!stack.empty()) {
        const BvhNode& node = pnodes[stack.back()];
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
          attenuate(partial_[partial_bvh_.triangles()[i].prim], o, samples, group, a.depth, a.transmittance);
      }
    }
    double sum = 0;
    for (int j = 0; j < m; ++j)
      if (a.depth[j] == 0) sum += a.transmittance[j];
    return sum;
  }

  // The number of surfaces the segment from o to q crosses (one closest-hit query per
  // surface, each starting just past the last hit; shadow_ray_to's end short of the light).
  // A segment through an edge or a vertex shared by triangles of one surface may report it
  // once per triangle, a few ulps apart: a hit that close to the last one, on the same object,
  // on a triangle sharing a vertex with the last one and facing the ray the same way, is the
  // same crossing. A ray through a ridge enters one face and leaves the next one at almost the
  // same point (a thin stem's crease, plant: hits 1e-6 apart on triangles sharing an edge):
  // they face it opposite ways, two crossings. Another surface crossed at almost the same point
  // (interpenetrating branches, crossing leaves) is counted.
  int32_t surfaces_crossed(const RayTracer& tracer, const Scene& scene, Vec3f o, Vec3f q, uint64_t* hits) const {
    const Vec3f d = q - o;
    const float dist = length(d);
    if (!(dist > 0)) return 0;
    Ray ray;
    ray.org = o;
    ray.dir = d / dist;
    ray.tnear = 0.0f;
    ray.tfar = dist * (1.0f - 1e-5f);
    int32_t count = 0;
    Hit hit, last, previous;
    bool any = false, any_hit = false;
    float step = 0.0f;  // how far past a repeated hit the next search starts (doubling)
    for (int guard = 0; guard < 4096 && tracer.intersect(ray, &hit); ++guard) {
      ++*hits;
      // The triangle just found, found again: a ray meets a triangle once, but Embree's
      // distance test can accept it again from the float after the t it reported (seen on one
      // machine with AVX2 and no AVX-512, never before: on the contact scene 4,096 repeats,
      // the box's far face never reached, every sample of a penumbra point counted blocked).
      // Step past it by a growing distance instead (at least one float: 1e-7 of t is over
      // half an ulp).
      if (any_hit && hit.object == previous.object && hit.prim == previous.prim &&
          hit.t - previous.t <= 1e-5f * std::max(1.0f, hit.t)) {
        step = step > 0.0f ? 2.0f * step : std::max(hit.t, 1e-30f) * 1e-7f;
        ray.tnear = std::max(ray.tnear, hit.t) + step;
        if (!(ray.tnear < ray.tfar)) break;
        continue;
      }
      previous = hit;
      any_hit = true;
      step = 0.0f;
      if (counted_[hit.object][hit.prim]) {
        const bool same_crossing = any && hit.object == last.object &&
                                   hit.t - last.t <= 1e-6f * std::max(1.0f, hit.t) &&
                                   (dot(hit.ng, ray.dir) < 0) == (dot(last.ng, ray.dir) < 0) &&
                                   share_a_vertex(scene.objects[hit.object].mesh, hit.prim, last.prim);
        if (!same_crossing) ++count;
        last = hit;
        any = true;
      }
      ray.tnear = std::nextafter(hit.t, kInfinity);
      if (!(ray.tnear < ray.tfar)) break;
    }
    return count;
  }
  static bool share_a_vertex(const TriangleMesh& m, uint32_t a, uint32_t b) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (m.vertex(a, i) == m.vertex(b, j)) return true;
    return false;
  }

  // Multiplies transmittance[j] by (1 - the opacity t has where the segment from o to light
  // sample group[j] crosses it), as the ray tracer's transparency filter does per crossing
  // (a sample left with at most kOpaqueCutoff counts as blocked). Samples some opaque surface
  // blocks already (depth > 0) are skipped, and so are those outside the box of t's shadow on
  // the light's plane (its corners projected from o, padded).
  void attenuate(const RasterTriangle& t, Vec3f o, const LightSamples& samples, const std::vector<uint32_t>& group,
                 const int32_t* depth, float* transmittance) const {
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
    for (size_t j = 0; j < group.size(); ++j) {
      if (depth[j] != 0 || transmittance[j] == 0.0f) continue;
      const Vec2f l = samples.local[group[j]];
      if (l.x < x0 || l.x > x1 || l.y < y0 || l.y > y1) continue;
      const float a = textures_.opacity_on_segment(t, o, samples.points[group[j]] - o);
      if (!(a > 0)) continue;
      transmittance[j] *= 1.0f - a;
      if (!(transmittance[j] > kOpaqueCutoff)) transmittance[j] = 0.0f;
    }
  }

  std::vector<RasterTriangle> partial_;  // the casters tested per light sample
  TriangleTextures textures_;            // their alpha textures
  TriangleBvh partial_bvh_;              // over partial_ (prim = index into it)
  ssv::EdgeHierarchy hierarchy_;  // the potential silhouettes (§3.1)
  std::vector<std::vector<uint8_t>> counted_;  // per object, per triangle: opaque, in the edges and the count
};

// One light's instance: the silhouette edges (at most every edge: 3/2 per triangle of a
// closed mesh, silhouette_edges.h) and their hierarchy, the larger of what finding them holds
// and what building the hierarchy holds (the edges twice while they are put in leaf order,
// their boxes, the build's nodes and scratch, the facing planes), or of the casters tested per
// light sample and their hierarchy where every triangle is one (they have no edges); a flag
// per triangle; per evaluate, the light samples; per worker thread, the samples relative to a
// point, their depth complexities and transmittances, and the two groups of sample indices.
MemoryEstimate memory(const ParamSet&, const MemoryQuery& q) {
  MemoryTally tally;
  const uint64_t edges = static_cast<uint64_t>(ssv::kEdgesPerTriangle * static_cast<double>(q.triangles));
  const uint64_t finding = edges * (ssv::kSilhouetteBuildBytesPerEdge + ssv::kSilhouetteResultBytesPerEdge);
  const uint64_t hierarchy = edges * (2 * sizeof(ssv::SilhouetteEdge) + sizeof(BvhTriangle) + sizeof(ssv::EdgeFacing)) +
                             TriangleBvh::build_bytes(edges, ssv::EdgeHierarchy::kLeafSize) +
                             TriangleBvh::node_bound(edges, ssv::EdgeHierarchy::kLeafSize) * sizeof(ssv::NodeFacing);
  const uint64_t partial = q.triangles * (2 * sizeof(RasterTriangle) + sizeof(BvhTriangle)) +
                           TriangleBvh::build_bytes(q.triangles, kPartialLeafSize);
  tally.add(std::max({finding, hierarchy, partial}) + q.triangles * sizeof(uint8_t), kTrianglesSetting);
  const uint64_t n = static_cast<uint64_t>(std::max(1, q.light_samples));
  tally.add(light_samples_bytes(static_cast<int>(n)) +
                static_cast<uint64_t>(q.threads) * ssv::padded_samples(n) * 7 * sizeof(float),
            kLightSamplesSetting);
  return tally.estimate();
}

const MethodRegistration registration({
    "ssv-rt",
    "soft shadow volumes for ray tracing (Laine et al. 2005): exact visibility of --spp fixed light samples (sphere "
    "and ellipsoid lights: exact against the light's central disk or ellipse, as afsm), one ray per point and side",
    {},
    [](const ParamSet& p) { return std::make_unique<SoftShadowVolumes>(p); },
    /*samples_light=*/true,
    memory,
    // Each view sample's V depends on that sample and the frame's light samples alone.
    /*tile_exact=*/true,
});

}  // namespace
}  // namespace penumbra
