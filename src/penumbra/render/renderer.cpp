#include "penumbra/render/renderer.h"

#include <cstdio>

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdint>

#include "penumbra/core/error.h"
#include "penumbra/core/huge_pages.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/sampling.h"
#include "penumbra/core/timer.h"
#include "penumbra/render/coherent_shading.h"
#include "penumbra/render/gpu_renderer.h"
#include "penumbra/render/map_cache.h"
#include "penumbra/shadow/gpu_method.h"

namespace penumbra {

void CameraPass::run(const Scene& scene, const RayTracer& tracer, uint64_t seed, ViewSamples& vs,
                     const PixelWindow& crop) {
  const Camera& cam = scene.camera;
  const PixelWindow window = crop_window(crop, cam);
  const CameraProjection projection(cam);
  const int spp = std::max(1, cam.samples_per_pixel);
  vs.width = cam.width;
  vs.height = cam.height;
  vs.window = window;
  vs.samples_per_pixel = spp;
  const StratifiedGrid grid(spp);
  // Rows and rays of the window; row j is image row window.y0 + j. A ray's direction, jitter
  // and (through ViewSample::pixel and sub) every method's random numbers depend on its global
  // pixel only, so a window's rays are the whole image's rays there.
  const size_t rows = static_cast<size_t>(window.height()), per_row = static_cast<size_t>(window.width()) * spp;
  hits_.resize(rows * per_row);
  row_offset_.assign(rows + 1, 0);
  // The directions of row j's rays (ray r = pixel window.x0 + r / spp, sample r % spp) into
  // dx, dy, dz: the pixel centres (a vectorised row), or stratified jitter inside each pixel.
  auto row_directions = [&](size_t j, float* dx, float* dy, float* dz) {
    const int y = window.y0 + static_cast<int>(j);
    if (spp == 1) {
      projection.row_directions(static_cast<float>(y) + 0.5f, window.x0, window.width(), dx, dy, dz);
      return;
    }
    for (int x = window.x0; x < window.x1; ++x) {
      Rng rng(seed, 0x43414dull /* "CAM" */, static_cast<uint32_t>(y * cam.width + x));
      for (int s = 0; s < spp; ++s) {
        const Vec2f u = grid.sample(s, rng.next_2d());
        const Vec3f d = projection.ray_direction(x + u.x, y + u.y);
        const size_t r = static_cast<size_t>(x - window.x0) * spp + s;
        dx[r] = d.x, dy[r] = d.y, dz[r] = d.z;
      }
    }
  };
  // Pass 1: trace the rays of 4 rows as one stream, ordered in 4 x 4 pixel tiles so that
  // consecutive rays are close (Embree traces them as packets), keep each ray's hit in
  // scanline order and count each row's hits.
  constexpr size_t kTile = 4;
  const size_t groups = (rows + kTile - 1) / kTile;
  parallel_for(groups, 1, [&](size_t g0, size_t g1) {
    std::vector<float> dx(kTile * per_row), dy(kTile * per_row), dz(kTile * per_row);
    std::vector<Ray> rays(kTile * per_row);
    std::vector<Hit> hits(kTile * per_row);
    std::vector<uint32_t> slot(kTile * per_row);  // stream position -> ray index within the group's rows
    for (size_t g = g0; g < g1; ++g) {
      const size_t j_begin = g * kTile, j_end = std::min(rows, j_begin + kTile);
      for (size_t j = j_begin; j < j_end; ++j) {
        const size_t o = (j - j_begin) * per_row;
        row_directions(j, dx.data() + o, dy.data() + o, dz.data() + o);
      }
      size_t i = 0;
      for (size_t tx = 0; tx < per_row; tx += kTile * spp) {
        const size_t tx_end = std::min(per_row, tx + kTile * spp);
        for (size_t o = 0; o < (j_end - j_begin) * per_row; o += per_row) {
          for (size_t r = o + tx; r < o + tx_end; ++r) {
            rays[i] = Ray{cam.eye, Vec3f(dx[r], dy[r], dz[r]), 0.0f, kInfinity};
            slot[i++] = static_cast<uint32_t>(r);
          }
        }
      }
      tracer.intersect(std::span(rays).first(i), std::span(hits).first(i), /*coherent=*/true);
      RayHit* out = hits_.data() + j_begin * per_row;
      for (size_t k = 0; k < i; ++k) {
        const Hit& hit = hits[k];
        out[slot[k]] = RayHit{hit.object, hit.prim, hit.u, hit.v};
      }
      for (size_t j = j_begin; j < j_end; ++j) {
        const RayHit* row = hits_.data() + j * per_row;
        size_t count = 0;
        for (size_t r = 0; r < per_row; ++r) count += row[r].object != Hit::kMiss;
        row_offset_[j + 1] = count;
      }
    }
  });
  for (size_t j = 0; j < rows; ++j) row_offset_[j + 1] += row_offset_[j];
  // Pass 2: the view samples, each row from its offset (scanline order whatever the thread count).
  vs.samples.resize(row_offset_.back());
  parallel_for(rows, 4, [&](size_t j0, size_t j1) {
    std::vector<float> dx(per_row), dy(per_row), dz(per_row);
    for (size_t j = j0; j < j1; ++j) {
      if (row_offset_[j + 1] == row_offset_[j]) continue;
      // The rays' directions again (cheaper than keeping them): which side each hit.
      row_directions(j, dx.data(), dy.data(), dz.data());
      ViewSample* out = vs.samples.data() + row_offset_[j];
      const RayHit* in = hits_.data() + j * per_row;
      const size_t row_pixel = (window.y0 + j) * static_cast<size_t>(cam.width) + window.x0;
      for (size_t r = 0; r < per_row; ++r) {
        const RayHit& hit = in[r];
        if (hit.object == Hit::kMiss) continue;
        const uint32_t object = hit.object;
        const SceneObject& obj = scene.objects[object];
        const TriangleMesh& m = obj.mesh;
        const uint32_t i0 = m.indices[3 * hit.prim], i1 = m.indices[3 * hit.prim + 1], i2 = m.indices[3 * hit.prim + 2];
        const float w = 1.0f - hit.u - hit.v;
        ViewSample& v = *out++;
        // Barycentric interpolation is more accurate than org + t * dir far from the eye.
        v.p = m.positions[i0] * w + m.positions[i1] * hit.u + m.positions[i2] * hit.v;
        const Vec3f ng = normalize(cross(m.positions[i1] - m.positions[i0], m.positions[i2] - m.positions[i0]));
        const bool back = dot(ng, Vec3f(dx[r], dy[r], dz[r])) > 0;
        v.ng = back ? -ng : ng;
        if (!m.normals.empty()) {
          Vec3f ns = m.normals[i0] * w + m.normals[i1] * hit.u + m.normals[i2] * hit.v;
          const float len = length(ns);
          ns = len > 0 ? ns / len : v.ng;
          v.ns = dot(ns, v.ng) < 0 ? -ns : ns;
        } else {
          v.ns = v.ng;
        }
        if (back && !obj.material.two_sided)
          v.albedo = Vec3f(0.0f);
        else if (obj.material.albedo_texture && !m.uvs.empty())
          v.albedo = obj.material.albedo_at(m.uv_at(hit.prim, hit.u, hit.v));
        else
          v.albedo = obj.material.albedo;
        v.object = object;
        v.prim = hit.prim;
        v.pixel = static_cast<uint32_t>(row_pixel + r / spp);
        v.sub = static_cast<uint32_t>(r % spp);
      }
    }
  });
}

ViewSamples camera_pass(const Scene& scene, const RayTracer& tracer, uint64_t seed, const PixelWindow& crop) {
  ViewSamples vs;
  CameraPass().run(scene, tracer, seed, vs, crop);
  return vs;
}

namespace {
// "512 KiB", "3.2 GiB": binary units, one decimal from MiB up.
std::string format_bytes(uint64_t b) {
  const double v = static_cast<double>(b);
  if (b < 1024) return fmt::format("{} bytes", b);
  if (b < (1u << 20)) return fmt::format("{:.0f} KiB", v / 1024.0);
  if (b < (1u << 30)) return fmt::format("{:.1f} MiB", v / (1024.0 * 1024.0));
  if (b < (uint64_t(1) << 40)) return fmt::format("{:.1f} GiB", v / (1024.0 * 1024.0 * 1024.0));
  return fmt::format("{:.1f} TiB", v / (1024.0 * 1024.0 * 1024.0 * 1024.0));
}
}  // namespace

std::vector<AreaLight> drawn_lights(const Scene& scene, const std::string& method, std::span<const AreaLight> lights) {
  std::vector<AreaLight> drawn = expand_textured_lights(lights);
  const MethodInfo* info = MethodRegistry::find(method);
  if (info && info->sphere_through_disk) drawn = split_sphere_lights(drawn, scene.bounds());
  return drawn;
}

RenderMemoryEstimate estimate_render_memory(const Scene& scene, const RenderSettings& settings) {
  RenderMemoryEstimate e;
  // The crop's pixels only (the whole image without one); a crop outside the image is refused here.
  const PixelWindow window = crop_window(settings.crop, scene.camera);
  const uint64_t pixels = static_cast<uint64_t>(window.width()) * static_cast<uint64_t>(window.height());
  const uint64_t rays = pixels * static_cast<uint64_t>(std::max(1, scene.camera.samples_per_pixel));
  // CameraPass: a 16-byte hit per ray and a ViewSample per hit (every ray may hit); the
  // compose's per-sample radiance, V sums, vis and irradiance (FrameBuffers: 40 bytes), twice
  // that again for progressive frames; the colour and V images; a split sphere's face's copy of
  // the view samples it serves and their indices.
  const std::vector<AreaLight> drawn = drawn_lights(scene, settings.method, scene.lights);
  const bool split = has_split_light(drawn);
  const uint64_t per_sample =
      sizeof(ViewSample) + 40 + (settings.frames > 1 ? 16 : 0) + (split ? sizeof(ViewSample) + 4 : 0);
  e.view_bytes = rays * (16 + per_sample) + pixels * 16;

  const MethodInfo& info = MethodRegistry::get(settings.method);
  if (info.estimate_memory) {
    MemoryQuery q;
    q.view_samples = rays;
    q.light_samples = settings.light_samples;
    q.triangles = scene.triangle_count();
    q.threads = std::max(1, max_threads());
    q.semi_transparent = scene.semi_transparent();
    const ParamSet params = resolve_method_params(settings.method, scene, settings.params);
    // One instance per light, each keeping its maps (Renderer::methods_); the setting named is
    // the one that drives most of their bytes together.
    MemoryTally lights;
    for (const AreaLight& light : drawn) {
      q.light = &light;
      const MemoryEstimate m = info.estimate_memory(params, q);
      lights.add(m.bytes, m.setting);
    }
    const MemoryEstimate all = lights.estimate();
    e.method_bytes = all.bytes;
    e.method_setting = all.setting;
  }
  return e;
}

uint64_t default_memory_limit() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
  if (pages <= 0 || page <= 0) return UINT64_MAX;
  return static_cast<uint64_t>(pages) / 10 * 8 * static_cast<uint64_t>(page);
}

void check_render_memory(const Scene& scene, const RenderSettings& settings) {
  const uint64_t limit = settings.memory_limit > 0 ? settings.memory_limit : default_memory_limit();
  const RenderMemoryEstimate need = estimate_render_memory(scene, settings);
  if (need.total() <= limit) return;
  const std::string over = fmt::format("over the memory limit of {}{}", format_bytes(limit),
                                       settings.memory_limit > 0 ? "" : " (80% of physical memory)");
  // The view samples' own message also when what the method needs most grows with them.
  if (need.view_bytes >= need.method_bytes || need.method_setting == kViewSamplesSetting)
    throw Error(
        "{}: a {}x{} image{} with {} camera sample(s) per pixel needs about {} for its view samples{}, {}; lower "
        "camera.resolution or camera.samples_per_pixel (--resolution, --pixel-samples){} or raise --memory-limit",
        scene.source.string(), scene.camera.width, scene.camera.height,
        settings.crop.empty() ? "" : fmt::format(" cropped to {}", settings.crop.to_string()),
        std::max(1, scene.camera.samples_per_pixel), format_bytes(need.view_bytes),
        need.method_bytes > 0 ? fmt::format(" and {} for {}", format_bytes(need.method_bytes), settings.method) : "",
        over, settings.crop.empty() ? "" : ", render smaller tiles (--crop)");
  // A method parameter is named as -p METHOD.NAME; other settings (--spp, the scene's
  // triangles) as they are.
  const std::vector<ParamSpec>& specs = MethodRegistry::get(settings.method).params;
  const bool is_param = std::any_of(specs.begin(), specs.end(),
                                    [&](const ParamSpec& p) { return p.name == need.method_setting; });
  // The instances the render holds: a split sphere's faces each hold their own (drawn_lights).
  const std::vector<AreaLight> drawn = drawn_lights(scene, settings.method, scene.lights);
  const bool split = has_split_light(drawn);
  throw Error("{}: {} needs about {} for its light-space data{} (and {} for the view samples), {}; lower {}{} or "
              "raise --memory-limit{}",
              scene.source.string(), settings.method, format_bytes(need.method_bytes),
              drawn.size() > 1 ? fmt::format(" of {} lights", drawn.size()) : "", format_bytes(need.view_bytes), over,
              is_param ? fmt::format("-p {}.", settings.method) : "", need.method_setting,
              split ? " (a sphere light the scene reaches behind is drawn as one light per face of a cube, each with "
                      "its own maps)"
                    : "");
}

GpuMemoryEstimate estimate_gpu_render_memory(const Scene& scene, const RenderSettings& settings) {
  GpuMemoryEstimate e;
  const PixelWindow window = crop_window(settings.crop, scene.camera);
  const uint64_t pixels = static_cast<uint64_t>(window.width()) * static_cast<uint64_t>(window.height());
  const uint64_t slots = pixels * static_cast<uint64_t>(std::max(1, scene.camera.samples_per_pixel));
  e.scene_bytes = gpu::GpuScene::estimate_bytes(scene);
  const std::vector<AreaLight> drawn = drawn_lights(scene, settings.method, scene.lights);
  const bool split = has_split_light(drawn);
  e.frame_bytes = gpu_frame_bytes(slots, pixels, split) + (settings.frames > 1 ? slots * 16 : 0);
  const GpuMethodInfo* info = find_gpu_method(settings.method);
  if (info && info->estimate_memory) {
    MemoryQuery q;
    q.view_samples = slots;
    q.light_samples = settings.light_samples;
    q.triangles = scene.triangle_count();
    q.threads = 1;
    q.semi_transparent = scene.semi_transparent();
    const ParamSet params = resolve_method_params(settings.method, scene, settings.params);
    MemoryTally lights;
    for (const AreaLight& light : drawn) {
      q.light = &light;
      const MemoryEstimate m = info->estimate_memory(params, q);
      lights.add(m.bytes, m.setting);
    }
    const MemoryEstimate all = lights.estimate();
    e.method_bytes = all.bytes;
    e.method_setting = all.setting;
  }
  return e;
}

void check_gpu_render_memory(const Scene& scene, const RenderSettings& settings, const gpu::Device& device) {
  const uint64_t capacity = device.memory_capacity();
  const bool user_limit = settings.memory_limit > 0 && settings.memory_limit < capacity;
  const uint64_t limit = user_limit ? settings.memory_limit : capacity;
  const GpuMemoryEstimate need = estimate_gpu_render_memory(scene, settings);
  if (need.total() <= limit) return;
  // The largest part names what to lower.
  std::string lower = "camera.resolution or camera.samples_per_pixel (--resolution, --pixel-samples)";
  if (need.scene_bytes >= need.frame_bytes && need.scene_bytes >= need.method_bytes)
    lower = "the scene's triangle count";
  else if (need.method_bytes > need.frame_bytes && !need.method_setting.empty())
    lower = need.method_setting == kLightSamplesSetting || need.method_setting == kViewSamplesSetting ||
                    need.method_setting == kTrianglesSetting
                ? need.method_setting
                : fmt::format("-p {}.{}", settings.method, need.method_setting);
  const std::vector<AreaLight> drawn = drawn_lights(scene, settings.method, scene.lights);
  const bool split = has_split_light(drawn);
  throw Error("{}: {} on {} needs about {} of GPU memory ({} for the scene, {} for the frame, {} for the method), over "
              "{}; lower {}{}{}",
              scene.source.string(), settings.method, device.info().name, format_bytes(need.total()),
              format_bytes(need.scene_bytes), format_bytes(need.frame_bytes), format_bytes(need.method_bytes),
              user_limit ? fmt::format("the memory limit of {}", format_bytes(limit))
                         : fmt::format("the {} this GPU can give a render (90% of its {})", format_bytes(limit),
                                       format_bytes(device.info().memory_bytes)),
              lower, user_limit ? " or raise --memory-limit" : "",
              split ? fmt::format(" (a sphere light the scene reaches behind is drawn as one light per face of a cube, "
                                  "each with its own maps: {} lights)",
                                  drawn.size())
                    : "");
}

Renderer::Renderer(const Scene& scene, RenderSettings settings) : scene_(scene), settings_(std::move(settings)) {
  if (scene_.lights.empty()) throw Error("{}: the scene has no lights", scene_.source.string());
  // A textured light is drawn as one light per colour channel (issue 20 part 3), a sphere the
  // scene reaches behind as one light per face of a cube (drawn_lights).
  given_lights_ = scene.lights;
  scene_.lights = drawn_lights(scene, settings_.method, scene.lights);
  const bool textured = std::any_of(scene.lights.begin(), scene.lights.end(), [](const AreaLight& l) { return l.textured(); });
  if (textured && MethodRegistry::get(settings_.method).uniform_light)
    std::fprintf(stderr,
                 "penumbra: note: %s models the light as uniform: a light's radiance_texture counts as its mean colour "
                 "(docs/scene-format.md)\n",
                 settings_.method.c_str());
  if (settings_.device.gpu) {
    // The method must have a GPU version (one line otherwise), and the render must fit.
    if (!find_gpu_method(settings_.method)) create_gpu_method(settings_.method, scene_, settings_.params);
    if (settings_.coherent_shading)
      throw Error("--coherent-shading is not on the GPU yet: render with --device cpu");
    if (!settings_.map_cache.empty())
      throw Error("--map-cache is not on the GPU yet: render with --device cpu");
    gpu::Device& device = gpu::Device::get(settings_.device);
    check_gpu_render_memory(scene_, settings_, device);
    gpu_ = std::make_unique<GpuRenderer>(scene_, settings_, device);
    resolved_params_ = resolve_method_params(settings_.method, scene_, settings_.params).to_json();
    return;
  }
  check_render_memory(scene_, settings_);
  tracer_ = std::make_unique<RayTracer>(scene_, settings_.movable_objects);
  for (size_t l = 0; l < scene_.lights.size(); ++l) {
    ParamSet resolved;
    methods_.push_back(create_method(settings_.method, scene_, settings_.params, &resolved));
    if (l == 0) resolved_params_ = resolved.to_json();
  }
  prepared_.assign(scene_.lights.size(), false);
  if (!settings_.map_cache.empty()) map_cache_ = std::make_unique<MapCache>(settings_.map_cache);
}

const RayTracer& Renderer::tracer() const {
  if (!tracer_) throw Error("Renderer::tracer: a render on the GPU has no Embree scene");
  return *tracer_;
}

int Renderer::refits() const { return gpu_ ? gpu_->refits() : tracer_->refits(); }

Renderer::~Renderer() = default;

void Renderer::prepare_light(size_t l, const ShadowContext& ctx) {
  ShadowMethod& method = *methods_[l];
  if (!map_cache_ || !method.stores_prepared()) {
    method.prepare(ctx);
    prepared_[l] = true;
    return;
  }
  if (geometry_digest_.empty()) geometry_digest_ = MapCache::geometry_digest(scene_);
  const std::string key = MapCache::key(geometry_digest_, settings_.method, resolved_params_, ctx);
  if (!map_cache_->load(key, settings_.method, method, ctx)) {
    method.prepare(ctx);
    map_cache_->store(key, settings_.method, method);
  }
  prepared_[l] = true;
}

void Renderer::set_camera(const Camera& camera) { scene_.camera = camera; }

namespace {
bool same_light(const AreaLight& a, const AreaLight& b) {
  auto eq = [](Vec3f x, Vec3f y) { return x.x == y.x && x.y == y.y && x.z == y.z; };
  return a.shape == b.shape && eq(a.center, b.center) && eq(a.frame.s, b.frame.s) && eq(a.frame.t, b.frame.t) &&
         eq(a.frame.n, b.frame.n) && a.size.x == b.size.x && a.size.y == b.size.y && a.radius == b.radius &&
         eq(a.radii, b.radii) && eq(a.radiance, b.radiance) && a.texture == b.texture &&
         a.texture_channel == b.texture_channel && a.split_face == b.split_face && a.split_faces == b.split_faces &&
         a.split_cube == b.split_cube && eq(a.split_frame.n, b.split_frame.n) && eq(a.split_frame.s, b.split_frame.s);
}
}  // namespace

void Renderer::set_lights(const std::vector<AreaLight>& given) {
  if (given.empty()) throw Error("{}: the scene has no lights", scene_.source.string());
  const std::vector<AreaLight> lights = drawn_lights(scene_, settings_.method, given);
  given_lights_ = given;
  if (gpu_) {
    std::vector<bool> changed(lights.size());
    for (size_t l = 0; l < lights.size(); ++l)
      changed[l] = !(l < scene_.lights.size() && same_light(lights[l], scene_.lights[l]));
    scene_.lights = lights;
    gpu_->set_lights(scene_, changed, settings_);
    return;
  }
  for (size_t l = 0; l < lights.size(); ++l) {
    if (l < scene_.lights.size() && same_light(lights[l], scene_.lights[l])) continue;
    if (l < methods_.size()) {
      methods_[l] = create_method(settings_.method, scene_, settings_.params);
      prepared_[l] = false;
    } else {
      methods_.push_back(create_method(settings_.method, scene_, settings_.params));
      prepared_.push_back(false);
    }
  }
  methods_.resize(lights.size());
  prepared_.resize(lights.size());
  scene_.lights = lights;
}

ShadowContext Renderer::light_context(size_t l) const {
  ShadowContext ctx;
  ctx.scene = &scene_;
  ctx.light = &scene_.lights[l];
  ctx.light_index = static_cast<int>(l);
  ctx.tracer = tracer_.get();
  ctx.seed = settings_.seed;
  ctx.light_samples = settings_.light_samples;
  return ctx;
}

void Renderer::set_objects(const std::vector<SceneObject>& objects, std::span<const uint32_t> moved) {
  if (objects.size() != scene_.objects.size())
    throw Error("{}: set_objects with {} objects for a scene of {}", scene_.source.string(), objects.size(),
                scene_.objects.size());
  if (moved.empty()) return;
  for (uint32_t o : moved) {
    if (o >= objects.size()) throw Error("{}: set_objects: no object {}", scene_.source.string(), o);
    scene_.objects[o] = objects[o];
  }
  if (gpu_) {
    gpu_->set_objects(scene_, moved, settings_);
  } else {
    tracer_->update_objects(scene_, moved);
    geometry_digest_.clear();
    for (size_t l = 0; l < methods_.size(); ++l) {
      if (!prepared_[l]) continue;
      const ShadowContext ctx = light_context(l);
      if (methods_[l]->keeps_prepared_after_moving(moved, ctx)) continue;
      methods_[l] = create_method(settings_.method, scene_, settings_.params);
      prepared_[l] = false;
    }
  }
  // A sphere light faces the scene's centre (orient_sphere_lights) and is split by its bounds
  // (drawn_lights): both follow the new bounds, as in a fresh render of the moved scene (and as
  // an animation's frames do); set_lights recreates only the lights that changed.
  if (std::any_of(given_lights_.begin(), given_lights_.end(), [](const AreaLight& l) {
        return l.shape == LightShape::Sphere || l.shape == LightShape::Ellipsoid;
      })) {
    std::vector<AreaLight> lights = given_lights_;
    orient_sphere_lights(lights, scene_.bounds());
    set_lights(lights);
  }
}

void Renderer::prepare() {
  if (gpu_) {
    gpu_->prepare(scene_, settings_);
    return;
  }
  for (size_t l = 0; l < scene_.lights.size(); ++l) {
    if (prepared_[l]) continue;
    const ShadowContext ctx = light_context(l);
    prepare_light(l, ctx);
  }
}

bool Renderer::prepared() const {
  if (gpu_) return gpu_->prepared();
  return std::all_of(prepared_.begin(), prepared_.end(), [](bool p) { return p; });
}

RenderResult Renderer::render() {
  if (gpu_) {
    RenderResult r = gpu_->render(scene_, settings_);
    r.resolved_params = resolved_params_;
    return r;
  }
  Timer total;
  RenderResult result;
  result.resolved_params = resolved_params_;
  Timer cam_timer;
  camera_pass_.run(scene_, *tracer_, settings_.seed, view_, settings_.crop);
  const ViewSamples& vs = view_;
  result.camera_pass_ms = cam_timer.elapsed_ms();
  result.view_sample_count = vs.size();

  const size_t n = vs.size();
  // Per-sample sums over the lights, in buffers kept between frames.
  FrameBuffers& fb = frame_buffers_;
  fb.radiance.assign(n, Vec3f(0.0f));
  fb.v_weighted.assign(n, 0.0f);
  fb.v_weight.assign(n, 0.0f);
  fb.v_plain.assign(n, 0.0f);
  fb.vis.resize(n);
  fb.irr.resize(n);
  std::vector<Vec3f>& radiance = fb.radiance;
  std::vector<float>&v_weighted = fb.v_weighted, &v_weight = fb.v_weight, &v_plain = fb.v_plain, &vis = fb.vis;
  std::vector<Vec3f>& irr = fb.irr;
  const size_t lights = scene_.lights.size();
  // The faces of a split sphere serve each view sample once together.
  const float whole_lights = whole_light_count(scene_.lights);
  const auto expected = static_cast<uint64_t>(static_cast<double>(n) * whole_lights + 0.5);
  Progress own_progress(settings_.method, expected * std::max(1, settings_.frames),
                        settings_.progress && !settings_.progress_bar);
  Progress& progress = settings_.progress_bar ? *settings_.progress_bar : own_progress;
  std::vector<uint32_t> served;  // a split sphere's face: the view samples it serves
  ViewSamples face_samples;
  for (size_t l = 0; l < lights; ++l) {
    const AreaLight& light = scene_.lights[l];
    ShadowContext ctx = light_context(l);
    ctx.progress = &progress;
    ShadowMethod& method = *methods_[l];
    // A face of a split sphere (split_sphere_lights) draws only the view samples it serves: its
    // method sees them alone (its light view fits them), and the compose adds nothing elsewhere.
    const bool split = light.split_face >= 0;
    if (split) {
      served.clear();
      for (size_t i = 0; i < n; ++i)
        if (light.serves(vs.samples[i].p)) served.push_back(static_cast<uint32_t>(i));
      if (served.empty()) continue;
      face_samples.width = vs.width;
      face_samples.height = vs.height;
      face_samples.window = vs.window;
      face_samples.samples_per_pixel = vs.samples_per_pixel;
      face_samples.samples.resize(served.size());
      for (size_t k = 0; k < served.size(); ++k) face_samples.samples[k] = vs.samples[served[k]];
    }
    const ViewSamples& drawn = split ? face_samples : vs;
    const size_t m = drawn.size();
    // The light-space structures survive camera changes (agrawala2000 §4).
    if (!prepared_[l]) prepare_light(l, ctx);
    ShadowOutput out{std::span<float>(vis).first(m), std::span<Vec3f>(irr).first(m)};
    const int frames = std::max(1, settings_.frames);
    std::vector<float> vis_sum(frames > 1 ? m : 0, 0.0f);
    std::vector<Vec3f> irr_sum(frames > 1 ? m : 0, Vec3f(0.0f));
    for (int f = 0; f < frames; ++f) {
      ctx.frame = settings_.first_frame + f;
      std::fill(vis.begin(), vis.end(), 1.0f);
      method.evaluate(ctx, drawn, out);
      if (frames == 1) break;
      for (size_t i = 0; i < m; ++i) {
        vis_sum[i] += vis[i];
        irr_sum[i] += irr[i];
      }
    }
    if (frames > 1) {
      const float inv = 1.0f / static_cast<float>(frames);
      for (size_t i = 0; i < m; ++i) {
        vis[i] = vis_sum[i] * inv;
        irr[i] = irr_sum[i] * inv;
      }
    }
    if (split) {  // back to the view samples' own places, from the last served one down
      for (size_t k = served.size(); k-- > 0;) {
        vis[served[k]] = vis[k];
        irr[served[k]] = irr[k];
      }
    }
    const bool has_e = method.computes_irradiance();
    const CoherentShading coherent = settings_.coherent_shading && !has_e ? CoherentShading(scene_, light.center)
                                                                          : CoherentShading();
    {
      ScopedPhase phase(method.stats(), "compose");
      const shader::LightGeometry geometry = light.geometry();
      parallel_for(n, 4096, [&](size_t b, size_t e) {
        // The closed-form unshadowed irradiance, a chunk of samples at a time (SIMD for rects).
        constexpr size_t kChunk = 256;
        std::array<Vec3f, kChunk> points, normals;
        std::array<float, kChunk> e_unit;
        for (size_t i = b; i < e; ++i) {
          const size_t k = (i - b) % kChunk;
          if (k == 0) {
            const size_t count = std::min(kChunk, e - i);
            for (size_t j = 0; j < count; ++j) {
              points[j] = vs.samples[i + j].p;
              normals[j] = vs.samples[i + j].ns;
            }
            light.unshadowed_irradiance_scalar(std::span(points).first(count), std::span(normals).first(count),
                                               std::span(e_unit).first(count));
          }
          const ViewSample& s = vs.samples[i];
          if (split && !light.serves(s.p)) continue;
          const Vec3f e0 = light.radiance * e_unit[k];
          // Where the light's emitting side does not face the point (behind a rect's or disk's
          // plane, inside a sphere), it sees none of the light: V = 0 whatever the method drew
          // there (a ray to the light's back is unblocked; a map covers only what is in front).
          float v = shader::light_faces(geometry, s.p) ? clamp01(vis[i]) : 0.0f;
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
  // counting as background (black, fully lit). The images are the window's: pixel (x, y) of
  // the whole image at (x - x0, y - y0).
  const int spp = vs.samples_per_pixel;
  const PixelWindow& window = vs.window;
  result.window = window;
  result.color = Image(window.width(), window.height(), 3, 0.0f);
  result.visibility = Image(window.width(), window.height(), 1, 1.0f);  // pixels without hits stay 1
  const float inv_spp = 1.0f / spp;
  const uint32_t image_width = static_cast<uint32_t>(vs.width);
  // In parallel over runs of samples that start at a pixel's first sample (the samples are
  // grouped by pixel), so no two tasks touch one pixel.
  parallel_for(n, 4096, [&](size_t b, size_t e) {
    while (b > 0 && b < n && vs.samples[b].pixel == vs.samples[b - 1].pixel) ++b;
    while (e < n && vs.samples[e].pixel == vs.samples[e - 1].pixel) ++e;
    for (size_t i = b; i < e;) {
      const uint32_t px = vs.samples[i].pixel;
      Vec3f c(0.0f);
      float v_sum = 0.0f;
      int hits = 0;
      for (; i < e && vs.samples[i].pixel == px; ++i, ++hits) {
        // V of a sample over several lights: weighted by each light's unshadowed irradiance
        // (a single light gives its V exactly).
        v_sum += v_weight[i] > 0 ? v_weighted[i] / v_weight[i] : v_plain[i] / whole_lights;
        c += radiance[i];
      }
      const int x = static_cast<int>(px % image_width) - window.x0, y = static_cast<int>(px / image_width) - window.y0;
      const size_t local = static_cast<size_t>(y) * window.width() + x;
      float* out = result.color.pixel(local);
      out[0] = c.x * inv_spp; out[1] = c.y * inv_spp; out[2] = c.z * inv_spp;
      result.visibility.data()[local] = (v_sum + (spp - hits)) * inv_spp;
    }
  });
  result.total_ms = total.elapsed_ms();
  if (map_cache_) result.map_cache = map_cache_->stats_json();
  result.tracer = tracer_->stats_json();
  return result;
}

RenderResult render_scene(const Scene& scene, const RenderSettings& settings) {
  Renderer r(scene, settings);
  return r.render();
}

nlohmann::json render_stats_json(const Scene& scene, const std::string& method, const RenderSettings& settings,
                                 const RenderResult& r) {
  nlohmann::json doc = {{"scene", scene.source.string()},
                        {"method", method},
                        {"params", r.resolved_params},
                        {"light_samples", settings.light_samples},
                        {"seed", settings.seed},
                        {"frames", settings.frames},
                        {"coherent_shading", settings.coherent_shading},
                        {"resolution", {scene.camera.width, scene.camera.height}},
                        // The pixels rendered ([x0, y0, x1, y1]: the whole image, or the crop).
                        {"window", {r.window.x0, r.window.y0, r.window.x1, r.window.y1}},
                        {"pixel_samples", scene.camera.samples_per_pixel},
                        {"triangles", scene.triangle_count()},
                        {"view_samples", r.view_sample_count},
                        {"camera_pass_ms", r.camera_pass_ms},
                        {"total_ms", r.total_ms},
                        {"huge_pages", heap_uses_huge_pages()},  // core/huge_pages.h
                        {"stats", r.stats.to_json()}};
  if (!r.map_cache.is_null()) doc["map_cache"] = r.map_cache;
  doc["device"] = r.device;
  if (!r.gpu_ms.is_null()) doc["gpu_ms"] = r.gpu_ms;
  if (!r.gpu_kernels.is_null()) doc["gpu_kernels"] = r.gpu_kernels;
  if (!r.tracer.is_null()) doc["embree"] = r.tracer;
  return doc;
}

}  // namespace penumbra
