#include "penumbra/render/gpu_renderer.h"

#include <algorithm>
#include <exception>
#include <memory>

#include "penumbra/core/error.h"
#include "penumbra/core/sampling.h"
#include "penumbra/core/timer.h"
#include "penumbra/render/frame_kernels_shared.h"

namespace penumbra {
namespace {

constexpr uint32_t kOne = 0x3f800000u;  // 1.0f, as CommandList::fill writes words

// Stages of the frame itself; every other stage of a render is its method's.
constexpr const char* kCameraStage = "camera_pass";
constexpr const char* kResolveStage = "resolve";

}  // namespace

namespace {

// Drops what a frame recorded when it throws before submitting (a method refusing its input in
// prepare or evaluate): those commands read buffers that may be gone by then, and must never run
// with the next frame's. The next frame makes a new command list.
class DropUnsubmittedOnThrow {
 public:
  explicit DropUnsubmittedOnThrow(std::unique_ptr<gpu::CommandList>& commands) : commands_(commands) {}
  ~DropUnsubmittedOnThrow() {
    if (std::uncaught_exceptions() > exceptions_) commands_.reset();
  }
  DropUnsubmittedOnThrow(const DropUnsubmittedOnThrow&) = delete;
  DropUnsubmittedOnThrow& operator=(const DropUnsubmittedOnThrow&) = delete;

 private:
  std::unique_ptr<gpu::CommandList>& commands_;
  int exceptions_ = std::uncaught_exceptions();
};

}  // namespace

uint64_t gpu_frame_bytes(uint64_t slots, uint64_t pixels, bool split_sphere) {
  // View samples (twice with a split sphere), V, E, radiance, three V sums per slot; colour and
  // V per pixel.
  const uint64_t samples = sizeof(shader::GpuViewSample) * (split_sphere ? 2 : 1);
  return slots * (samples + 4 + 12 + 12 + 3 * 4) + pixels * (12 + 4);
}

GpuRenderer::GpuRenderer(const Scene& scene, const RenderSettings& settings, gpu::Device& device) : device_(&device) {
  gpu_scene_ = std::make_unique<gpu::GpuScene>(device, scene, settings.movable_objects);
  std::vector<bool> all(scene.lights.size(), true);
  set_lights(scene, all, settings);
  commands_ = std::make_unique<gpu::CommandList>(device);
}

GpuRenderer::~GpuRenderer() = default;

void GpuRenderer::set_lights(const Scene& scene, const std::vector<bool>& changed, const RenderSettings& settings) {
  const size_t n = scene.lights.size();
  lights_.resize(n);
  methods_.resize(n);
  prepared_.resize(n, false);
  split_.resize(n);
  for (size_t l = 0; l < n; ++l) {
    split_[l] = scene.lights[l].split_face >= 0;
    if (!changed[l] && methods_[l]) continue;
    lights_[l] = std::make_unique<gpu::GpuLightBuffer>(*device_, scene.lights[l]);
    methods_[l] = create_gpu_method(settings.method, scene, settings.params);
    prepared_[l] = false;
  }
}

void GpuRenderer::set_objects(const Scene& scene, std::span<const uint32_t> moved, const RenderSettings& settings) {
  gpu_scene_->update_objects(scene, moved);
  for (size_t l = 0; l < methods_.size(); ++l) {
    if (!prepared_[l] || methods_[l]->keeps_prepared_after_moving(moved)) continue;
    methods_[l] = create_gpu_method(settings.method, scene, settings.params);
    prepared_[l] = false;
  }
}

bool GpuRenderer::prepared() const {
  return std::all_of(prepared_.begin(), prepared_.end(), [](bool p) { return p; });
}

ShadowContext GpuRenderer::light_context(const Scene& scene, size_t l, const RenderSettings& settings) const {
  ShadowContext ctx;
  ctx.scene = &scene;
  ctx.light = &scene.lights[l];
  ctx.light_index = static_cast<int>(l);
  ctx.tracer = nullptr;
  ctx.seed = settings.seed;
  ctx.light_samples = settings.light_samples;
  return ctx;
}

GpuFrame GpuRenderer::frame_for(size_t l) {
  GpuFrame f;
  f.device = device_;
  f.commands = commands_.get();
  f.scene = gpu_scene_.get();
  // A split sphere's face reads its own copy (face_samples.comp), the camera pass's otherwise.
  const gpu::Buffer& samples = split_[l] ? face_samples_ : samples_;
  f.view_samples = samples.empty() ? 0 : samples.address();
  f.slots = frame_slots_;
  f.width = frame_width_;
  f.height = frame_height_;
  f.window = frame_window_;
  f.samples_per_pixel = frame_spp_;
  f.light = lights_[l]->address();
  f.unit_circle = gpu::unit_circle_buffer(*device_).address();
  f.flush = [this] { times_.add(commands_->submit()); };
  return f;
}

void GpuRenderer::prepare(const Scene& scene, const RenderSettings& settings) {
  if (!commands_) commands_ = std::make_unique<gpu::CommandList>(*device_);
  DropUnsubmittedOnThrow drop(commands_);
  for (size_t l = 0; l < methods_.size(); ++l) {
    if (prepared_[l]) continue;
    GpuFrame frame = frame_for(l);
    methods_[l]->prepare(light_context(scene, l, settings), frame);
    prepared_[l] = true;
  }
  times_.add(commands_->submit());
}

void GpuRenderer::size_frame(uint64_t slots, uint64_t pixels) {
  if (slots == slots_ && pixels == pixels_) return;
  gpu::Device& d = *device_;
  samples_ = gpu::Buffer(d, slots * sizeof(shader::GpuViewSample), "the view samples");
  visibility_ = gpu::Buffer(d, slots * 4, "the visibility of each view sample");
  irradiance_ = gpu::Buffer(d, slots * 12, "the irradiance of each view sample");
  radiance_ = gpu::Buffer(d, slots * 12, "the radiance of each view sample");
  v_weighted_ = gpu::Buffer(d, slots * 4, "the compose's sums");
  v_weight_ = gpu::Buffer(d, slots * 4, "the compose's sums");
  v_plain_ = gpu::Buffer(d, slots * 4, "the compose's sums");
  color_out_ = gpu::Buffer(d, pixels * 12, "the image");
  visibility_out_ = gpu::Buffer(d, pixels * 4, "the visibility image");
  visibility_sum_ = gpu::Buffer();
  irradiance_sum_ = gpu::Buffer();
  face_samples_ = gpu::Buffer();
  slots_ = slots;
  pixels_ = pixels;
}

RenderResult GpuRenderer::render(const Scene& scene, const RenderSettings& settings) {
  Timer total;
  RenderResult result;
  const Camera& cam = scene.camera;
  const PixelWindow window = crop_window(settings.crop, cam);
  const int spp = std::max(1, cam.samples_per_pixel);
  const uint64_t pixels = static_cast<uint64_t>(window.width()) * window.height();
  const uint64_t slots = pixels * spp;
  if (slots > 0xffffffffu) throw Error("{}: {} camera rays is too many for one GPU frame", scene.source.string(), slots);
  size_frame(slots, pixels);
  frame_slots_ = static_cast<uint32_t>(slots);
  frame_width_ = cam.width;
  frame_height_ = cam.height;
  frame_spp_ = spp;
  frame_window_ = window;
  const int frames = std::max(1, settings.frames);
  if (face_samples_.empty() && std::find(split_.begin(), split_.end(), true) != split_.end())
    face_samples_ = gpu::Buffer(*device_, slots * sizeof(shader::GpuViewSample), "a split sphere's view samples");
  if (frames > 1 && visibility_sum_.empty()) {
    visibility_sum_ = gpu::Buffer(*device_, slots * 4, "the frames' visibility sums");
    irradiance_sum_ = gpu::Buffer(*device_, slots * 12, "the frames' irradiance sums");
  }
  times_ = {};
  if (!commands_) commands_ = std::make_unique<gpu::CommandList>(*device_);
  DropUnsubmittedOnThrow drop(commands_);
  gpu::CommandList& cl = *commands_;

  // The camera pass.
  cl.stage(kCameraStage);
  const CameraProjection projection(cam);
  const StratifiedGrid grid(spp);
  shader::CameraPassParams cp{};
  cp.scene = gpu_scene_->address();
  cp.samples = samples_.address();
  cp.eye = cam.eye;
  cp.tan_half = projection.tan_half();
  cp.s = projection.frame().s;
  cp.aspect = projection.aspect();
  cp.t = projection.frame().t;
  cp.width = static_cast<float>(cam.width);
  cp.n = projection.frame().n;
  cp.height = static_cast<float>(cam.height);
  cp.x0 = window.x0;
  cp.y0 = window.y0;
  cp.window_width = window.width();
  cp.window_height = window.height();
  cp.image_width = cam.width;
  cp.spp = spp;
  cp.grid_cols = grid.cols();
  cp.inv_cols = grid.inv_cols();
  cp.inv_rows = grid.inv_rows();
  cp.seed = settings.seed;
  cl.dispatch("camera_pass", slots, cp);
  cl.fill(radiance_, 0);
  cl.fill(v_weighted_, 0);
  cl.fill(v_weight_, 0);
  cl.fill(v_plain_, 0);

  // Each light: its method, then the compose.
  for (size_t l = 0; l < methods_.size(); ++l) {
    GpuShadowMethod& method = *methods_[l];
    ShadowContext ctx = light_context(scene, l, settings);
    if (split_[l]) {  // the face's view samples, every other slot a miss
      const AreaLight& light = scene.lights[l];
      cl.stage("face_samples");
      shader::FaceSamplesParams fp{};
      fp.samples = samples_.address();
      fp.served = face_samples_.address();
      fp.center = light.center;
      fp.face = static_cast<uint32_t>(light.split_face);
      fp.s = light.split_frame.s;
      fp.t = light.split_frame.t;
      fp.n = light.split_frame.n;
      fp.cube = light.split_cube ? 1u : 0u;
      fp.slots = static_cast<uint32_t>(slots);
      cl.dispatch("face_samples", slots, fp);
    }
    GpuFrame frame = frame_for(l);
    if (!prepared_[l]) {
      method.prepare(ctx, frame);
      prepared_[l] = true;
    }
    const bool has_e = method.computes_irradiance();
    const GpuShadowOutput out{visibility_.address(), irradiance_.address()};
    if (frames > 1) {
      cl.fill(visibility_sum_, 0);
      cl.fill(irradiance_sum_, 0);
    }
    for (int f = 0; f < frames; ++f) {
      ctx.frame = settings.first_frame + f;
      cl.fill(visibility_, kOne);
      method.evaluate(ctx, frame, out);
      if (frames > 1) {
        cl.stage("frames");
        cl.dispatch("frame_sum", slots,
                    shader::FrameSumParams{visibility_.address(), has_e ? irradiance_.address() : 0,
                                           visibility_sum_.address(), irradiance_sum_.address(),
                                           static_cast<uint32_t>(slots), 0u, 0.0f, 0u});
      }
    }
    if (frames > 1)
      cl.dispatch("frame_sum", slots,
                  shader::FrameSumParams{visibility_.address(), has_e ? irradiance_.address() : 0,
                                         visibility_sum_.address(), irradiance_sum_.address(),
                                         static_cast<uint32_t>(slots), 1u, 1.0f / static_cast<float>(frames), 0u});
    cl.stage("compose");
    shader::ComposeParams p{};
    p.samples = frame.view_samples;  // a split sphere's face: the samples it serves alone
    p.light = lights_[l]->address();
    p.unit_circle = frame.unit_circle;
    p.visibility = visibility_.address();
    p.irradiance = irradiance_.address();
    p.radiance = radiance_.address();
    p.v_weighted = v_weighted_.address();
    p.v_weight = v_weight_.address();
    p.v_plain = v_plain_.address();
    p.slots = static_cast<uint32_t>(slots);
    p.has_irradiance = has_e ? 1u : 0u;
    cl.dispatch("compose", slots, p);
  }

  // The resolve into pixels, then the one read-back.
  cl.stage(kResolveStage);
  shader::ResolveParams rp{};
  rp.samples = samples_.address();
  rp.radiance = radiance_.address();
  rp.v_weighted = v_weighted_.address();
  rp.v_weight = v_weight_.address();
  rp.v_plain = v_plain_.address();
  rp.color = color_out_.address();
  rp.visibility = visibility_out_.address();
  rp.window_width = window.width();
  rp.window_height = window.height();
  rp.spp = spp;
  rp.lights = whole_light_count(scene.lights);
  cl.dispatch("resolve", pixels, rp);
  times_.add(cl.submit());

  Timer readback;
  result.window = window;
  result.color = Image(window.width(), window.height(), 3, 0.0f);
  result.visibility = Image(window.width(), window.height(), 1, 1.0f);
  color_out_.download(result.color.data().data(), pixels * 12);
  visibility_out_.download(result.visibility.data().data(), pixels * 4);
  const double readback_ms = readback.elapsed_ms();

  // Statistics: the methods' counters, their phases as GPU time (every stage but the frame's
  // camera pass and resolve, compose included as on the CPU), and the GPU time of every stage.
  for (auto& m : methods_) {
    m->collect_stats();
    result.stats.accumulate(m->stats());
    m->stats() = MethodStats{};
  }
  result.stats.phases_ms.clear();
  nlohmann::json gpu_ms = nlohmann::json::object();
  for (const auto& [name, ms] : times_.ms) {
    gpu_ms[name] = ms;
    if (name == kCameraStage)
      result.camera_pass_ms = ms;
    else if (name != kResolveStage)
      result.stats.add_phase(name, ms);
  }
  gpu_ms["total"] = times_.total();
  gpu_ms["readback"] = readback_ms;
  result.gpu_ms = gpu_ms;
  if (!times_.kernels.empty()) {
    result.gpu_kernels = nlohmann::json::object();
    for (const gpu::KernelTime& k : times_.kernels)
      result.gpu_kernels[k.name] = {{"ms", k.ms}, {"dispatches", k.dispatches}};
  }
  result.device = device_->info().name;
  result.view_sample_count = slots;  // camera rays: the GPU keeps a slot for every one
  result.total_ms = total.elapsed_ms();
  return result;
}

ViewSamples GpuRenderer::download_view_samples() const {
  ViewSamples vs;
  vs.width = frame_width_;
  vs.height = frame_height_;
  vs.window = frame_window_;
  vs.samples_per_pixel = frame_spp_;
  if (frame_slots_ == 0) return vs;
  std::vector<ViewSample> all = samples_.download_vector<ViewSample>(frame_slots_);
  for (const ViewSample& s : all)
    if (s.object != shader::kMissObject) vs.samples.push_back(s);
  return vs;
}

}  // namespace penumbra
