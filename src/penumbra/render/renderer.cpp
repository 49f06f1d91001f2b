#include "penumbra/render/renderer.h"

#include <algorithm>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/sampling.h"
#include "penumbra/core/timer.h"
#include "penumbra/render/coherent_shading.h"

namespace penumbra {

ViewSamples camera_pass(const Scene& scene, const RayTracer& tracer, uint64_t seed) {
  const Camera& cam = scene.camera;
  const int spp = std::max(1, cam.samples_per_pixel);
  ViewSamples vs;
  vs.width = cam.width;
  vs.height = cam.height;
  vs.samples_per_pixel = spp;
  // Each row is traced into its own list, then rows are concatenated in order, so the
  // sample order is scanline order whatever the thread count.
  std::vector<std::vector<ViewSample>> rows(cam.height);
  const StratifiedGrid grid(spp);
  parallel_for(cam.height, 1, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y < y1; ++y) {
      auto& row = rows[y];
      row.reserve(cam.width * spp);
      for (int x = 0; x < cam.width; ++x) {
        uint32_t pixel = static_cast<uint32_t>(y * cam.width + x);
        Rng rng(seed, 0x43414dull /* "CAM" */, pixel);
        for (int s = 0; s < spp; ++s) {
          // One sample: the pixel centre. Several: stratified jitter inside the pixel.
          Vec2f u = spp == 1 ? Vec2f(0.5f, 0.5f) : grid.sample(s, rng.next_2d());
          Ray ray{cam.eye, cam.ray_direction(x + u.x, y + u.y), 0.0f, kInfinity};
          Hit hit;
          if (!tracer.intersect(ray, &hit)) continue;
          const SceneObject& obj = scene.objects[hit.object];
          const TriangleMesh& m = obj.mesh;
          uint32_t i0 = m.indices[3 * hit.prim], i1 = m.indices[3 * hit.prim + 1], i2 = m.indices[3 * hit.prim + 2];
          float w = 1.0f - hit.u - hit.v;
          ViewSample v;
          // Barycentric interpolation is more accurate than org + t * dir far from the eye.
          v.p = m.positions[i0] * w + m.positions[i1] * hit.u + m.positions[i2] * hit.v;
          Vec3f ng = normalize(cross(m.positions[i1] - m.positions[i0], m.positions[i2] - m.positions[i0]));
          bool back = dot(ng, ray.dir) > 0;
          v.ng = back ? -ng : ng;
          if (!m.normals.empty()) {
            Vec3f ns = m.normals[i0] * w + m.normals[i1] * hit.u + m.normals[i2] * hit.v;
            float len = length(ns);
            ns = len > 0 ? ns / len : v.ng;
            v.ns = dot(ns, v.ng) < 0 ? -ns : ns;
          } else {
            v.ns = v.ng;
          }
          v.albedo = (back && !obj.material.two_sided) ? Vec3f(0.0f) : obj.material.albedo;
          v.object = hit.object;
          v.prim = hit.prim;
          v.pixel = pixel;
          row.push_back(v);
        }
      }
    }
  });
  size_t total = 0;
  for (auto& r : rows) total += r.size();
  vs.samples.reserve(total);
  for (auto& r : rows) vs.samples.insert(vs.samples.end(), r.begin(), r.end());
  return vs;
}

Renderer::Renderer(const Scene& scene, RenderSettings settings) : scene_(scene), settings_(std::move(settings)) {
  if (scene_.lights.empty()) throw Error("{}: the scene has no lights", scene_.source.string());
  tracer_ = std::make_unique<RayTracer>(scene_);
  for (size_t l = 0; l < scene_.lights.size(); ++l) {
    ParamSet resolved;
    methods_.push_back(create_method(settings_.method, scene_, settings_.params, &resolved));
    if (l == 0) resolved_params_ = resolved.to_json();
  }
  prepared_.assign(scene_.lights.size(), false);
}

Renderer::~Renderer() = default;

void Renderer::set_camera(const Camera& camera) { scene_.camera = camera; }

RenderResult Renderer::render() {
  Timer total;
  RenderResult result;
  result.resolved_params = resolved_params_;
  Timer cam_timer;
  ViewSamples vs = camera_pass(scene_, *tracer_, settings_.seed);
  result.camera_pass_ms = cam_timer.elapsed_ms();
  result.view_sample_count = vs.size();

  const size_t n = vs.size();
  std::vector<Vec3f> radiance(n, Vec3f(0.0f));
  std::vector<float> v_weighted(n, 0.0f), v_weight(n, 0.0f), v_plain(n, 0.0f);
  std::vector<float> vis(n);
  std::vector<Vec3f> irr(n);
  const size_t lights = scene_.lights.size();
  Progress own_progress(settings_.method, n * lights * std::max(1, settings_.frames), settings_.progress && !settings_.progress_bar);
  Progress& progress = settings_.progress_bar ? *settings_.progress_bar : own_progress;
  for (size_t l = 0; l < lights; ++l) {
    const AreaLight& light = scene_.lights[l];
    ShadowContext ctx;
    ctx.scene = &scene_;
    ctx.light = &light;
    ctx.light_index = static_cast<int>(l);
    ctx.tracer = tracer_.get();
    ctx.seed = settings_.seed;
    ctx.light_samples = settings_.light_samples;
    ctx.progress = &progress;
    ShadowMethod& method = *methods_[l];
    // The light-space structures survive camera changes (agrawala2000 §4).
    if (!prepared_[l]) {
      method.prepare(ctx);
      prepared_[l] = true;
    }
    ShadowOutput out{std::span<float>(vis), std::span<Vec3f>(irr)};
    const int frames = std::max(1, settings_.frames);
    std::vector<float> vis_sum(frames > 1 ? n : 0, 0.0f);
    std::vector<Vec3f> irr_sum(frames > 1 ? n : 0, Vec3f(0.0f));
    for (int f = 0; f < frames; ++f) {
      ctx.frame = f;
      std::fill(vis.begin(), vis.end(), 1.0f);
      method.evaluate(ctx, vs, out);
      if (frames == 1) break;
      for (size_t i = 0; i < n; ++i) {
        vis_sum[i] += vis[i];
        irr_sum[i] += irr[i];
      }
    }
    if (frames > 1) {
      const float inv = 1.0f / static_cast<float>(frames);
      for (size_t i = 0; i < n; ++i) {
        vis[i] = vis_sum[i] * inv;
        irr[i] = irr_sum[i] * inv;
      }
    }
    const bool has_e = method.computes_irradiance();
    const CoherentShading coherent = settings_.coherent_shading && !has_e ? CoherentShading(scene_, light.center)
                                                                          : CoherentShading();
    {
      ScopedPhase phase(method.stats(), "compose");
      parallel_for(n, 4096, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) {
          const ViewSample& s = vs.samples[i];
          Vec3f e0 = light.unshadowed_irradiance(s.p, s.ns);
          float v = clamp01(vis[i]);
          // A method that gives only V is multiplied with the closed-form unshadowed
          // irradiance; Lambertian: L = albedo / pi * E.
          Vec3f E = has_e ? irr[i] : e0 * (v * coherent.factor(s, light.center));
          radiance[i] += s.albedo * E * kInvPi;
          float w = luminance(e0);
          v_weighted[i] += w * v;
          v_weight[i] += w;
          v_plain[i] += v;
        }
      });
    }
  }
  own_progress.finish();
  for (size_t l = 0; l < lights; ++l) result.stats.accumulate(methods_[l]->stats());
  for (auto& m : methods_) m->stats() = MethodStats{};

  // Resolve view samples into pixels: the mean over the pixel's camera samples, misses
  // counting as background (black, fully lit).
  const int spp = vs.samples_per_pixel;
  result.color = Image(vs.width, vs.height, 3, 0.0f);
  result.visibility = Image(vs.width, vs.height, 1, 0.0f);
  std::vector<int> hits(static_cast<size_t>(vs.width) * vs.height, 0);
  for (size_t i = 0; i < n; ++i) {
    const uint32_t px = vs.samples[i].pixel;
    // V of a sample over several lights: weighted by each light's unshadowed irradiance
    // (a single light gives its V exactly).
    float v = v_weight[i] > 0 ? v_weighted[i] / v_weight[i] : v_plain[i] / lights;
    float* c = result.color.pixel(px);
    c[0] += radiance[i].x; c[1] += radiance[i].y; c[2] += radiance[i].z;
    result.visibility.data()[px] += v;
    hits[px]++;
  }
  for (size_t px = 0; px < hits.size(); ++px) {
    float inv = 1.0f / spp;
    float* c = result.color.pixel(px);
    c[0] *= inv; c[1] *= inv; c[2] *= inv;
    result.visibility.data()[px] = (result.visibility.data()[px] + (spp - hits[px])) * inv;
  }
  result.total_ms = total.elapsed_ms();
  return result;
}

RenderResult render_scene(const Scene& scene, const RenderSettings& settings) {
  Renderer r(scene, settings);
  return r.render();
}

}  // namespace penumbra
