// The pipeline of DESIGN.md: camera pass -> per light prepare/evaluate -> compose.
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "penumbra/core/image.h"
#include "penumbra/gpu/device.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {

struct RenderSettings {
  std::string method = "reference";
  std::vector<std::string> params;  // "key=value" overrides
  int light_samples = 256;          // --spp
  uint64_t seed = 0;
  // Progressive accumulation (sintorn2008 §4.2, Fig. 7): V and E are averaged over this many
  // evaluations with ShadowContext::frame = 0, 1, ...; methods that sample the light draw new
  // samples per frame. The light-space structures are prepared once.
  int frames = 1;
  // ShadowContext::frame of the first of those frames: a progressive refinement that renders
  // one frame at a time (the viewer) asks for frame k with first_frame = k, frames = 1, and
  // the mean of frames 0..K-1 is the render with frames = K (up to rounding).
  int first_frame = 0;
  // Coherent shading (sintorn2008 §4.3 "Shading", Fig. 8): blend the shading normal's cosine
  // toward the smallest cosine of the faces around the triangle's vertices (bent normals,
  // c = 3), so light does not leak onto the light back-facing side of smooth meshes near
  // shadow borders. Applies to methods that give V (compose multiplies the closed form).
  bool coherent_shading = false;
  bool progress = false;            // a progress bar on stderr (when it is a terminal)
  // A bar owned by the caller (a comparison of several renders) to advance instead of
  // drawing one per render; `progress` is then ignored. Not owned.
  Progress* progress_bar = nullptr;
  // Render only these pixels of the camera's image (a tile of a frame split among machines):
  // the camera pass traces their rays alone, and the images are the window's size. Empty (the
  // default) = the whole image; a window not inside the image is an error. Every method keys its
  // random numbers by the camera ray (sample_key), so a tile's pixels equal the whole frame's
  // there, bit for bit, for the methods whose MethodInfo::tile_exact is true.
  PixelWindow crop;
  // Memory budget for the render, in bytes (0 = 80% of physical memory): a render whose
  // estimate exceeds it is refused before anything is allocated (estimate_render_memory).
  uint64_t memory_limit = 0;
  // Light-space data on disk (render/map_cache.h, `--map-cache DIR`): methods that can
  // (ShadowMethod::stores_prepared) read their prepared structures from this folder instead
  // of preparing them, and write them there after preparing. Empty: no cache.
  std::filesystem::path map_cache;
  // The objects (indices into Scene::objects) that Renderer::set_objects will move: an
  // animated scene's object tracks (SequenceRenderer). The Embree scene is then built two-level
  // with these objects' BVHs refittable (RayTracer), so a move refits instead of rebuilding.
  std::vector<uint32_t> movable_objects;
  // Where the frame is rendered (--device): the CPU, or a Vulkan GPU (render/gpu_renderer.h:
  // the whole frame on the device; the method must have a GPU version, gpu_method.h).
  gpu::DeviceChoice device;
};

// The lights a render of `scene` with `method` draws for `lights`, one method instance each:
// a textured light as one light per colour channel (expand_textured_lights), and for a method
// that samples a sphere through one disk (MethodInfo::sphere_through_disk) a sphere the scene
// reaches behind as one light per face (split_sphere_lights), each serving its own view
// samples (AreaLight::serves).
std::vector<AreaLight> drawn_lights(const Scene& scene, const std::string& method, std::span<const AreaLight> lights);

// What a render of `scene` will allocate, estimated before anything is: the camera pass (a
// 16-byte hit per camera ray, a view sample per hit), the per-sample sums of the compose and
// the output images, and each light's method instance (MethodInfo::estimate_memory: its
// maps, lists and per-sample buffers at the resolved parameters).
struct RenderMemoryEstimate {
  uint64_t view_bytes = 0;    // camera pass, compose and images
  uint64_t method_bytes = 0;  // all lights' method instances together
  std::string method_setting;  // what drives method_bytes ("resolution", "--spp", ...)
  uint64_t total() const { return view_bytes + method_bytes; }
};
RenderMemoryEstimate estimate_render_memory(const Scene& scene, const RenderSettings& settings);
// 80% of the machine's physical memory.
uint64_t default_memory_limit();
// Throws an Error naming the scene, the estimate, the limit and the setting to lower (the
// larger part's) when the estimate exceeds settings.memory_limit (or the default).
void check_render_memory(const Scene& scene, const RenderSettings& settings);

// The same on a GPU: what the scene, the frame's per-slot buffers and each light's GPU method
// will hold in device memory, against the device's capacity (90% of its largest memory heap) or
// --memory-limit where lower. Throws an Error naming the device, the estimate and what to lower.
struct GpuMemoryEstimate {
  uint64_t scene_bytes = 0, frame_bytes = 0, method_bytes = 0;
  std::string method_setting;
  uint64_t total() const { return scene_bytes + frame_bytes + method_bytes; }
};
GpuMemoryEstimate estimate_gpu_render_memory(const Scene& scene, const RenderSettings& settings);
void check_gpu_render_memory(const Scene& scene, const RenderSettings& settings, const gpu::Device& device);

struct RenderResult {
  // The pixels of the camera's image rendered (RenderSettings::crop, or the whole image): the
  // images are its size, pixel (x, y) of the whole image at (x - window.x0, y - window.y0).
  PixelWindow window;
  Image color;       // linear RGB radiance (Lambertian: albedo / pi * E)
  Image visibility;  // V per pixel (1 = fully lit; background 1)
  MethodStats stats;            // summed over lights
  double camera_pass_ms = 0;
  double total_ms = 0;
  size_t view_sample_count = 0;
  nlohmann::json resolved_params;
  // With RenderSettings::map_cache: MapCache::stats_json() of the renderer's cache (hits and
  // misses since the Renderer was made); null otherwise.
  nlohmann::json map_cache;
  // The device that rendered it ("cpu", or the GPU's name), and on a GPU the GPU time of each
  // stage in ms (timestamps: camera_pass, the method's stages, compose, resolve; "total"), plus
  // "readback", the host's time to copy the image back.
  std::string device = "cpu";
  nlohmann::json gpu_ms;
  // With kernel profiling (PENUMBRA_GPU_PROFILE=1, gpu/commands.h): the GPU time of each kernel,
  // {name: {"ms", "dispatches"}} (by name); null otherwise.
  nlohmann::json gpu_kernels;
  // The renderer's Embree scene: RayTracer::stats_json() (its build time, bytes, BVHs and
  // instances).
  nlohmann::json tracer;
};

// The camera pass on Embree: primary rays through each pixel (jittered when the camera
// asks for several samples per pixel), or through each pixel of `crop` (empty: the whole
// image; ViewSamples::window says which), producing the view samples in scanline order. The
// rays of a row are traced as one Embree stream; a first pass keeps only each ray's hit (16
// bytes), a second writes the view samples straight to their place. An instance keeps its
// buffers, and `run` reuses those of `out`, so a renderer drawing frame after frame does not
// fault in fresh pages for the 64-byte samples each time.
class CameraPass {
 public:
  void run(const Scene& scene, const RayTracer& tracer, uint64_t seed, ViewSamples& out, const PixelWindow& crop = {});

 private:
  struct RayHit {
    uint32_t object;  // Hit::kMiss where the ray hit nothing
    uint32_t prim;
    float u, v;
  };
  std::vector<RayHit> hits_;        // per ray of the window, in scanline order
  std::vector<size_t> row_offset_;  // first view sample of each of the window's rows, and the total
};

// One camera pass with fresh buffers.
ViewSamples camera_pass(const Scene& scene, const RayTracer& tracer, uint64_t seed, const PixelWindow& crop = {});

// Renders frames of one scene with one method, keeping the method's light-space
// structures between frames: set_camera() re-runs the camera pass only.
class MapCache;
class GpuRenderer;

class Renderer {
 public:
  Renderer(const Scene& scene, RenderSettings settings);
  ~Renderer();
  void set_camera(const Camera& camera);
  // New lights over the same geometry (the Embree scene is kept): the method instances of the
  // lights that changed are created afresh and prepare() again at the next render; those of
  // unchanged lights keep their light-space structures. The count may change. The lights are
  // expanded as in the constructor (drawn_lights): scene().lights holds one light per colour
  // channel of a textured light and one per face of a split sphere.
  void set_lights(const std::vector<AreaLight>& lights);
  // New vertex positions for the objects `moved` (indices into Scene::objects; the same
  // triangles, as an animated transform gives; `objects` is the whole new list): the Embree
  // scene is refit where RenderSettings::movable_objects allows, else rebuilt, and each light's
  // method either keeps its light-space structures (ShadowMethod::keeps_prepared_after_moving)
  // or is created afresh and prepared again at the next render. A sphere light is aimed and
  // split again by the new bounds (orient_sphere_lights, drawn_lights), as in a fresh render of
  // the moved scene: the lights that change are created afresh, as set_lights does.
  void set_objects(const std::vector<SceneObject>& objects, std::span<const uint32_t> moved);
  // Only the first frame index of the next render (RenderSettings::first_frame).
  void set_first_frame(int frame) { settings_.first_frame = frame; }
  // Only the window of the next render (RenderSettings::crop): the tiles of one frame share the
  // light-space structures. Checked against the camera when rendered.
  void set_crop(const PixelWindow& crop) { settings_.crop = crop; }
  // Whether every light's method has its light-space structures for the current lights (the
  // next render costs an evaluate() alone).
  bool prepared() const;
  // Builds the light-space structures of every light not prepared yet, without rendering
  // (the viewer does it while the view is still, so the next camera move costs a display).
  void prepare();
  RenderResult render();
  // The Embree scene of a render on the CPU (a render on the GPU has none: throws).
  const RayTracer& tracer() const;
  // How many set_objects calls refit the moved objects' BVHs (Embree's, or the GPU's).
  int refits() const;
  bool on_gpu() const { return gpu_ != nullptr; }
  GpuRenderer* gpu() { return gpu_.get(); }
  const Scene& scene() const { return scene_; }
  // The method instance serving light i (for tests and statistics).
  ShadowMethod& method(int light) { return *methods_[light]; }

 private:
  Scene scene_;
  // The lights as given (the scene's, or set_lights'), before drawn_lights expanded them into
  // scene_.lights: set_objects aims and splits their spheres again by the new bounds.
  std::vector<AreaLight> given_lights_;
  RenderSettings settings_;
  std::unique_ptr<RayTracer> tracer_;  // on the CPU
  std::unique_ptr<GpuRenderer> gpu_;   // on a GPU (then no tracer_ and no methods_)
  std::vector<std::unique_ptr<ShadowMethod>> methods_;
  std::vector<bool> prepared_;
  nlohmann::json resolved_params_;
  std::unique_ptr<MapCache> map_cache_;  // with RenderSettings::map_cache
  std::string geometry_digest_;          // MapCache::geometry_digest, computed at the first lookup
  // What light l's method reads: the scene, the light, the tracer, seed and light samples.
  ShadowContext light_context(size_t l) const;
  // prepare() of light l's method, or its prepared data from the map cache.
  void prepare_light(size_t l, const ShadowContext& ctx);
  CameraPass camera_pass_;
  ViewSamples view_;  // the last camera pass's samples (their storage is reused)
  struct FrameBuffers {  // per view sample, summed over the lights (reused between frames)
    std::vector<Vec3f> radiance, irr;
    std::vector<float> v_weighted, v_weight, v_plain, vis;
  } frame_buffers_;
};

// One-call convenience: load nothing, render `scene` with `settings`.
RenderResult render_scene(const Scene& scene, const RenderSettings& settings);

// The statistics document of one render (`penumbra render --stats-json`, the Python module's
// RenderResult.stats): the scene, method, parameters, settings, sizes and timings.
nlohmann::json render_stats_json(const Scene& scene, const std::string& method, const RenderSettings& settings,
                                 const RenderResult& r);

}  // namespace penumbra
