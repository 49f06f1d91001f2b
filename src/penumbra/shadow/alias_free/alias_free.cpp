// Methods `afsm-hard` and `afsm` (sintorn2008): alias-free shadow maps and sample-based
// soft visibility. Instead of sampling the casters at the light's texel centres (a shadow
// map), the *view samples* are listed at the light's texels (texel_lists.h) and every caster
// is rasterized conservatively over them; each (listed sample, caster) pair is then decided
// exactly in world space. Nothing is resampled, so there is no aliasing and no depth bias.
//
// afsm-hard (§3): one point, the light's centre. A caster's shadow volume is the intersection
// of four half-spaces: behind its supporting plane, and inside the three planes through the
// light and an edge (§3.3). On a closed mesh only light back-facing triangles cast and light
// back-facing view samples are in shadow by their own surface (§3.3: no bias, no acne).
//
// afsm (§4): N light samples as bits. A caster is rasterized over its influence region
// (influence_region.h), and for each listed sample p the light samples it hides are the AND
// of four plane masks (sample_masks.h): behind its supporting plane as seen from p, inside
// the planes through p and each edge (§4.2, Fig. 6). The masks OR into p's mask; V is the
// fraction of unset bits.
//
// Both run on the CPU: the conservative rasterizer bins and walks texels in parallel tiles,
// all calls for one texel come from one thread, so the per-slot state needs no atomics.
// docs/methods/alias-free.md.
#include <algorithm>
#include <bit>
#include <cmath>
#include <optional>
#include <unordered_map>

#include <tbb/enumerable_thread_specific.h>

#include "penumbra/core/error.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/rng.h"
#include "penumbra/raster/conservative.h"
#include "penumbra/raster/raster_triangle.h"
#include "penumbra/raster/shadow_view.h"
#include "penumbra/shadow/alias_free/alias_free_shared.h"
#include "penumbra/shadow/alias_free/influence_region.h"
#include "penumbra/shadow/alias_free/pair_filter.h"
#include "penumbra/shadow/alias_free/sample_masks.h"
#include "penumbra/shadow/alias_free/texel_lists.h"
#include "penumbra/shadow/shadow_map_common.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/trace/ray_shared.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {
namespace {

using afsm::TexelLists;

constexpr float kFlat = shader::kAfsmFlat;  // alias_free_shared.h

// The plane through an apex and a triangle edge (alias_free_shared.h afsm_edge_plane: shared with
// the GPU version).
inline Vec3f edge_plane(Vec3f a, Vec3f d, bool apex_in_front) { return shader::afsm_edge_plane(a, d, apex_in_front); }

// The light a view sample loses along the segments to `points`: 1 - transmittance summed in their
// order (the GPU's, afsm_soft_resolve.comp), over the rays shadow_ray_to gives, as `reference`
// and embree_to_points trace them. For the light samples the lists cannot decide: those only
// semi-transparent casters cover, and the entries no list holds. `rays` and `transmitted` are
// the caller's scratch.
float light_lost(const RayTracer& tracer, const ViewSample& s, std::span<const Vec3f> points,
                 std::vector<ShadowRay>& rays, std::vector<float>& transmitted) {
  rays.clear();
  for (Vec3f q : points) rays.push_back(shadow_ray_to(s.p, s.ng, q));
  transmitted.resize(rays.size());
  tracer.transmittance(rays, transmitted);
  float lost = 0;
  for (float t : transmitted) lost += 1.0f - t;
  return lost;
}

struct Counters {
  uint64_t texel_visits = 0;   // (covered texel, caster) pairs
  uint64_t empty_visits = 0;   // ... whose texel lists no sample (skipped at once)
  uint64_t sample_tests = 0;   // (listed sample, caster) tests
  uint64_t plane_lookups = 0;  // plane -> mask lookups (afsm)
  uint64_t exact_bits = 0;     // light samples tested exactly inside lookups (afsm)
  uint64_t grid_pairs = 0;     // (sample, caster) pairs decided on the sample grid (afsm)
  uint64_t grid_tests = 0;     // light samples tested exactly there
  void add(const Counters& o) {
    texel_visits += o.texel_visits;
    empty_visits += o.empty_visits;
    sample_tests += o.sample_tests;
    plane_lookups += o.plane_lookups;
    exact_bits += o.exact_bits;
    grid_pairs += o.grid_pairs;
    grid_tests += o.grid_tests;
  }
};

// What both methods share: the casters, the light view fitted to the listed view samples
// (§4.3 "Parametrization") and the lists.
class AliasFreeBase : public ShadowMethod {
 public:
  explicit AliasFreeBase(const ParamSet& p) : resolution_(p.get_int("resolution")), max_fov_(p.get_float("max_fov")) {}

  void prepare(const ShadowContext& ctx) override {
    ScopedPhase phase(stats_, "gather");
    stats_.prepare_count++;
    triangles_ = gather_raster_triangles(*ctx.scene);
    scene_bounds_ = ctx.scene->bounds();
    reach_ = shadow_map::shadow_reach(*ctx.scene, *ctx.light);
  }

 protected:
  // The point a shadow ray from view sample s starts from, off its surface along ng by the ray
  // tracer's margin to its front (along ng) or back side (offset_ray_origin, ray_shared.h).
  // This is the plane offset of §3.3 in its receiver form: the surface a sample lies on (its
  // own triangle, a coplanar neighbour, a touching face) is decided the way a shadow ray decides
  // it, so the methods agree with rays to the same light points sample for sample, and no bias
  // is ever tuned.
  static Vec3f ray_origin(const ViewSample& s, bool front) { return offset_ray_origin(s.p, s.ng, front ? s.ng : -s.ng); }

  // Lists `points` (ids[i] names points[i]: a view sample, or an entry of the caller's) at the
  // texels of a view from the light's centre along its axis, fitted to them. False if none lies
  // in front of the light.
  bool build_lists(std::span<const Vec3f> points, std::span<const uint32_t> ids, const AreaLight& light) {
    if (ids.empty()) return false;
    ScopedPhase phase(stats_, "lists");
    ShadowViewFit fit;
    fit.resolution = resolution_;
    fit.max_fov = max_fov_;
    shadow_map::set_reach(fit, reach_);
    try {
      view_ = fit_shadow_view(light.center, light.frame.n, light.frame.t, points, scene_bounds_, fit);
    } catch (const Interrupted&) {
      throw;  // Ctrl-C ends the run, whatever this step would do with an error
    } catch (const Error&) {
      return false;  // no receiver in front of the light's centre
    }
    lists_ = afsm::build_texel_lists(view_, points, ids);
    const TexelLists::Occupancy occ = lists_.occupancy();
    stats_.extra["map_width"] = lists_.width;
    stats_.extra["map_height"] = lists_.height;
    stats_.extra["listed_samples"] = lists_.slots();
    stats_.extra["uncovered_samples"] = lists_.uncovered;
    stats_.extra["lists_occupied"] = occ.occupied;
    stats_.extra["lists_occupied_fraction"] =
        static_cast<double>(occ.occupied) / (static_cast<double>(lists_.width) * lists_.height);
    stats_.extra["list_average"] = occ.average;
    stats_.extra["list_max"] = occ.longest;
    return true;
  }

  // §3: the shadow of every listed slot for the point light at c: kCenterBlocked where some
  // caster blocks the segment from the slot's point to c; kCenterPartial where, with `partial`,
  // only casters that stop part of the light (semi-transparent, alpha blend) cover it (its ray
  // then decides how much passes); else 0. Closed meshes cast with their triangles facing
  // away from c only (§3.3). Sets extra.casters; adds to *counters and *memory.
  static constexpr uint8_t kCenterPartial = shader::kAfsmCenterPartial, kCenterBlocked = shader::kAfsmCenterBlocked;
  std::vector<uint8_t> center_shadow(const Scene& scene, Vec3f c, bool partial, Counters* counters, size_t* memory) {
    std::vector<RasterTriangle> casters;
    std::vector<Planes> planes;
    {
      ScopedPhase phase(stats_, "casters");
      // At most every triangle: one allocation each instead of a doubling's copies and fresh
      // pages (the forest's 1.4 M casters: 183 -> 60 ms).
      casters.reserve(triangles_.list.size());
      planes.reserve(triangles_.list.size());
      for (const RasterTriangle& t : triangles_.list) {
        if (!(t.opacity > 0)) continue;
        const Vec3f n = cross(t.p[1] - t.p[0], t.p[2] - t.p[0]);
        const float side = dot(n, c - t.p[0]);
        // §3.3: a closed mesh casts with its light back-facing triangles only.
        if (scene.objects[t.object].closed ? !(side < 0) : side == 0) continue;
        Planes pl;
        pl.support = side > 0 ? -n : n;
        pl.v0 = t.p[0];
        for (int i = 0; i < 3; ++i) pl.edge[i] = edge_plane(t.p[i] - c, t.p[(i + 1) % 3] - t.p[i], side > 0);
        casters.push_back(t);
        planes.push_back(pl);
      }
    }
    std::vector<uint8_t> shadowed(lists_.slots(), 0);  // the shadow bits, apart from positions
    tbb::enumerable_thread_specific<Counters> local;
    {
      ScopedPhase phase(stats_, "raster_center");
      const TriangleTextures& textures = triangles_.textures;
      rasterizer_.triangles(RasterTriangleView(casters, &textures), view_, RasterFilter{}, [&](int x, int y, uint32_t index) {
        Counters& cnt = local.local();
        cnt.texel_visits++;
        const uint32_t begin = lists_.begin(x, y), end = lists_.end(x, y);
        if (begin == end) {
          cnt.empty_visits++;  // §4.3: texels with empty lists do no work
          return;
        }
        const Planes& pl = planes[index];
        const uint8_t mark = partial && textures.semi_transparent(casters[index]) ? kCenterPartial : kCenterBlocked;
        for (uint32_t slot = begin; slot < end; ++slot) {
          if (shadowed[slot] >= mark) continue;
          cnt.sample_tests++;
          const Vec3f p = lists_.positions[slot];
          // §3.3's four planes (alias_free_shared.h: the GPU version runs the same test).
          if (!shader::afsm_hard_blocks(pl.support, pl.v0, pl.edge[0], pl.edge[1], pl.edge[2], c, p)) continue;
          const Vec3f d = p - c;
          // An alpha-textured caster (issue 20) blocks where the segment meets it inside its mask.
          if (mark == kCenterBlocked && textures.textured(casters[index]) &&
              !(textures.opacity_on_line(casters[index], p, d) > 0))
            continue;
          shadowed[slot] = mark;
        }
      });
    }
    for (const Counters& c2 : local) counters->add(c2);
    stats_.extra["casters"] = casters.size();
    *memory += shadowed.size() + planes.size() * sizeof(Planes) + casters.size() * sizeof(RasterTriangle);
    return shadowed;
  }

  // For memory estimates, into `tally`: the gathered triangles; per view sample, the ids of
  // those to list (grown by doubling), the points the lists are built from, the lists and which
  // samples are listed; per texel of the fitted image (resolution^2), the lists' starts.
  static void add_lists_memory(MemoryTally& tally, const ParamSet& p, const MemoryQuery& q) {
    const ViewSize v = fitted_view_bound(p.get_int("resolution"));
    const uint64_t texels = static_cast<uint64_t>(v.width) * static_cast<uint64_t>(v.height);
    tally.add(raster_triangles_bytes(q.triangles), kTrianglesSetting);
    tally.add(q.view_samples * (2 * sizeof(uint32_t) + sizeof(Vec3f) + sizeof(char)), kViewSamplesSetting);
    tally.add(TexelLists::bytes(texels, q.view_samples), "resolution");
  }
  // What center_shadow() holds: the casters and their planes (grown by doubling), a shadow
  // bit per slot and the conservative rasterizer's scratch (a clipped triangle: 3-5 vertices).
  static void add_center_shadow_memory(MemoryTally& tally, const ParamSet& p, const MemoryQuery& q) {
    const ViewSize v = fitted_view_bound(p.get_int("resolution"));
    tally.add(2 * q.triangles * (sizeof(RasterTriangle) + sizeof(Planes)) +
                  ConservativeRasterizer::scratch_bytes(q.triangles, 4 * q.triangles, v.width, v.height),
              kTrianglesSetting);
    tally.add(q.view_samples * sizeof(uint8_t), kViewSamplesSetting);
  }

  void report(const Counters& c, uint64_t casters, uint64_t extra_memory) {
    stats_.texels_visited += c.texel_visits;
    stats_.extra["casters"] = casters;
    stats_.extra["texel_visits"] = c.texel_visits;
    stats_.extra["empty_texel_visits"] = c.empty_visits;
    stats_.extra["sample_tests"] = c.sample_tests;
    stats_.memory_bytes = std::max<uint64_t>(stats_.memory_bytes, lists_.memory_bytes() + extra_memory);
  }

  // A caster of center_shadow() and its four planes (§3.3), oriented so that "inside" is
  // positive.
  struct Planes {
    Vec3f support;  // p is behind the caster when dot(support, p - v0) > 0
    Vec3f v0;
    Vec3f edge[3];  // p is inside the pyramid when dot(edge[i], p - c) >= 0 for all i
  };

  int resolution_;
  float max_fov_;
  RasterTriangles triangles_;  // with their alpha textures
  Bounds3f scene_bounds_;
  ShadowRegion reach_;  // shadow_map::shadow_reach: the samples beyond max_fov a caster can shadow are listed too
  LightView view_;
  TexelLists lists_;
  ConservativeRasterizer rasterizer_;
};

// In front of the light's emitting plane (rect, disk; for a sphere, of the disk facing the
// scene that its samples lie on): other points see no light sample (V = 0, as `reference`).
bool in_front_of_light(const AreaLight& light, Vec3f p) { return dot(p - light.center, light.frame.n) > 0.0f; }

// ---------------------------------------------------------------------------------------
// afsm-hard

class AliasFreeHard final : public AliasFreeBase {
 public:
  using AliasFreeBase::AliasFreeBase;

  // One light's instance: the lists (add_lists_memory) and the centre's shadow bits
  // (add_center_shadow_memory).
  static MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q) {
    MemoryTally tally;
    add_lists_memory(tally, p, q);
    add_center_shadow_memory(tally, p, q);
    return tally.estimate();
  }

  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override {
    const AreaLight& light = *ctx.light;
    const Vec3f c = light.center;
    const Scene& scene = *ctx.scene;
    std::fill(out.visibility.begin(), out.visibility.end(), 0.0f);
    // §3.1: only visible, light front-facing samples are listed; on a closed mesh a light
    // back-facing one is in its own shadow (§3.3). An open surface has no inside: the shadow
    // ray leaves it on the light's side, so its samples are listed whatever their facing.
    std::vector<uint32_t> ids;
    std::vector<Vec3f> points;
    for (size_t k = 0; k < vs.size(); ++k) {
      const ViewSample& s = vs.samples[k];
      if (!in_front_of_light(light, s.p)) continue;
      const bool closed = scene.objects[s.object].closed;
      if (closed && !(dot(s.ng, c - s.p) > 0)) continue;
      ids.push_back(static_cast<uint32_t>(k));
      // The shadow ray to the centre leaves a closed mesh outward (where every ray that is not
      // blocked by the object itself starts), an open surface on the centre's side.
      points.push_back(closed ? ray_origin(s, true) : offset_ray_origin(s.p, s.ng, c - s.p));
    }
    if (!build_lists(points, ids, light)) {
      finish(ctx, vs);
      return;
    }
    for (size_t slot = 0; slot < lists_.slots(); ++slot) out.visibility[lists_.sample[slot]] = 1.0f;
    // Uncovered samples (outside the fitted window, which max_fov caps, or before its near plane)
    // take their ray to the centre (`hard`'s); without a ray tracer they are lit, as outside a
    // shadow map.
    std::vector<uint32_t> rays_decide;  // view samples (unlisted), then list slots (partial, below)
    {
      std::vector<char> listed(vs.size(), 0);
      for (uint32_t id : lists_.sample) listed[id] = 1;
      for (uint32_t id : ids) {
        if (listed[id]) continue;
        if (ctx.tracer)
          rays_decide.push_back(id);
        else
          out.visibility[id] = 1.0f;
      }
    }

    Counters total;
    size_t memory = 0;
    const std::vector<uint8_t> shadowed = center_shadow(scene, c, ctx.tracer != nullptr, &total, &memory);
    const size_t unlisted = rays_decide.size();
    for (size_t slot = 0; slot < lists_.slots(); ++slot) {
      if (shadowed[slot] == kCenterBlocked) out.visibility[lists_.sample[slot]] = 0.0f;
      // Only casters that stop part of the light cover it.
      if (shadowed[slot] == kCenterPartial) rays_decide.push_back(lists_.sample[slot]);
    }
    // Their rays to the centre decide how much light passes (the ray tracer's transmittance,
    // as `hard`'s).
    if (!rays_decide.empty()) {
      ScopedPhase phase(stats_, "rays");
      parallel_for(rays_decide.size(), 256, [&](size_t begin, size_t end) {
        std::vector<ShadowRay> rays;
        std::vector<float> transmitted(end - begin);
        for (size_t k = begin; k < end; ++k) {
          const ViewSample& s = vs.samples[rays_decide[k]];
          rays.push_back(shadow_ray_to(s.p, s.ng, c));
        }
        ctx.tracer->transmittance(rays, transmitted);
        for (size_t k = begin; k < end; ++k) out.visibility[rays_decide[k]] = transmitted[k - begin];
      });
    }
    stats_.extra["unlisted_rays"] = unlisted;
    stats_.extra["partial_rays"] = rays_decide.size() - unlisted;
    report(total, static_cast<uint64_t>(stats_.extra.value("casters", 0)), memory);
    finish(ctx, vs);
  }

 private:
  void finish(const ShadowContext& ctx, const ViewSamples& vs) {
    if (ctx.progress) ctx.progress->add(vs.size());
  }
};

// ---------------------------------------------------------------------------------------
// afsm

class AliasFreeSoft final : public AliasFreeBase {
 public:
  explicit AliasFreeSoft(const ParamSet& p)
      : AliasFreeBase(p),
        use_lut_(p.get_bool("lut")),
        lut_resolution_(p.get_int("lut_resolution")),
        jitter_(p.get_bool("jitter")),
        restrict_(p.get_bool("restrict")),
        slabs_(p.get_int("slabs")),
        silhouettes_(p.get_bool("silhouettes")) {}

  // One light's instance: the lists (add_lists_memory); the light samples, their grid and
  // the table of plane masks; the depth slabs (a slot start per slab and texel, and its
  // summed-area table with restrict); per listed view sample, its depth, its mask of blocked
  // light samples (a bit each), its flags, its rotation (jitter) and the SIMD copies of its
  // position; per caster, its set-ups, nearest depth and support mask, and per slab its
  // region (of the usual size, grown by doubling: every caster in every slab, where restrict
  // and the slabs' far planes usually drop half) and the slab rasterizer's scratch, for the
  // slabs of one group (slab_group: those rasterized at once), with a whole hull per caster
  // while one slab's regions are computed. With silhouettes, the
  // welded edges and their hash maps, their regions, the stencil and the centre's shadow
  // bits. Everything per listed sample counts twice: a view sample on an open surface whose
  // plane cuts the light is listed once per side (evaluate), with its side's mask of light
  // samples while the sides are found. Left out: a thread's buffer of one span's survivors (a
  // row of texels' samples).
  static MemoryEstimate memory(const ParamSet& p, const MemoryQuery& view_query) {
    MemoryTally tally;
    const int n = std::clamp(view_query.light_samples, 1, afsm::kMaxLightSamples);
    const uint64_t words = static_cast<uint64_t>(afsm::mask_words(n));
    // The split samples' masks of front light samples (at most one a view sample; the vector
    // grows geometrically: twice that), then the sides and the entries.
    tally.add(view_query.view_samples * 2 * words * sizeof(uint64_t), kLightSamplesSetting);
    tally.add(view_query.view_samples * (sizeof(uint8_t) + 2 * (sizeof(ListEntry) + sizeof(uint16_t))),
              kViewSamplesSetting);
    MemoryQuery q = view_query;
    q.view_samples *= 2;
    add_lists_memory(tally, p, q);
    const int lut_bins = p.get_bool("lut") ? p.get_int("lut_resolution") : 0;
    tally.add(afsm::PlaneMaskLut::bytes(n, lut_bins, lut_bins), "lut_resolution");
    tally.add(afsm::light_samples_bytes(n) + afsm::SampleGrid::bytes(n), kLightSamplesSetting);

    const ViewSize v = fitted_view_bound(p.get_int("resolution"));
    const int slabs = p.get_int("slabs");
    tally.add(afsm::DepthSlabs::bytes(slabs, v.width, v.height, q.view_samples, p.get_bool("restrict")), "resolution");
    const bool symmetric = !q.light || q.light->shape == LightShape::Disk || q.light->shape == LightShape::Sphere;
    const bool jitter = p.get_bool("jitter") && symmetric;
    const uint64_t slots = q.view_samples + afsm::kPairPadding;
    tally.add(slots * words * sizeof(uint64_t), kLightSamplesSetting);
    // Casters that stop part of the light: a second mask and the light they take, per slot.
    if (q.semi_transparent) tally.add(slots * (words * sizeof(uint64_t) + sizeof(float)), kLightSamplesSetting);
    tally.add(slots * (sizeof(float) + sizeof(uint32_t) + sizeof(uint8_t) + sizeof(uint16_t) + 3 * sizeof(float) +
                       (jitter ? sizeof(Vec2f) + 2 * sizeof(float) : 0)),
              kViewSamplesSetting);

    const uint64_t t = q.triangles;
    const uint64_t region_vertices = static_cast<uint64_t>(afsm::typical_region_vertices(q.light));
    constexpr uint64_t kHullVertices = 3 * 8;  // evaluate's hull slots per caster
    const uint64_t per_caster = 2 * (sizeof(Caster) + sizeof(float) + words * sizeof(uint64_t)) +
                                sizeof(afsm::PairCaster) + kHullVertices * sizeof(Vec2f) + sizeof(uint8_t);
    const uint64_t per_slab =
        2 * t * (region_vertices * sizeof(Vec2f) + 2 * sizeof(uint32_t)) +
        ConservativeRasterizer::scratch_bytes(t, t * region_vertices, v.width, v.height, kSlabTile);
    tally.add(t * per_caster + static_cast<uint64_t>(slab_group(slabs)) * per_slab, kTrianglesSetting);
    if (p.get_bool("silhouettes")) {
      // At most three edges a triangle; a hash-map entry is a node of a few words.
      const uint64_t edges = 3 * t;
      constexpr uint64_t kHashEntry = 48;
      const uint64_t per_edge =
          2 * sizeof(SilhouetteEdge) + 2 * kHashEntry + 2 * (region_vertices * sizeof(Vec2f) + sizeof(uint32_t));
      tally.add(
          edges * per_edge + ConservativeRasterizer::scratch_bytes(edges, edges * region_vertices, v.width, v.height),
          kTrianglesSetting);
      tally.add(static_cast<uint64_t>(v.width) * static_cast<uint64_t>(v.height), "resolution");
      add_center_shadow_memory(tally, p, q);
    }
    return tally.estimate();
  }

  // §4.3 "Restrict computations": the edges of the casters, welded by position, with the
  // normals of their (first two) faces, for the silhouette test of each frame.
  void prepare(const ShadowContext& ctx) override {
    AliasFreeBase::prepare(ctx);
    edges_.clear();
    if (!silhouettes_) return;
    ScopedPhase phase(stats_, "edges");
    struct Key {
      uint32_t x, y, z;
      bool operator==(const Key& o) const { return x == o.x && y == o.y && z == o.z; }
    };
    struct KeyHash {
      size_t operator()(const Key& k) const { return hash_combine(hash_combine(k.x, k.y), k.z); }
    };
    std::unordered_map<Key, uint32_t, KeyHash> vertex_ids;
    std::unordered_map<uint64_t, uint32_t> edge_ids;
    auto vertex_id = [&](Vec3f p) {
      const Key k{std::bit_cast<uint32_t>(p.x), std::bit_cast<uint32_t>(p.y), std::bit_cast<uint32_t>(p.z)};
      return vertex_ids.emplace(k, static_cast<uint32_t>(vertex_ids.size())).first->second;
    };
    for (const RasterTriangle& t : triangles_.list) {
      if (!(t.opacity > 0)) continue;
      const Vec3f n = cross(t.p[1] - t.p[0], t.p[2] - t.p[0]);
      const uint32_t id[3] = {vertex_id(t.p[0]), vertex_id(t.p[1]), vertex_id(t.p[2])};
      for (int i = 0; i < 3; ++i) {
        const uint32_t a = id[i], b = id[(i + 1) % 3];
        const uint64_t key = (static_cast<uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
        auto [it, fresh] = edge_ids.emplace(key, static_cast<uint32_t>(edges_.size()));
        if (fresh) edges_.push_back({t.p[i], t.p[(i + 1) % 3], {n, n}, 0});
        SilhouetteEdge& e = edges_[it->second];
        if (e.faces < 2) e.normal[e.faces] = n;
        e.faces++;
      }
    }
  }

  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override {
    const AreaLight& light = *ctx.light;
    const Scene& scene = *ctx.scene;
    const int n = ctx.light_samples;
    std::fill(out.visibility.begin(), out.visibility.end(), 0.0f);
    afsm::LightSamples samples;
    {
      ScopedPhase phase(stats_, "lut");
      samples = afsm::make_light_samples(light, n, ctx.seed, ctx.light_index, ctx.frame);
      const int bins = use_lut_ ? lut_resolution_ : 0;
      lut_.emplace(samples.local, bins, bins);
    }
    const afsm::PlaneMaskLut& lut = *lut_;
    const afsm::SampleGrid grid(samples.local);
    // Above this many cells under a projected triangle, its masks are cheaper.
    const int max_grid_cells = std::max(16, grid.cells_x() * grid.cells_x() / 4);
    const int words = lut.words();
    const float R = samples.radius;
    const Vec3f c = samples.center, ls = samples.s * R, lt = samples.t * R;

    // §4.2: per-pixel rotation of the pattern for symmetric lights (disk, sphere): rotating
    // the samples by alpha equals rotating each plane's line by -alpha. A rect's or an
    // ellipsoid's samples (on its central ellipse) would leave the light: no rotation.
    const bool jitter = jitter_ && (light.shape == LightShape::Disk || light.shape == LightShape::Sphere);
    auto rotation_of = [&](const ViewSample& s) {
      const float a = 2 * kPi * Rng(ctx.seed, 0x4a495454u + ctx.light_index, s.pixel, ctx.frame).next_float();
      return Vec2f{std::cos(a), std::sin(a)};
    };

    std::vector<uint32_t> ids;
    for (size_t k = 0; k < vs.size(); ++k)
      if (in_front_of_light(light, vs.samples[k].p)) ids.push_back(static_cast<uint32_t>(k));
    // What is listed: the view samples at the origins their shadow rays start from. A shadow ray
    // leaves its surface to the side its light point lies on (ray_shared.h leaves_front). On a
    // closed mesh that is outside for every point it can see (the others, behind the tangent
    // plane, start blocked: below); on an open surface whose own plane leaves every light
    // sample on one side, that side. An open surface whose plane cuts the samples (a thin
    // two-sided leaf lit partly from behind) sees each light sample from the sample's side: it
    // is listed twice, at its front origin for the light samples in front of it and at its back
    // origin for the others, each entry's mask starting with the other side's bits set (not
    // counted: ignored below). Only these receivers pay for the split.
    std::vector<ListEntry> entries;
    std::vector<uint64_t> front_masks;  // per split sample: its light samples in front (words)
    // Entries no list holds (outside the fitted window, which max_fov caps, or before its near
    // plane: a receiver beside a light that shines through a window, almost in the light's plane)
    // are decided by rays: `unlisted` (an entry index each) gets, per view sample, the light its
    // entries' side loses along the segments to the same N light points (shadow_ray_to, as
    // embree_to_points and the partial casters' rays), so V stays exact there too. Without a ray
    // tracer they count as lit, as outside a shadow map.
    uint64_t unlisted_rays = 0;
    auto trace_unlisted = [&](std::span<const uint32_t> unlisted, std::span<float> lost) {
      if (!ctx.tracer || unlisted.empty()) return;
      std::vector<float> entry_lost(unlisted.size(), 0.0f);
      std::atomic<uint64_t> traced{0};
      parallel_for(unlisted.size(), 16, [&](size_t begin, size_t end) {
        std::vector<Vec3f> points;
        std::vector<ShadowRay> rays;
        std::vector<float> transmitted;
        for (size_t u = begin; u < end; ++u) {
          const ListEntry& e = entries[unlisted[u]];
          const ViewSample& s = vs.samples[e.sample];
          const Vec2f rot = jitter ? rotation_of(s) : Vec2f{1, 0};
          // A split sample's entry sees the light samples on its own side only.
          const uint64_t* front =
              e.split != kWhole ? front_masks.data() + static_cast<size_t>(e.split) * words : nullptr;
          points.clear();
          for (int k = 0; k < n; ++k) {
            if (front && (((front[k >> 6] >> (k & 63)) & 1) != 0) != e.front) continue;
            points.push_back(jitter ? light_point(samples, k, rot) : samples.points[k]);
          }
          entry_lost[u] = light_lost(*ctx.tracer, s, points, rays, transmitted);
          traced += points.size();
        }
      });
      for (size_t u = 0; u < unlisted.size(); ++u) lost[entries[unlisted[u]].sample] += entry_lost[u];
      unlisted_rays += traced;
    };
    {
      ScopedPhase phase(stats_, "sides");
      // Which light samples the ray from view sample s leaves toward on its front side (into f,
      // when given); returns how many.
      auto front_samples = [&](const ViewSample& s, uint64_t* f) {
        const Vec3f n_unit = shader::offset_normal(s.ng);
        const Vec2f rot = jitter ? rotation_of(s) : Vec2f{1, 0};
        int in_front = 0;
        for (int k = 0; k < n; ++k) {
          const Vec3f q = jitter ? light_point(samples, k, rot) : samples.points[k];
          if (!shader::leaves_front(n_unit, q - s.p)) continue;
          if (f) f[k >> 6] |= 1ull << (k & 63);
          ++in_front;
        }
        return in_front;
      };
      std::vector<uint8_t> side(ids.size());  // kFront, kBack or kBoth
      parallel_for(ids.size(), 256, [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) {
          const ViewSample& s = vs.samples[ids[i]];
          if (scene.objects[s.object].closed) {
            side[i] = kFront;
            continue;
          }
          // (The disk test does not depend on the pattern's rotation.)
          const int disk = lut.side_of_disk({dot(s.ng, ls), dot(s.ng, lt)}, dot(s.ng, c - s.p));
          if (disk != 0) {
            side[i] = disk > 0 ? kFront : kBack;
            continue;
          }
          // The plane may cut the samples: each light point's side, as its ray decides it.
          const int in_front = front_samples(s, nullptr);
          side[i] = in_front == n ? kFront : in_front == 0 ? kBack : kBoth;
        }
      });
      std::vector<Vec3f> points;
      std::vector<uint32_t> entry_ids;
      entries.reserve(ids.size());
      for (size_t i = 0; i < ids.size(); ++i) {
        const ViewSample& s = vs.samples[ids[i]];
        const uint32_t split = side[i] == kBoth ? static_cast<uint32_t>(front_masks.size() / words) : kWhole;
        if (split != kWhole) {
          front_masks.resize(front_masks.size() + words, 0);
          front_samples(s, front_masks.data() + front_masks.size() - words);
        }
        for (bool f : {true, false}) {
          if (side[i] != kBoth && side[i] != (f ? kFront : kBack)) continue;
          entry_ids.push_back(static_cast<uint32_t>(entries.size()));
          entries.push_back({ids[i], split, f});
          points.push_back(ray_origin(s, f));
        }
      }
      stats_.extra["split_samples"] = front_masks.size() / words;
      if (!build_lists(points, entry_ids, light)) {
        // None listed: every entry's rays decide.
        std::vector<float> lost(vs.size(), 0.0f);
        trace_unlisted(entry_ids, lost);
        for (uint32_t id : ids) out.visibility[id] = std::max(0.0f, 1.0f - lost[id] / static_cast<float>(n));
        stats_.extra["unlisted_rays"] = unlisted_rays;
        if (ctx.progress) ctx.progress->add(vs.size());
        return;
      }
    }
    // §4.3 "Parametrization", per slab of depth: each slab's regions end at its own far plane.
    // From here on slots are the slabs' (slab-major); lists_ keeps its own order.
    afsm::DepthSlabs slabs;
    {
      ScopedPhase phase(stats_, "slabs");
      std::vector<float> depth(lists_.slots());
      for (size_t slot = 0; slot < depth.size(); ++slot) depth[slot] = view_.linear_depth(lists_.positions[slot]);
      slabs = afsm::split_by_depth(lists_, depth, slabs_);
    }
    const size_t slots = slabs.slots();

    std::vector<Vec2f> rotation(jitter ? slots : 0);
    // The per-slot masks of blocked light samples, apart from the positions (§3.1).
    std::vector<uint64_t> blocked(slots * words, 0);
    // Per slot: how many of its set bits are the other side's samples of a split sample (set
    // from the start, not counted).
    std::vector<uint16_t> ignored(slots, 0);
    // Slots settled: every light sample blocked (no test can add one), or V known otherwise
    // (silhouettes=true, away from every silhouette edge); and slots whose own tangent plane
    // cuts the light (their V is not the centre's even away from every silhouette edge).
    // (settled is padded to whole SIMD vectors for pair_filter.)
    std::vector<uint32_t> settled(slots + afsm::kPairPadding, 0);
    std::vector<uint8_t> own_plane_cuts(slots, 0);
    {
      ScopedPhase phase(stats_, "init");
      parallel_for(slots, 1024, [&](size_t begin, size_t end) {
        for (size_t slot = begin; slot < end; ++slot) {
          const ListEntry& e = entries[slabs.sample[slot]];
          const ViewSample& s = vs.samples[e.sample];
          if (jitter) rotation[slot] = rotation_of(s);
          Vec2f g{dot(s.ng, ls), dot(s.ng, lt)};
          if (jitter) g = rotate(g, rotation[slot]);
          const float h = dot(s.ng, c - s.p);
          own_plane_cuts[slot] = e.split != kWhole || lut.side_of_disk(g, h) == 0;
          uint64_t* m = blocked.data() + slot * words;
          if (e.split != kWhole) {
            // One side of a split sample: the other side's light samples are the other entry's.
            const uint64_t* f = front_masks.data() + static_cast<size_t>(e.split) * words;
            int count = 0;
            for (int w = 0; w < words; ++w) count += std::popcount(m[w] = (e.front ? ~f[w] : f[w]) & lut.all()[w]);
            ignored[slot] = static_cast<uint16_t>(count);
            continue;
          }
          // A sample on a closed mesh sees nothing behind its own tangent plane (the shadow
          // ray would start inside the object): those bits start blocked.
          if (!scene.objects[s.object].closed) continue;
          lut.exact(g, h, m);
          uint64_t left = 0;
          for (int w = 0; w < words; ++w) left |= (m[w] = ~m[w] & lut.all()[w]) ^ lut.all()[w];
          settled[slot] = left == 0;
        }
      });
    }

    // The casters (every triangle: which side faces which light sample differs per sample)
    // and their influence regions (§4.1).
    std::vector<Caster> casters;
    std::vector<float> caster_near;  // per caster: its nearest vertex's depth from the light
    std::vector<uint8_t> stencil;    // silhouette edges' regions (empty: no restriction)
    std::vector<uint64_t> support_masks;
    // Groups of consecutive casters of one object (a mesh's triangles in file order lie close
    // together) with their bounds and nearest depth: a group whose bounding box's region
    // covers no list of a slab is skipped whole there (issue 34 part 3: cost that follows the
    // casters that matter), before any of its casters' own regions is made.
    struct CasterRun {
      size_t begin, end;
      Bounds3f bounds;
      float near;
    };
    std::vector<CasterRun> runs;
    uint64_t front_facing = 0, runs_culled = 0, partial_casters = 0;
    // Per slab: the casters' regions on its far plane, and which caster each region is.
    std::vector<ConvexPolygons> regions(slabs.count);
    std::vector<std::vector<uint32_t>> region_caster(slabs.count);
    uint64_t skipped = 0, unbounded = 0;
    float far_depth = 0;
    for (const Vec3f& p : slabs.positions) far_depth = std::max(far_depth, view_.linear_depth(p));
    far_depth = far_depth * (1 + 1e-4f) + 1e-6f;
    const Vec2f whole[4] = {{0, 0}, {float(view_.width()), 0}, {float(view_.width()), float(view_.height())},
                            {0, float(view_.height())}};
    {
      ScopedPhase phase(stats_, "casters");
      casters.reserve(triangles_.list.size());  // at most every triangle: one allocation
      caster_near.reserve(triangles_.list.size());
      std::vector<uint64_t> behind(words);
      uint32_t run_object = ~0u;
      for (const RasterTriangle& t : triangles_.list) {
        if (!(t.opacity > 0)) continue;
        // A triangle entirely on or behind the light's sample plane blocks nothing in front of it
        // (a ceiling flush with the light: trace/ray_shared.h on_or_behind_light_plane).
        const float z0 = view_.linear_depth(t.p[0]), z1 = view_.linear_depth(t.p[1]), z2 = view_.linear_depth(t.p[2]);
        if (shader::on_or_behind_light_plane(z0, t.p[0]) && shader::on_or_behind_light_plane(z1, t.p[1]) &&
            shader::on_or_behind_light_plane(z2, t.p[2]))
          continue;
        Caster cs;
        for (int i = 0; i < 3; ++i) cs.v[i] = t.p[i];
        cs.normal = cross(t.p[1] - t.p[0], t.p[2] - t.p[0]);
        cs.normal_len = length(cs.normal);
        cs.support_g = {dot(cs.normal, ls), dot(cs.normal, lt)};
        cs.support_h = dot(cs.normal, c - t.p[0]);
        cs.closed = scene.objects[t.object].closed;
        if (triangles_.textures.textured(t)) cs.textured = &t;
        cs.partial = ctx.tracer && triangles_.textures.semi_transparent(t);
        partial_casters += cs.partial;
        if (cs.closed) {
          // A closed mesh's triangle casts only toward the light samples behind it (it faces
          // away from them), whatever p: that set is p's supporting-plane mask, computed once.
          // None behind: it never casts (conservative back-face culling, §4.3 after [ED07]).
          // With per-pixel rotation the mask is rotated per sample: only the rotation-
          // invariant test (the samples' disk against the plane) is done here.
          bool casts;
          if (jitter) {
            const float len = std::sqrt(dot(cs.support_g, cs.support_g));
            casts = cs.support_h < len * 1.0001f;
          } else {
            lut.mask(cs.support_g * -1.0f, -cs.support_h, behind.data());
            uint64_t any = 0;
            for (uint64_t w : behind) any |= w;
            casts = any != 0;
          }
          if (!casts) {
            front_facing++;
            continue;
          }
          if (!jitter) {
            cs.support_mask = support_masks.size() / words;
            support_masks.insert(support_masks.end(), behind.begin(), behind.end());
          }
        }
        if (runs.empty() || t.object != run_object || runs.back().end - runs.back().begin == kCasterRun) {
          runs.push_back({casters.size(), casters.size(), Bounds3f{}, kInfinity});
          run_object = t.object;
        }
        casters.push_back(cs);
        caster_near.push_back(std::min({z0, z1, z2}));
        CasterRun& run = runs.back();
        run.end = casters.size();
        for (int i = 0; i < 3; ++i) run.bounds.extend(t.p[i]);
        run.near = std::min(run.near, caster_near.back());
      }
    }
    // Casters that stop only part of the light (semi-transparent, alpha blend) have no bit to set:
    // the fraction they let through depends on every such surface a segment crosses. Per slot, the
    // light samples they cover are marked here (the same tests as a blocking caster's), and each
    // marked sample no opaque caster blocks gets the ray tracer's transmittance along its segment
    // at the end: the reference's estimator for the same light points (ssv-rt does the same).
    // Without a ray tracer (a bare context) they block, as the paper's opaque casters.
    std::vector<uint64_t> partial(partial_casters > 0 ? slots * words : 0, 0);
    // Slab k's regions on its own far plane (§4.1); a caster wholly deeper than every sample of
    // the slab shadows none of its samples. Computed in parallel, kept in caster order; made for a
    // group of slabs just before their raster pass and dropped after it (below).
    auto slab_regions = [&](int k) {
      const afsm::InfluenceRegions influence(light, view_, slabs.far[k]);
      // Per run, the regions of its casters that are kept, in caster order (kUnbounded: the
      // whole image): only what is kept is stored, so a wide scene's millions of casters whose
      // regions cover no list cost no memory here.
      constexpr uint8_t kUnbounded = 255;
      struct RunRegions {
        std::vector<Vec2f> vertices;
        std::vector<uint8_t> sizes;
        std::vector<uint32_t> casters;
      };
      std::vector<RunRegions> kept(runs.size());
      auto to_int = [](float f) { return static_cast<int>(std::clamp(f, -1e9f, 1e9f)); };
      // Whether no list of slab k lies within the texel rectangle around `polygon` (grown by
      // `margin` texels each way).
      auto covers_no_list = [&](const std::vector<Vec2f>& polygon, int margin) {
        float x0 = kInfinity, y0 = kInfinity, x1 = -kInfinity, y1 = -kInfinity;
        for (Vec2f q : polygon) {
          x0 = std::min(x0, q.x), y0 = std::min(y0, q.y), x1 = std::max(x1, q.x), y1 = std::max(y1, q.y);
        }
        return slabs.count_in(k, to_int(std::floor(x0)) - margin, to_int(std::floor(y0)) - margin,
                              to_int(std::floor(x1)) + 1 + margin, to_int(std::floor(y1)) + 1 + margin) == 0;
      };
      std::atomic<uint64_t> culled{0};
      parallel_for(runs.size(), 4, [&](size_t run_begin, size_t run_end) {
        std::vector<Vec2f> polygon;
        for (size_t r = run_begin; r < run_end; ++r) {
          const CasterRun& run = runs[r];
          if (!(run.near < slabs.far[k])) continue;  // every caster of the run is deeper than the slab
          if (restrict_ && run.end - run.begin > 1) {
            // The region of the run's box holds each of its casters' regions; a margin of a
            // texel more than theirs below keeps the rounding of the two projections apart.
            Vec3f corners[8];
            for (int c = 0; c < 8; ++c) corners[c] = run.bounds.corner(c);
            if (influence.project(std::span<const Vec3f>(corners, 8), &polygon) && covers_no_list(polygon, 2)) {
              culled++;
              continue;
            }
          }
          RunRegions& out = kept[r];
          for (size_t i = run.begin; i < run.end; ++i) {
            if (!(caster_near[i] < slabs.far[k])) continue;
            if (!influence.project(std::span<const Vec3f>(casters[i].v, 3), &polygon)) {
              out.sizes.push_back(kUnbounded);
              out.casters.push_back(static_cast<uint32_t>(i));
              continue;
            }
            // §4.3: a caster whose region covers no list (of this slab) does nothing. (The
            // projected points' bounding box is the region's: the hull only for those kept.)
            if (restrict_ && covers_no_list(polygon, 1)) continue;
            afsm::convex_hull(&polygon);
            out.sizes.push_back(static_cast<uint8_t>(polygon.size()));
            out.casters.push_back(static_cast<uint32_t>(i));
            out.vertices.insert(out.vertices.end(), polygon.begin(), polygon.end());
          }
        }
      });
      runs_culled += culled.load();
      size_t regions_kept = 0;
      for (RunRegions& out : kept) {
        const Vec2f* vertices = out.vertices.data();
        for (size_t j = 0; j < out.sizes.size(); ++j) {
          if (out.sizes[j] == kUnbounded) {
            regions[k].add(whole);
            unbounded++;
          } else {
            regions[k].add(std::span<const Vec2f>(vertices, out.sizes[j]));
            vertices += out.sizes[j];
          }
          region_caster[k].push_back(out.casters[j]);
        }
        regions_kept += out.sizes.size();
        out = RunRegions{};
      }
      skipped += casters.size() - regions_kept;
    };
    {
      ScopedPhase phase(stats_, "regions");
      if (restrict_) slabs.build_summed_areas();
      // §4.3: penumbrae are cast only by silhouette edges (an edge whose two faces do not
      // face the same way for every point of the light's disk, or a boundary edge). A sample
      // outside every silhouette edge's influence region sees all the light or none of it:
      // its V is the centre's (a hard shadow bit), unless its own plane cuts the light.
      if (silhouettes_) {
        const afsm::InfluenceRegions influence(light, view_, far_depth);
        std::vector<Vec2f> polygon;
        ConvexPolygons edge_regions;
        for (const SilhouetteEdge& e : edges_) {
          bool silhouette = e.faces != 2;
          if (!silhouette) {
            int side[2];
            for (int f = 0; f < 2; ++f)
              side[f] = lut.side_of_disk({dot(e.normal[f], ls), dot(e.normal[f], lt)}, dot(e.normal[f], c - e.a));
            silhouette = side[0] == 0 || side[1] == 0 || side[0] != side[1];
          }
          if (!silhouette) continue;
          if (view_.linear_depth(e.a) <= 0 && view_.linear_depth(e.b) <= 0) continue;
          const Vec3f v[3] = {e.a, e.b, e.b};
          if (!influence.region(v, &polygon)) polygon.assign(whole, whole + 4);
          edge_regions.add(polygon);
        }
        // The edges of an alpha mask's holes cast penumbrae anywhere inside an alpha-textured
        // triangle (issue 20): its whole region is away from no silhouette.
        // So do the casters that stop part of the light: their rays decide (below).
        for (const Caster& cs : casters) {
          if (!cs.textured && !cs.partial) continue;
          if (!influence.region(cs.v, &polygon)) polygon.assign(whole, whole + 4);
          edge_regions.add(polygon);
        }
        stats_.extra["silhouette_edges"] = edge_regions.size();
        stats_.extra["edges"] = edges_.size();
        stencil.assign(static_cast<size_t>(view_.width()) * view_.height(), 0);
        rasterizer_.polygons(edge_regions, view_.width(), view_.height(),
                             [&](int x, int y, uint32_t) { stencil[lists_.texel(x, y)] = 1; });
      }
    }

    Counters center_counters;
    size_t center_memory = 0;
    if (silhouettes_) {
      // Away from every silhouette edge: all of the light or none, as the centre (its hard
      // shadow bit, afsm-hard's pass over the lists in their own order); those slots settle.
      // (Slots only partial casters cover lie in their regions, which the stencil holds.)
      const std::vector<uint8_t> center =
          center_shadow(scene, c, partial_casters > 0, &center_counters, &center_memory);
      uint64_t hard = 0;
      for (int k = 0; k < slabs.count; ++k)
        for (size_t texel = 0; texel < slabs.texels; ++texel) {
          if (stencil[texel]) continue;
          for (uint32_t slot = slabs.begin(k, texel); slot < slabs.end(k, texel); ++slot) {
            if (own_plane_cuts[slot]) continue;
            settled[slot] = 1;
            if (center[slabs.list_slot[slot]] != kCenterBlocked) continue;
            std::copy_n(lut.all(), words, blocked.data() + static_cast<size_t>(slot) * words);
            ++hard;
          }
        }
      stats_.extra["hard_shadowed_samples"] = hard;
    }
    // The same in the form pair_filter takes: samples as padded arrays, casters set up once.
    std::vector<float> sample_x(slots + afsm::kPairPadding, 0), sample_y(sample_x), sample_z(sample_x);
    std::vector<float> rot_c(jitter ? slots + afsm::kPairPadding : 0), rot_s(rot_c);
    for (size_t slot = 0; slot < slots; ++slot) {
      const Vec3f p = slabs.positions[slot];
      sample_x[slot] = p.x, sample_y[slot] = p.y, sample_z[slot] = p.z;
      if (jitter) rot_c[slot] = rotation[slot].x, rot_s[slot] = rotation[slot].y;
    }
    const afsm::PairSamples pair_samples{sample_x.data(), sample_y.data(), sample_z.data(), settled.data(),
                                         jitter ? rot_c.data() : nullptr, jitter ? rot_s.data() : nullptr};
    const afsm::PairLight pair_light{{c.x, c.y, c.z}, {ls.x, ls.y, ls.z},   {lt.x, lt.y, lt.z},
                                     lut.max_distance2(), grid.geometry(), max_grid_cells, &grid};
    std::vector<afsm::PairCaster> pair_casters(casters.size());
    for (size_t i = 0; i < casters.size(); ++i) {
      const Caster& t = casters[i];
      afsm::PairCaster& pc = pair_casters[i];
      for (int k = 0; k < 3; ++k) {
        const Vec3f d = t.v[(k + 1) % 3] - t.v[k];
        for (int j = 0; j < 3; ++j) pc.v[k][j] = t.v[k][j], pc.d[k][j] = d[j];
      }
      for (int j = 0; j < 3; ++j) pc.normal[j] = t.normal[j];
      // p (almost) in the triangle's plane sees it edge-on: the cone from p over it is flat and
      // its edge planes are rounding noise, so it casts nothing (a segment from p crosses that
      // plane next to p, away from the triangle, unless p touches it).
      pc.flat_scale = kFlat * kFlat * t.normal_len * t.normal_len;
      // A closed mesh blocks a light sample only with the triangles facing away from it (§3.3
      // per light sample): those with p in front. An open one blocks from either side.
      pc.closed = t.closed;
    }
    tbb::enumerable_thread_specific<Counters> counters;
    size_t region_bytes = 0;  // the most the regions of one group of slabs held
    {
      // The (listed sample, caster) test of §4.2 for the slots [begin, end): the SIMD part
      // (pair_filter.h) settles most pairs; the rest are decided here.
      tbb::enumerable_thread_specific<std::vector<afsm::PairSurvivor>> survivor_buffers;
      const TriangleTextures& textures = triangles_.textures;
      auto test = [&](Counters& cnt, uint32_t begin, uint32_t end, uint32_t caster) {
        const Caster& t = casters[caster];
        std::vector<afsm::PairSurvivor>& survivors = survivor_buffers.local();
        if (survivors.size() < end - begin) survivors.resize(end - begin);
        size_t tested = 0;
        const size_t count =
            afsm::filter_pairs(pair_light, pair_casters[caster], pair_samples, begin, end, survivors.data(), &tested);
        cnt.sample_tests += tested;
        uint64_t hidden[afsm::kMaxLightSamples / 64], edge[afsm::kMaxLightSamples / 64];
        for (size_t j = 0; j < count; ++j) {
          const uint32_t slot = survivors[j].slot;
          const float side = survivors[j].side;
          const afsm::Line* edges = survivors[j].edges;
          uint64_t* m = blocked.data() + static_cast<size_t>(slot) * words;
          // A caster that stops part of the light marks the samples it covers (the rays decide).
          uint64_t* pm = t.partial ? partial.data() + static_cast<size_t>(slot) * words : nullptr;
          const Vec2f rot = jitter ? rotation[slot] : Vec2f{1, 0};
          // Behind the supporting plane as seen from p: the other side.
          const float sign = side > 0 ? -1.0f : 1.0f;
          const bool support_known = t.closed && !jitter;
          const uint64_t* support = support_masks.data() + t.support_mask * words;
          const afsm::Line behind{rotate(t.support_g * sign, rot), t.support_h * sign};
          afsm::SampleGrid::Range cells{survivors[j].x0, survivors[j].y0, survivors[j].x1, survivors[j].y1};
          bool on_grid = survivors[j].on_grid;
          // An alpha-textured caster (issue 20) hides the light samples the whole triangle
          // hides, less those whose segment from p meets it in a hole of its mask: the
          // crossings from p are set up once for the pair, when the first sample needs one.
          const Vec3f p = slabs.positions[slot];
          std::optional<TriangleLines> lines;
          auto solid = [&](int i) {
            if (!lines) lines.emplace(*t.textured, p);
            return textures.opacity_on_line(*t.textured, *lines, light_point(samples, i, rot) - p) > 0;
          };
          if (!on_grid) {
            // Not decided in float (lines nearly parallel, or a big triangle): in double.
            int cutting = 0;
            for (int i = 0; i < 3; ++i) cutting += lut.side_of_disk(edges[i].g, edges[i].h) == 0;
            on_grid = cutting == 3 && grid.triangle_cells(edges, max_grid_cells, &cells);
          }
          if (on_grid) {
            // The triangle projects onto the light as a small triangle: test the samples of
            // the cells under its bounding box, each exactly as the masks would (same bits).
            cnt.grid_pairs++;
            bool added = false;
            uint64_t candidates = 0;
            for (int y = cells.y0; y <= cells.y1; ++y) candidates += grid.row_end(y, cells.x1) - grid.row_begin(y, cells.x0);
            // Inside the three edge planes (SIMD over the cells' samples where there are
            // many), then behind the caster, then not yet blocked.
            uint32_t inside[afsm::kMaxLightSamples];
            size_t inside_count = 0;
            if (candidates > 2) {
              inside_count = afsm::inside_cells(grid, cells, edges, inside);
            } else {
              for (int y = cells.y0; y <= cells.y1; ++y)
                for (uint32_t k = grid.row_begin(y, cells.x0), k_end = grid.row_end(y, cells.x1); k < k_end; ++k) {
                  const float ux = grid.x()[k], uy = grid.y()[k];
                  // All three tests, without branches between them (bitwise, not &&).
                  const unsigned in_all = static_cast<unsigned>(afsm::above(ux, uy, edges[0].g, edges[0].h)) &
                                          static_cast<unsigned>(afsm::above(ux, uy, edges[1].g, edges[1].h)) &
                                          static_cast<unsigned>(afsm::above(ux, uy, edges[2].g, edges[2].h));
                  if (in_all) inside[inside_count++] = k;
                }
            }
            for (size_t q = 0; q < inside_count; ++q) {
              const uint32_t k = inside[q];
              const uint32_t i = grid.index()[k];
              const uint64_t bit = 1ull << (i & 63);
              if (support_known ? !(support[i >> 6] & bit)
                                : !afsm::above(grid.x()[k], grid.y()[k], behind.g, behind.h))
                continue;
              if (m[i >> 6] & bit) continue;
              if (pm)
                pm[i >> 6] |= bit;
              else if (!t.textured || solid(static_cast<int>(i))) {
                m[i >> 6] |= bit;
                added = true;
              }
            }
            cnt.grid_tests += candidates;
            if (added) {
              uint64_t missing = 0;
              for (int w = 0; w < words; ++w) missing |= lut.all()[w] & ~m[w];
              settled[slot] = missing == 0;
            }
            continue;
          }
          // Otherwise the masks of §4.2: the supporting plane's, then AND each cutting edge's.
          if (support_known) {
            std::copy_n(support, words, hidden);
          } else {
            cnt.exact_bits += lut.mask(behind.g, behind.h, hidden);
            cnt.plane_lookups++;
          }
          uint64_t fresh = 0;
          for (int w = 0; w < words; ++w) fresh |= hidden[w] & ~m[w] & (pm ? ~pm[w] : ~0ull);
          if (!fresh) continue;  // nothing this caster could add
          bool any = true;
          for (int i = 0; i < 3 && any; ++i) {
            if (lut.side_of_disk(edges[i].g, edges[i].h) != 0) continue;  // the whole light inside
            cnt.exact_bits += lut.mask(edges[i].g, edges[i].h, edge);
            cnt.plane_lookups++;
            uint64_t left = 0;
            for (int w = 0; w < words; ++w) left |= (hidden[w] &= edge[w]);
            any = left != 0;
          }
          // The samples the whole triangle hides; an alpha-textured one hides those whose segment
          // from p meets it inside its mask.
          if (any && pm) {
            for (int w = 0; w < words; ++w) pm[w] |= hidden[w] & ~m[w];
            continue;
          }
          if (any && t.textured) {
            uint64_t left = 0;
            for (int w = 0; w < words; ++w) {
              uint64_t bits = hidden[w] & ~m[w];
              for (uint64_t rest = bits; rest; rest &= rest - 1)
                if (!solid(64 * w + std::countr_zero(rest))) bits &= ~(rest & -rest);
              left |= (hidden[w] = bits);
            }
            any = left != 0;
          }
          if (any) {
            uint64_t missing = 0;
            for (int w = 0; w < words; ++w) missing |= lut.all()[w] & ~(m[w] |= hidden[w]);
            settled[slot] = missing == 0;
          }
        }
      };
      // The slabs' slots are disjoint: a group of slabs (slab_group) runs at once (each its own
      // rasterizer, each parallel over its tiles), which keeps the cores busy
      // where one slab's samples sit in a few tiles. A group's regions are made just before its
      // pass and dropped after it: a wide scene's casters have regions in every slab (the
      // 100-tree forest's 5.9 M triangles, 2.6 GiB of them a slab), and only one group's are
      // held at a time. The result is the same: a sample's mask is the OR over the casters.
      // Per texel the order of the casters stays the rasterizer's.
      if (slab_rasterizers_.size() < static_cast<size_t>(slabs.count)) slab_rasterizers_.resize(slabs.count);
      for (auto& r : slab_rasterizers_)
        if (!r) r = std::make_unique<ConservativeRasterizer>(kSlabTile);
      const int group = slab_group(slabs.count);
      for (int first = 0; first < slabs.count; first += group) {
        const int last = std::min(slabs.count, first + group);
        {
          ScopedPhase phase(stats_, "regions");
          for (int k = first; k < last; ++k) slab_regions(k);
        }
        {
          ScopedPhase phase(stats_, "raster");
          parallel_for(static_cast<size_t>(last - first), 1, [&](size_t slab_begin, size_t slab_end) {
            for (size_t slab_index = slab_begin; slab_index < slab_end; ++slab_index) {
              const int slab = first + static_cast<int>(slab_index);
              const std::vector<uint32_t>& caster_of = region_caster[slab];
              slab_rasterizers_[slab]->polygon_spans(regions[slab], view_.width(), view_.height(),
                                                     [&](int y, int x0, int x1, uint32_t index) {
                // The samples of slab `slab` in texels [x0, x1) of row y are one range of slots.
                const uint32_t begin = slabs.begin(slab, lists_.texel(x0, y)),
                               end = slabs.end(slab, lists_.texel(x1 - 1, y));
                Counters& cnt = counters.local();
                cnt.texel_visits += x1 - x0;
                if (begin == end) {
                  cnt.empty_visits += x1 - x0;
                  return;
                }
                test(cnt, begin, end, caster_of[index]);
              });
            }
          });
        }
        size_t bytes = 0;
        for (int k = first; k < last; ++k) {
          bytes += regions[k].vertices.size() * sizeof(Vec2f) + region_caster[k].size() * sizeof(uint32_t);
          regions[k] = ConvexPolygons{};
          region_caster[k] = std::vector<uint32_t>{};
        }
        region_bytes = std::max(region_bytes, bytes);
      }
    }
    std::vector<uint16_t> blocked_count(vs.size(), 0);  // per view sample, over its entries
    // Per slot: the light its marked samples lose to the casters that stop part of it, 1 -
    // transmittance summed over them (the rays from the view sample, shadow_ray_to, as `reference`
    // and embree_to_points trace them; a split sample's side by its light point, as its entry).
    std::vector<float> attenuated(partial.empty() ? 0 : slots, 0.0f);
    uint64_t partial_rays = 0;
    {
      ScopedPhase phase(stats_, "resolve");
      if (!partial.empty()) {
        std::atomic<uint64_t> rays_traced{0};
        parallel_for(slots, 64, [&](size_t begin, size_t end) {
          std::vector<Vec3f> points;
          std::vector<ShadowRay> rays;
          std::vector<float> transmitted;
          for (size_t slot = begin; slot < end; ++slot) {
            const uint64_t* m = blocked.data() + slot * words;
            const uint64_t* pm = partial.data() + slot * words;
            points.clear();
            for (int w = 0; w < words; ++w)
              for (uint64_t rest = pm[w] & ~m[w]; rest; rest &= rest - 1) {
                const int i = 64 * w + std::countr_zero(rest);
                points.push_back(jitter ? light_point(samples, i, rotation[slot]) : samples.points[i]);
              }
            if (points.empty()) continue;
            const ViewSample& s = vs.samples[entries[slabs.sample[slot]].sample];
            attenuated[slot] = light_lost(*ctx.tracer, s, points, rays, transmitted);
            rays_traced += points.size();
          }
        });
        partial_rays = rays_traced;
      }
      std::vector<float> lost(vs.size(), 0.0f);
      {
        std::vector<uint8_t> listed(entries.size(), 0);
        for (size_t slot = 0; slot < slots; ++slot) listed[slabs.sample[slot]] = 1;
        std::vector<uint32_t> unlisted;
        for (uint32_t e = 0; e < entries.size(); ++e)
          if (!listed[e]) unlisted.push_back(e);
        trace_unlisted(unlisted, lost);
      }
      for (size_t slot = 0; slot < slots; ++slot) {
        const uint64_t* m = blocked.data() + slot * words;
        int count = 0;
        for (int w = 0; w < words; ++w) count += std::popcount(m[w]);
        const uint32_t sample = entries[slabs.sample[slot]].sample;
        blocked_count[sample] += static_cast<uint16_t>(count - ignored[slot]);
        if (!attenuated.empty()) lost[sample] += attenuated[slot];
      }
      const float inv = 1.0f / static_cast<float>(n);
      for (uint32_t id : ids)
        out.visibility[id] = std::max(0.0f, 1.0f - (static_cast<float>(blocked_count[id]) + lost[id]) * inv);
    }
    stats_.extra["partial_casters"] = partial_casters;
    stats_.extra["partial_rays"] = partial_rays;
    stats_.extra["unlisted_rays"] = unlisted_rays;
    Counters total = center_counters;
    for (const Counters& c2 : counters) total.add(c2);
    report(total, casters.size(),
           center_memory + stencil.size() + blocked.size() * sizeof(uint64_t) +
               support_masks.size() * sizeof(uint64_t) + rotation.size() * sizeof(Vec2f) +
               casters.size() * (sizeof(Caster) + sizeof(afsm::PairCaster)) + settled.size() * sizeof(uint32_t) +
               (sample_x.size() * 3 + rot_c.size() * 2) * sizeof(float) + region_bytes + slabs.memory_bytes() +
               lut.memory_bytes() + entries.capacity() * sizeof(ListEntry) + front_masks.capacity() * sizeof(uint64_t) +
               ignored.size() * sizeof(uint16_t) + blocked_count.size() * sizeof(uint16_t) +
               (partial.size() * sizeof(uint64_t) + attenuated.size() * sizeof(float)));
    stats_.extra["light_samples"] = n;
    stats_.extra["casters_skipped"] = skipped;
    stats_.extra["caster_runs"] = runs.size() * static_cast<size_t>(slabs.count);
    stats_.extra["caster_runs_culled"] = runs_culled;
    stats_.extra["casters_facing_the_whole_light"] = front_facing;
    stats_.extra["unbounded_regions"] = unbounded;
    stats_.extra["depth_slabs"] = slabs.count;
    stats_.extra["plane_lookups"] = total.plane_lookups;
    stats_.extra["exact_sample_tests"] = total.exact_bits;
    stats_.extra["grid_pairs"] = total.grid_pairs;
    stats_.extra["grid_sample_tests"] = total.grid_tests;
    stats_.extra["lut_bytes"] = lut.memory_bytes();
    if (ctx.progress) ctx.progress->add(vs.size());
  }

 private:
  // How many of `slabs` depth slabs are rasterized at once, their regions held together: two
  // (both cores of the development machine; each slab's pass is parallel over its tiles besides).
  // Fixed, not the thread count, so that the memory a render holds and reports is the same on
  // every machine (a comparison split over a cluster's workers checks it is).
  static constexpr int kSlabsAtOnce = 2;
  static int slab_group(int slabs) { return std::clamp(kSlabsAtOnce, 1, std::max(1, slabs)); }
  // Casters per run of the regions' culling: the run's box must be small against the lists'
  // gaps to cull anything, and each kept run costs one more region (8 corners).
  static constexpr size_t kCasterRun = 128;

  // g rotated by -alpha, (cos alpha, sin alpha) = r.
  static Vec2f rotate(Vec2f g, Vec2f r) { return {r.x * g.x + r.y * g.y, -r.y * g.x + r.x * g.y}; }
  // Light sample k as a world point, the pattern rotated by rot (jitter, §4.2): where the
  // rotated lines of the masks put it.
  static Vec3f light_point(const afsm::LightSamples& samples, int k, Vec2f rot) {
    const Vec2f u = samples.local[k];
    const Vec2f r{rot.x * u.x - rot.y * u.y, rot.y * u.x + rot.x * u.y};
    const Vec3f ls = samples.s * samples.radius, lt = samples.t * samples.radius;
    return samples.center + ls * r.x + lt * r.y;
  }

  // What is listed (evaluate): a view sample whole, or one side of a split one.
  static constexpr uint32_t kWhole = ~0u;
  struct ListEntry {
    uint32_t sample;  // the view sample
    uint32_t split;   // a split sample's index into the front masks, kWhole otherwise
    bool front;       // the side of its surface its origin lies on (a split sample: its light samples')
  };
  static constexpr uint8_t kFront = 1, kBack = 2, kBoth = 3;

  struct Caster {
    Vec3f v[3];
    Vec3f normal;     // cross(v1 - v0, v2 - v0)
    float normal_len;
    Vec2f support_g;  // the supporting plane as a line on the light: g . u + h
    float support_h;
    bool closed;
    size_t support_mask = 0;  // closed, without jitter: index into support_masks
    const RasterTriangle* textured = nullptr;  // an alpha-textured caster's triangle (issue 20)
    // It may stop only part of the light (semi-transparent, or an alpha blend): the light samples
    // it covers are marked, not blocked, and the rays to them decide (`partial`, resolve).
    bool partial = false;
  };

  bool use_lut_;
  int lut_resolution_;
  bool jitter_;
  bool restrict_;
  int slabs_;
  bool silhouettes_;
  std::optional<afsm::PlaneMaskLut> lut_;
  // One rasterizer per depth slab (their passes run at once; 64-texel tiles measured best).
  static constexpr int kSlabTile = 64;
  std::vector<std::unique_ptr<ConservativeRasterizer>> slab_rasterizers_;
  struct SilhouetteEdge {
    Vec3f a, b;
    Vec3f normal[2];  // of its first two faces (winding normals)
    int faces = 0;
  };
  std::vector<SilhouetteEdge> edges_;
};

std::vector<ParamSpec> view_specs() {
  return {
      {"resolution", ParamType::Int, 512,
       "texels along the longer side of the light's image holding the view-sample lists (fitted to the listed "
       "samples, §4.3); affects speed only, never the result",
       {}, 8, 8192},
      {"max_fov", ParamType::Float, 120.0,
       "widest field of view of the light's image (degrees); samples outside it are not listed, and shadow rays decide "
       "them (lit without a ray tracer)",
       {}, 1, 179},
  };
}

const MethodRegistration hard_registration({
    "afsm-hard",
    "alias-free shadow map (sintorn2008 §3): exact hard shadows from the light's centre, view samples listed per "
    "light texel, casters rasterized conservatively",
    view_specs(),
    [](const ParamSet& p) { return std::make_unique<AliasFreeHard>(p); },
    /*samples_light=*/false,
    AliasFreeHard::memory,
    /*tile_exact=*/true,
    // A textured light counts as its mean colour: the light is its centre, size or outline.
    /*uniform_light=*/true,
});

std::vector<ParamSpec> soft_specs() {
  std::vector<ParamSpec> specs = view_specs();
  specs.push_back({"lut", ParamType::Bool, true,
                   "look plane masks up in a table (sure bits from the table, the band of unsure samples tested "
                   "exactly: same result); false: test every light sample exactly",
                   {}});
  specs.push_back({"lut_resolution", ParamType::Int, 128,
                   "table cells along each axis (line angle and distance); more cells, fewer exact tests, more memory",
                   {}, 4, 1024});
  specs.push_back({"jitter", ParamType::Bool, false,
                   "rotate the sample pattern per pixel (disk and sphere lights, §4.2; ignored for rect and "
                   "ellipsoid lights): noise instead of banding",
                   {}});
  specs.push_back({"silhouettes", ParamType::Bool, false,
                   "test light samples only inside silhouette edges' influence regions (§4.3); elsewhere V is the "
                   "light centre's hard shadow (same result). Off by default: with the shipped scenes' large lights "
                   "every listed sample lies in some silhouette edge's region, so it only adds the edge pass",
                   {}});
  specs.push_back({"slabs", ParamType::Int, 8,
                   "depth slabs of the view-sample lists (equal sample counts); each slab's influence regions end "
                   "at its own farthest sample (§4.3 far plane, per slab): smaller regions, same result",
                   {}, 1, 64});
  specs.push_back({"restrict", ParamType::Bool, true,
                   "skip casters whose influence region's bounding box holds no listed sample (§4.3)", {}});
  return specs;
}

const MethodRegistration soft_registration({
    "afsm",
    "sample-based soft visibility (sintorn2008 §4): per view sample a bitmask of --spp (<= 1024) fixed light "
    "samples, exact per sample (sphere and ellipsoid lights: exact against the light's central disk or ellipse, "
    "mean |dV| 0.002 from the reference on the bunny under a sphere light); influence regions rasterized "
    "conservatively",
    soft_specs(),
    [](const ParamSet& p) { return std::make_unique<AliasFreeSoft>(p); },
    /*samples_light=*/true,
    AliasFreeSoft::memory,
});

}  // namespace
}  // namespace penumbra
