// Method `coherent-rt`: coherence-based ray tracing of depth images (agrawala2000 §5), the
// high-quality half of the paper's lighting workflow. prepare() renders a few reference
// depth images of the scene from points on the light (default: its 4 corners) and builds
// their floors-and-walls surfaces, min/max quadtrees and connectedness quadtrees
// (reference_images.h). evaluate() shades the view samples tile by tile, along a Hilbert
// curve inside each tile so consecutive points are close (the coherent order of §5.2), and
// samples each point's light with SoftShad (§5.2, soft_shad.h): only the light cells whose
// visibility the earlier points cannot predict get a shadow ray. Rays go through the depth
// images (depth_image_tracer.h, §5.1) or, with tracer=geometry, through the real geometry
// on Embree (the paper's suggestion that a geometric ray tracer can use the same sampler).
// Irradiance is eq. 1 over the light cells' samples (area sampling). docs/methods/coherent-rt.md
// maps the paper to this code.
#include <mutex>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/sampling.h"
#include "penumbra/raster/raster_triangle.h"
#include "penumbra/raster/rasterizer.h"
#include "penumbra/shadow/coherent_rt/coherent_rt_kernels_shared.h"
#include "penumbra/shadow/coherent_rt/coherent_rt_settings.h"
#include "penumbra/shadow/coherent_rt/depth_image_tracer.h"
#include "penumbra/shadow/coherent_rt/reference_images.h"
#include "penumbra/shadow/coherent_rt/soft_shad.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {
namespace {

using namespace coherent_rt;

class CoherentRayTracing final : public ShadowMethod {
 public:
  explicit CoherentRayTracing(const ParamSet& p) {
    const CoherentRtSettings settings = coherent_rt_settings(p);
    geometry_ = settings.geometry;
    views_ = settings.views;
    image_options_ = settings.images;
    trace_options_ = settings.trace;
    sampling_ = settings.sampling;
    tile_ = settings.tile;
    own_plane_ = settings.own_plane;
    near_field_ = settings.near_field;
    light_field_on_ = settings.light_field;
  }

  bool computes_irradiance() const override { return true; }

  // A sphere light is sampled through its central disk (soft_shad.h sampled_light): both passes
  // run on that disk, and E is the sphere's closed form times V.
  void prepare(const ShadowContext& ctx) override {
    stats_.prepare_count++;
    coherent_rt::check_light(*ctx.light);
    sampled_ = sampled_light(*ctx.light);
    ShadowContext sampled = ctx;
    sampled.light = &sampled_;
    prepare_sampled(sampled);
  }

  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override {
    ShadowContext sampled = ctx;
    sampled.light = &sampled_;  // prepare() set it for this light
    const bool sphere = sphere_emitter(*ctx.light);
    evaluate_sampled(sampled, vs, out, /*sample_irradiance=*/!sphere);
    if (!sphere) return;
    parallel_for(vs.size(), 1024, [&](size_t begin, size_t end) {
      for (size_t k = begin; k < end; ++k)
        out.irradiance[k] = ctx.light->unshadowed_irradiance(vs.samples[k].p, vs.samples[k].ns) * out.visibility[k];
    });
  }

 private:
  void prepare_sampled(const ShadowContext& ctx) {
    images_.clear();
    extra_ = nlohmann::json::object();
    light_field_ = 0;
    if (geometry_) return;
    const ShadowRegion region = fit_shadow_region(*ctx.scene, *ctx.light);
    if (light_field_on_) light_field_ = region.light_field;
    if (region.empty) {  // no image: nothing blocks a ray (reference_view)
      extra_["views"] = nlohmann::json::array();
      memory_bytes_ = 0;
      return;
    }
    ScopedPhase phase(stats_, "precompute");
    Timer t_gather;
    const RasterTriangles tris = gather_raster_triangles(*ctx.scene);
    const double gather_ms = t_gather.elapsed_ms();
    BuildTimes times;
    const std::vector<uint8_t> closed = objects_closed(*ctx.scene);
    nlohmann::json views = nlohmann::json::array();
    for (Vec3f eye : view_points(*ctx.light, views_)) {
      const LightView view = reference_view(region, *ctx.light, eye, image_options_.resolution);
      images_.push_back(build_reference_image(tris, view, image_options_, closed, &times));
      views.push_back({{"width", view.width()}, {"height", view.height()}, {"near", view.near()}, {"far", view.far()}});
    }
    size_t bytes = 0;
    for (const ReferenceImage& img : images_) bytes += img.memory_bytes();
    memory_bytes_ = bytes;
    extra_["views"] = std::move(views);
    extra_["precompute_ms"] = {{"gather", gather_ms},
                               {"raster", times.raster_ms},
                               {"floors_walls", times.floors_ms},
                               {"quadtrees", times.pyramid_ms}};
  }

  // V of ctx.light's cells, and with `sample_irradiance` E from the visible cells (eq. 1); without
  // it, E is left for the caller (a sphere's closed form times V).
  void evaluate_sampled(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out, bool sample_irradiance) {
    ScopedPhase phase(stats_, "trace");
    const AreaLight& light = *ctx.light;
    if (geometry_ && !ctx.tracer) throw Error("coherent-rt: tracer=geometry needs the Embree scene");
    // The near field (coherent-rt.md): each ray's part where an occluder's penumbra would be
    // narrower than near_field texels of the images, through Embree (none without an Embree scene,
    // a bare context: the images answer for the whole ray).
    std::vector<LightView> views;
    for (const ReferenceImage& img : images_) views.push_back(img.view);
    const NearFieldFrame near = geometry_ || !ctx.tracer ? NearFieldFrame{} : near_field_frame(near_field_, light, views);
    const int n = std::max(1, ctx.light_samples);
    int cols = 1, rows = 1;
    stratification_grid(n, &cols, &rows);
    const StratifiedGrid grid(n);
    const DepthImageTracer tracer(images_, trace_options_);
    // View samples of each pixel of the rendered window: [first[i], first[i + 1]), i the
    // pixel's index within the window.
    const PixelWindow window = vs.traced_window();
    const int W = std::max(1, window.width()), H = std::max(1, window.height());
    const uint32_t image_width = static_cast<uint32_t>(std::max(1, vs.width));
    auto window_index = [&](const ViewSample& s) -> size_t {
      const int x = static_cast<int>(s.pixel % image_width) - window.x0;
      const int y = static_cast<int>(s.pixel / image_width) - window.y0;
      if (x < 0 || x >= W || y < 0 || y >= H)
        throw Error("coherent-rt: view sample pixel {} outside the window {} of the {}x{} image", s.pixel,
                    window.to_string(), vs.width, vs.height);
      return static_cast<size_t>(y) * W + x;
    };
    std::vector<uint32_t> first(static_cast<size_t>(W) * H + 1, 0);
    for (const ViewSample& s : vs.samples) first[window_index(s) + 1]++;
    for (size_t i = 1; i < first.size(); ++i) first[i] += first[i - 1];
    // Sample indices grouped by pixel (a counting sort; the camera pass already groups them).
    std::vector<uint32_t> by_pixel(vs.size());
    {
      std::vector<uint32_t> next(first.begin(), first.end() - 1);
      for (uint32_t k = 0; k < vs.size(); ++k) by_pixel[next[window_index(vs.samples[k])]++] = k;
    }

    // The tiles are the whole image's (tile-aligned from its top left corner), clipped to the
    // window: each tile's prediction starts afresh, so a crop whose edges lie on tile
    // boundaries (or the image's) shades its pixels exactly as the whole frame does. Other
    // crops cut tiles, whose points then follow other points than in the whole frame
    // (MethodInfo::tile_exact is false).
    const int tx0 = window.x0 / tile_, ty0 = window.y0 / tile_;
    const int tiles_x = (window.x1 - 1) / tile_ + 1 - tx0, tiles_y = (window.y1 - 1) / tile_ + 1 - ty0;
    std::mutex mutex;
    TraceCounters trace_total;
    SoftShadCounters sample_total;
    uint64_t geometry_rays = 0, own_plane_total = 0, near_total = 0, light_total = 0;
    parallel_for_tiles(tiles_x, tiles_y, 1, [&](int i, int j, int, int) {
      const int x0 = (tx0 + i) * tile_, y0 = (ty0 + j) * tile_;
      SoftShad sampler(light, cols, rows, sampling_);
      TraceScratch scratch;
      TraceCounters tc;
      SoftShadCounters sc;
      uint64_t grays = 0, own_plane_cells = 0, near_rays = 0, light_rays = 0;
      std::vector<Vec2f> u(n);
      std::vector<Vec3f> q(n);
      size_t done = 0;
      for (int d = 0; d < tile_ * tile_; ++d) {
        int hx, hy;
        shader::crt_hilbert_point(tile_, d, hx, hy);
        const int x = x0 + hx, y = y0 + hy;
        if (x < window.x0 || x >= window.x1 || y < window.y0 || y >= window.y1) continue;
        const size_t pixel = static_cast<size_t>(y - window.y0) * W + (x - window.x0);
        for (uint32_t slot = first[pixel]; slot < first[pixel + 1]; ++slot) {
          const uint32_t k = by_pixel[slot];
          const ViewSample& s = vs.samples[k];
          ++done;
          if (!light.faces(s.p)) {
            out.visibility[k] = 0;
            out.irradiance[k] = Vec3f(0.0f);
            continue;
          }
          // The reference's per-point samples: keyed by (seed, light, camera ray, frame).
          Rng rng(ctx.seed, 0x52454600u + ctx.light_index, sample_key(s), ctx.frame);
          for (int i = 0; i < n; ++i) {
            u[i] = grid.sample(i, rng.next_2d());
            q[i] = light.sample_area(u[i]);
          }
          // penumbra's addition: on a closed mesh, light behind the point's own plane is
          // hidden by the solid itself (ng faces the camera, i.e. out of the solid); no ray.
          const bool solid = own_plane_ && !geometry_ && s.object < ctx.scene->objects.size() &&
                             ctx.scene->objects[s.object].closed;
          auto trace = [&](int j) {
            RayAnswer a;
            if (solid && dot(q[j] - s.p, s.ng) <= 0) {
              a.blocked = true;
              ++own_plane_cells;
              return a;
            }
            const ShadowRay sr = shadow_ray_to(s.p, s.ng, q[j]);
            if (geometry_) {
              ++grays;
              Ray r{sr.org, sr.dir, sr.tnear, sr.tfar};
              Hit h;
              if (ctx.tracer->intersect(r, &h)) {
                a.blocked = a.has_point = true;
                a.point = sr.org + sr.dir * h.t;
              }
            } else {
              // The light field (crt_light_field_start): the ray's part nearer the light than the
              // images can hold a caster, through the scene; the images answer up to where it begins.
              float t_end = sr.tfar;
              if (ctx.tracer) {
                const float t_light = shader::crt_light_field_start(sr.org, sr.dir, sr.tfar, light.center, light.frame.n, light_field_);
                if (t_light < sr.tfar) {
                  ++light_rays;
                  const Vec3f from = sr.org + sr.dir * t_light;
                  Ray r{from, sr.dir, 0.0f, sr.tfar - t_light};
                  Hit h;
                  if (ctx.tracer->intersect(r, &h)) {
                    a.blocked = a.has_point = true;
                    a.point = from + sr.dir * h.t;
                    return a;
                  }
                  if (!(t_light > 0.0f)) return a;  // the whole segment was in it: unblocked
                  t_end = t_light;
                }
              }
              Vec3f start = sr.org;
              if (near.scale > 0) {
                const float len = std::min(
                    t_end, shader::crt_near_field_length(s.p, near.eye, near.forward, near.scale, near.light_width, sr.tfar));
                ++near_rays;
                Ray r{sr.org, sr.dir, sr.tnear, len};
                Hit h;
                if (ctx.tracer->intersect(r, &h)) {
                  a.blocked = a.has_point = true;
                  a.point = sr.org + sr.dir * h.t;
                  return a;
                }
                if (len >= t_end) return a;  // the whole segment was near (or in the light field): unblocked
                start = sr.org + sr.dir * len;
              }
              const Vec3f end = t_end < sr.tfar ? sr.org + sr.dir * t_end : q[j];
              TraceResult t = tracer.trace(start, end, sampling_.coherence, scratch, &tc);
              a.blocked = t.blocked;
              a.has_point = t.has_point;
              a.point = t.point;
            }
            return a;
          };
          sampler.shade(s.p, u.data(), trace, &sc);
          // Eq. 1 with area sampling; V = the visible fraction of the light's area (eq. 2).
          const std::vector<uint8_t>& vis = sampler.visible();
          double e = 0;
          int visible = 0;
          for (int j = 0; j < n; ++j) {
            if (!vis[j]) continue;
            ++visible;
            if (sample_irradiance) e += shader::crt_cell_irradiance(s.p, s.ns, light.frame.n, q[j]);
          }
          out.visibility[k] = static_cast<float>(visible) / n;
          if (sample_irradiance) out.irradiance[k] = light.radiance * static_cast<float>(e * light.area() / n);
        }
      }
      if (ctx.progress) ctx.progress->add(done);
      std::lock_guard<std::mutex> lock(mutex);
      trace_total.add(tc);
      sample_total.add(sc);
      geometry_rays += grays;
      own_plane_total += own_plane_cells;
      near_total += near_rays;
      light_total += light_rays;
    });
    // Rays actually traced (cells the sampler asked for, less those the own-plane test answered).
    const uint64_t traced = geometry_ ? geometry_rays : trace_total.rays;
    stats_.rays_traced += traced;
    stats_.texels_visited += trace_total.walk.nodes;
    stats_.memory_bytes = std::max<uint64_t>(stats_.memory_bytes, memory_bytes_);
    const double points = std::max<double>(1, sample_total.points);
    const double rays = std::max<double>(1, trace_total.rays);
    nlohmann::json extra = extra_;
    extra["tracer"] = geometry_ ? "geometry" : "depth-images";
    extra["light_samples"] = n;
    extra["points"] = sample_total.points;
    extra["rays_per_point"] = traced / points;
    extra["ray_fraction"] = traced / (points * n);
    extra["cells_evaluated_per_point"] = sample_total.rays / points;
    extra["own_plane_cells_per_point"] = own_plane_total / points;
    if (!geometry_) {
      extra["near_field_rays_per_point"] = near_total / points;
      extra["light_field"] = light_field_;
      extra["light_field_rays_per_point"] = light_total / points;
    }
    if (sampling_.coherence)
      extra["coherence"] = {{"resets", sample_total.resets},
                            {"predicted_wrong_per_point", sample_total.predicted_wrong / points},
                            {"shortcut_cells_per_point", sample_total.shortcut_cells / points},
                            {"blocker_points_per_point", sample_total.blocker_points / points}};
    if (!geometry_)
      extra["depth_images"] = {{"maps_per_ray", trace_total.maps_walked / rays},
                               {"blocked_fraction", trace_total.blocked / rays},
                               {"clear_miss_fraction", trace_total.clear_misses / rays},
                               {"intervals_exhausted_fraction", trace_total.intervals_exhausted / rays},
                               {"connected_hit_fraction", trace_total.connected_hits / rays},
                               {"hidden_everywhere_fraction", trace_total.hidden_everywhere / rays},
                               {"nodes_per_ray", trace_total.walk.nodes / rays},
                               {"texels_per_ray", trace_total.walk.texels / rays}};
    const std::string suffix = ctx.light_index == 0 ? "" : "_light" + std::to_string(ctx.light_index);
    for (auto it = extra.begin(); it != extra.end(); ++it) stats_.extra[it.key() + suffix] = it.value();
  }

 private:
  AreaLight sampled_;  // the light the passes sample (sampled_light)
  bool geometry_ = false;
  std::string views_;
  int tile_ = 32;
  bool own_plane_ = true;
  float near_field_ = 32.0f;
  bool light_field_on_ = true;
  float light_field_ = 0;  // ShadowRegion::light_field of the prepared light (0: none)
  ReferenceImageOptions image_options_;
  TraceOptions trace_options_;
  SoftShadOptions sampling_;
  std::vector<ReferenceImage> images_;
  size_t memory_bytes_ = 0;
  nlohmann::json extra_ = nlohmann::json::object();
};

// One light's instance: the reference images (resolution^2 texels each: floors, links and
// both quadtrees) and, while one is built, its depth map, ranges and the rasterizer's scratch,
// with the gathered triangles (none with tracer=geometry); per view sample, the pixel
// offsets and the samples grouped by pixel; per worker thread, a tile's sampler and its
// light points.
MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q) {
  MemoryTally tally;
  if (p.get_string("tracer") != "geometry") {
    const int r = p.get_int("resolution");
    const uint64_t views = static_cast<uint64_t>(view_point_count(p.get_string("views")));
    tally.add(views * ReferenceImage::bytes(r, r) + ReferenceImage::build_scratch_bytes(r, r), "resolution");
    tally.add(raster_triangles_bytes(q.triangles) + Rasterizer::scratch_bytes(q.triangles, r, r), kTrianglesSetting);
  }
  tally.add(q.view_samples * 3 * sizeof(uint32_t), kViewSamplesSetting);
  const int n = std::max(1, q.light_samples);
  const uint64_t per_thread =
      SoftShad::bytes(n, p.get_int("sub_grid")) + static_cast<uint64_t>(n) * (sizeof(Vec2f) + sizeof(Vec3f));
  tally.add(static_cast<uint64_t>(q.threads) * per_thread, kLightSamplesSetting);
  return tally.estimate();
}

const MethodRegistration registration({
    "coherent-rt",
    "coherence-based ray tracing of depth images (agrawala2000 §5): shadow rays through a few reference depth "
    "images (min/max quadtrees, floors and walls), traced only where light visibility changes (--spp light cells)",
    {
        {"tracer", ParamType::String, "depth-images",
         "what shadow rays are traced through: 'depth-images' (§5.1) or 'geometry' (Embree, the same sampler)",
         {"depth-images", "geometry"}},
        {"views", ParamType::String, "corners",
         "reference depth images: from the light's 4 'corners', its 'center', or 'corners+center'",
         {"corners", "center", "corners+center"}},
        {"resolution", ParamType::Int, 2048, "texels along the longer side of each reference image (the paper used 1024)", {}, 4, 8192},
        {"gap_bias", ParamType::Float, 4.0,
         "adjacent texels are one surface (joined by a wall) when their depths differ by at most gap_bias texel "
         "widths (§5.1)",
         {}, 0, 1e6},
        {"shadow_bias", ParamType::Float, 1.5,
         "floors of closed objects are pushed back by shadow_bias texel widths (against self-shadowing)", {}, 0,
         1e6},
        {"open_shadow_bias", ParamType::Float, 0.5,
         "floors of open surfaces (leaves, cards, planes: objects that are not closed) are pushed back by this many "
         "texel widths: flat per triangle, they need less, and a leaf then still shadows the leaves just below it",
         {}, 0, 1e6},
        {"slope_bias", ParamType::Float, 0.25,
         "plus slope_bias times the texel's largest depth step to a connected neighbour (grazing surfaces)", {}, 0,
         1e6},
        {"minmax_clipping", ParamType::Bool, true, "§5.1.1: clip the epipolar segment to each node's depth range", {}},
        {"connectedness", ParamType::Bool, true,
         "§5.1.1: report 'blocked' at connected inner nodes (not used with coherence, which needs blocker points)", {}},
        {"clear_miss", ParamType::Bool, true, "§5.1.2: a map that sees the whole ray ends it, unblocked", {}},
        {"occlusion_intervals", ParamType::Bool, true,
         "§5.1.2: later maps trace only the parts of the ray hidden in the earlier ones", {}},
        {"ranking", ParamType::Bool, true, "§5.1.2: maps in increasing order of clipped epipolar length", {}},
        {"hidden_blocks", ParamType::Bool, false,
         "a ray hidden behind surfaces in every map without an intersection is blocked (false: unblocked, as in "
         "§5.1.2)",
         {}},
        {"coherence", ParamType::Bool, true,
         "§5.2: coherence-based light sampling (SoftShad); false traces every light cell", {}},
        {"sub_grid", ParamType::Int, 3, "§5.2.2: blocker-point sub-cells per light cell along each axis", {}, 1, 16},
        {"shortcut", ParamType::Bool, false,
         "§5.2.2: a light cell whose sample shares a sub-cell with a blocker point is blocked without a ray (off by "
         "default: measured to darken penumbrae, docs/methods/coherent-rt.md)",
         {}},
        {"reset_distance", ParamType::Float, 0.02,
         "§5.2.1: drop the prediction when consecutive points are farther apart than this times the distance to "
         "the light",
         {}, 0, 1e6},
        {"own_plane", ParamType::Bool, true,
         "depth images: on closed meshes, light behind the point's own plane is blocked without a ray (penumbra's "
         "addition, against leaks along edges within the shadow bias)",
         {}},
        {"tile", ParamType::Int, 32, "image tiles shaded in Hilbert order, each with its own prediction (power of two)",
         {}, 1, 1024},
        {"near_field", ParamType::Float, 32.0,
         "depth images: the images answer for occluders whose penumbra at the point is at least near_field of "
         "their texels wide; each shadow ray's part nearer its point than that is traced through the scene itself "
         "(penumbra's addition: there a ray meets surfaces the images hold only as biased texel floors); 0: the "
         "paper's rays, images alone",
         {}, 0, 1e6},
        {"light_field", ParamType::Bool, true,
         "depth images: where a caster that can shadow something lies so near the light and so far off its axis "
         "that the images (cut at 76 degrees) cannot hold it (a lamp's shade), each shadow ray's part as near the "
         "light is traced through the scene itself (penumbra's addition); false: the images alone",
         {}},
    },
    [](const ParamSet& p) { return std::make_unique<CoherentRayTracing>(p); },
    /*samples_light=*/true,
    memory,
    // Not tile-exact: SoftShad predicts a point's light cells from the points shaded before it
    // in its tile (agrawala2000 §5.2), so a crop that cuts a tile drops some of those points.
    // A crop whose edges lie on multiples of the `tile` parameter (or the image's edges) is
    // exact: tiles are the whole image's, each with its own prediction.
    /*tile_exact=*/false,
});

}  // namespace
}  // namespace penumbra
