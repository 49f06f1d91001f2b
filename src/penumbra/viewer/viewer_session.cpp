#include "penumbra/viewer/viewer_session.h"

#include "penumbra/shadow/gpu_method.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <fmt/format.h>

#include "penumbra/core/error.h"
#include "penumbra/core/timer.h"
#include "penumbra/eval/heatmap.h"
#include "penumbra/shadow/shadow_method.h"

namespace penumbra::viewer {

namespace fs = std::filesystem;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

// Every method that runs on `device`: the auto preview's candidates (preview_choice.h).
std::vector<std::string> methods_on(const gpu::DeviceChoice& device) {
  std::vector<std::string> out;
  for (const MethodInfo* m : MethodRegistry::all())
    if (!device.gpu || find_gpu_method(m->name)) out.push_back(m->name);
  return out;
}

// `image` box-averaged down to w x h (a method's refined V to a calibration render's size).
Image downsample(const Image& image, int w, int h) {
  if (image.width() == w && image.height() == h) return image;
  Image out(w, h, image.channels(), 0.0f);
  std::vector<float> count(static_cast<size_t>(w) * h, 0.0f);
  for (int y = 0; y < image.height(); ++y)
    for (int x = 0; x < image.width(); ++x) {
      const int ox = std::min(w - 1, x * w / image.width()), oy = std::min(h - 1, y * h / image.height());
      const size_t o = static_cast<size_t>(oy) * w + ox;
      for (int c = 0; c < image.channels(); ++c) out.pixel(o)[c] += image.pixel(static_cast<size_t>(y) * image.width() + x)[c];
      count[o] += 1;
    }
  for (size_t i = 0; i < count.size(); ++i)
    for (int c = 0; c < out.channels(); ++c) out.pixel(i)[c] /= std::max(1.0f, count[i]);
  return out;
}

json bounds_json(const Bounds3f& b) {
  if (b.empty()) return {{"min", {0, 0, 0}}, {"max", {0, 0, 0}}};
  return {{"min", {b.lo.x, b.lo.y, b.lo.z}}, {"max", {b.hi.x, b.hi.y, b.hi.z}}};
}

json light_samples_json(const std::string& method, int spp) {
  const MethodInfo* info = MethodRegistry::find(method);
  return info && info->samples_light ? json(spp) : json(nullptr);
}

void add_into(Image& sum, const Image& x) {
  if (sum.width() != x.width() || sum.height() != x.height() || sum.channels() != x.channels()) {
    sum = x;
    return;
  }
  auto& s = sum.data();
  const auto& d = x.data();
  for (size_t i = 0; i < s.size(); ++i) s[i] += d[i];
}

Image scaled(const Image& sum, int frames) {
  Image out = sum;
  const float inv = 1.0f / static_cast<float>(std::max(1, frames));
  for (float& v : out.data()) v *= inv;
  return out;
}

}  // namespace

std::vector<uint8_t> to_rgba8(const Image& image) { return to_8bit(image, 4); }

Image ViewerSession::Accumulation::mean_color() const { return scaled(color_sum, frames_done); }
Image ViewerSession::Accumulation::mean_visibility() const { return scaled(vis_sum, frames_done); }

ViewerSession::ViewerSession(Scene scene, json scene_doc, SessionOptions options)
    : scene_(std::move(scene)),
      doc_(std::move(scene_doc)),
      options_(options),
      bounds_(scene_.bounds()),
      initial_view_(view_from_document(doc_, scene_)),
      chooser_(methods_on(options.device), options.preview_target_ms) {
  view_ = initial_view_;
  // The device opens now: a bad one (`--device gpu:7`) is the command line's one-line error.
  if (options_.device.gpu) device_name_ = gpu::Device::get(options_.device).info().name;
  last_change_ = Clock::now();
  refine_requested_ = true;  // the first frame: nothing moves yet
  pending_preview_ = true;
  status_ = {{"phase", "idle"}, {"method", ""}, {"frame", 0}, {"frames", 0}, {"error", ""}, {"mean_dv", nullptr}};
  thread_ = std::thread([this] { run(); });
}

ViewerSession::~ViewerSession() { stop(); }

void ViewerSession::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stop_ && !thread_.joinable()) return;
    stop_ = true;
    cancel_job();
  }
  work_cv_.notify_all();
  frames_cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

// ---------------------------------------------------------------- requests

json ViewerSession::scene_document() const {
  std::lock_guard<std::mutex> lock(mutex_);
  json doc = doc_;
  doc["camera"] = view_.camera;
  doc["lights"] = view_.lights;
  json methods = merged_method_params(scene_, settings_);
  if (!methods.empty()) doc["methods"] = methods;
  return doc;
}

json ViewerSession::scene_file_document() const {
  json doc = scene_document();
  // Mesh paths are relative to the scene file's folder; the saved file goes elsewhere.
  const fs::path folder = fs::absolute(scene_.source).parent_path();
  if (doc.contains("objects") && doc["objects"].is_array())
    for (json& o : doc["objects"])
      if (o.is_object() && o.contains("mesh") && o["mesh"].is_string()) {
        fs::path p = o["mesh"].get<std::string>();
        if (p.is_relative()) o["mesh"] = (folder / p).lexically_normal().string();
      }
  return doc;
}

std::string ViewerSession::scene_file_name() const {
  const std::string stem = scene_.source.stem().string();
  return (stem.empty() ? std::string("scene") : stem) + "-view.json";
}

json ViewerSession::methods_json() const {
  json out = json::array();
  for (const MethodInfo* m : MethodRegistry::all()) {
    const bool gpu = find_gpu_method(m->name) != nullptr;
    json devices = gpu ? json{"cpu", "gpu"} : json{"cpu"};
    json params = json::array();
    for (const ParamSpec& p : m->params) {
      json spec = {{"name", p.name}, {"type", to_string(p.type)}, {"default", p.default_value},
                   {"doc", p.doc}, {"choices", p.choices}};
      // The open ends of a range (±1e300) are left out.
      spec["min"] = p.min > -1e299 ? json(p.min) : json(nullptr);
      spec["max"] = p.max < 1e299 ? json(p.max) : json(nullptr);
      params.push_back(std::move(spec));
    }
    out.push_back({{"name", m->name}, {"description", m->description}, {"samples_light", m->samples_light},
                   {"devices", std::move(devices)}, {"available", !options_.device.gpu || gpu},
                   {"params", std::move(params)}});
  }
  return out;
}

json ViewerSession::state() const {
  std::lock_guard<std::mutex> lock(mutex_);
  json status = status_;
  status["cancelled"] = counters_.cancelled;
  return {{"generation", generation_},
          {"device", {{"choice", options_.device.to_string()}, {"name", device_name_}}},
          {"camera", view_.resolved_camera()},
          {"lights", view_.resolved_lights()},
          {"bounds", bounds_json(bounds_)},
          {"initial", {{"camera", initial_view_.resolved_camera()}, {"lights", initial_view_.resolved_lights()}}},
          {"settings", settings_.to_json()},
          {"status", std::move(status)},
          {"counters",
           {{"previews", counters_.previews},
            {"final_frames", counters_.final_frames},
            {"compare_frames", counters_.compare_frames},
            {"cancelled", counters_.cancelled},
            {"stale_dropped", counters_.stale_dropped},
            {"calibrations", counters_.calibrations}}}};
}

ViewerSettings ViewerSession::settings() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return settings_;
}

void ViewerSession::cancel_job() {
  if (job_token_) job_token_->cancel();
}

void ViewerSession::changed(bool preview) {
  ++generation_;
  status_["mean_dv"] = nullptr;
  if (preview) pending_preview_ = true;
  cancel_job();
}

uint64_t ViewerSession::update_view(const json& patch) {
  std::unique_lock<std::mutex> lock(mutex_);
  bool camera = false, lights = false;
  ViewState next = apply_view_patch(view_, patch, bounds_, &camera, &lights);
  if (!camera && !lights) return generation_;
  view_ = std::move(next);
  pending_camera_ = pending_camera_ || camera;
  pending_lights_ = pending_lights_ || lights;
  last_change_ = Clock::now();
  refine_requested_ = false;  // the final frame waits until the view is still
  changed(/*preview=*/true);
  const uint64_t g = generation_;
  lock.unlock();
  work_cv_.notify_all();
  return g;
}

json ViewerSession::update_settings(const json& body) {
  std::unique_lock<std::mutex> lock(mutex_);
  ViewerSettings next = apply_settings(settings_, body, scene_, options_.device.gpu);
  if (next.to_json() == settings_.to_json()) return settings_.to_json();
  // The auto preview's errors were measured against the final method's frames: measure again
  // against the new ones.
  if (next.final_method != settings_.final_method || next.spp != settings_.spp || next.params != settings_.params)
    reset_measurements_ = true;
  const bool preview_changed = next.preview != settings_.preview || next.preview_scale != settings_.preview_scale;
  settings_ = std::move(next);
  // No movement: the final method starts at once (a preview only shows a new preview choice).
  // What stays valid is reused: an accumulation of the same view, method, samples and
  // parameters goes on where it was (run_accumulation).
  refine_requested_ = true;
  changed(preview_changed);
  json out = settings_.to_json();
  lock.unlock();
  work_cv_.notify_all();
  return out;
}

uint64_t ViewerSession::refine_now() {
  std::unique_lock<std::mutex> lock(mutex_);
  refine_requested_ = true;
  const uint64_t g = generation_;
  lock.unlock();
  work_cv_.notify_all();
  return g;
}

uint64_t ViewerSession::reset_view() {
  std::unique_lock<std::mutex> lock(mutex_);
  const bool camera = view_.camera != initial_view_.camera, lights = view_.lights != initial_view_.lights;
  if (!camera && !lights) return generation_;
  view_ = initial_view_;
  pending_camera_ = pending_camera_ || camera;
  pending_lights_ = pending_lights_ || lights;
  last_change_ = Clock::now();
  refine_requested_ = false;
  changed(true);
  const uint64_t g = generation_;
  lock.unlock();
  work_cv_.notify_all();
  return g;
}

ViewerSession::Counters ViewerSession::counters() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return counters_;
}

uint64_t ViewerSession::generation() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return generation_;
}

bool ViewerSession::poll(uint64_t after, int timeout_ms, std::string* body) {
  std::unique_lock<std::mutex> lock(mutex_);
  const bool got = frames_cv_.wait_for(lock, std::chrono::milliseconds(std::max(0, timeout_ms)),
                                       [&] { return stop_ || seq_ > after; });
  if (!got || stop_ || seq_ <= after) return false;
  json layers = json::array();
  size_t offset = 0;
  std::vector<const Layer*> sent;
  for (const auto& [name, layer] : layers_) {
    if (layer.seq <= after) continue;
    json meta = layer.meta;
    meta["name"] = name;
    meta["offset"] = offset;
    meta["seq"] = layer.seq;
    offset += layer.rgba.size();
    layers.push_back(std::move(meta));
    sent.push_back(&layer);
  }
  json status = status_;
  status["cancelled"] = counters_.cancelled;
  const std::string header =
      json{{"seq", seq_}, {"generation", generation_}, {"status", std::move(status)}, {"layers", std::move(layers)}}
          .dump();
  body->clear();
  body->reserve(4 + header.size() + offset);
  const uint32_t n = static_cast<uint32_t>(header.size());
  for (int i = 0; i < 4; ++i) body->push_back(static_cast<char>((n >> (8 * i)) & 0xff));
  body->append(header);
  for (const Layer* l : sent) body->append(reinterpret_cast<const char*>(l->rgba.data()), l->rgba.size());
  return true;
}

// ---------------------------------------------------------------- /api/frame

Scene ViewerSession::scene_for(const ViewerSettings& settings, const ViewState& view) const {
  Scene s = scene_;
  s.camera = view.parsed_camera;
  s.lights = view.parsed_lights;
  s.method_params = merged_method_params(scene_, settings);
  return s;
}

FrameFile ViewerSession::render_frame(const FrameRequest& request) {
  Scene scene;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    scene = scene_for(settings_, view_);
    // The render thread yields: a request for a finished frame comes before a refinement.
    ++frame_requests_;
    cancel_job();
  }
  struct Release {
    ViewerSession* s;
    ~Release() {
      {
        std::lock_guard<std::mutex> lock(s->mutex_);
        --s->frame_requests_;
      }
      s->work_cv_.notify_all();
    }
  } release{this};
  if (request.width > 0) {
    scene.camera.width = request.width;
    scene.camera.height = request.height;
  }
  // `penumbra render`'s settings (app/cmd_render.cpp) for the same arguments.
  RenderSettings settings;
  settings.method = request.method;
  settings.params = request.params;
  settings.light_samples = request.spp;
  settings.seed = request.seed;
  settings.frames = request.frames;
  settings.device = options_.device;  // the session's frames and this one on the same device
  RenderResult r;
  {
    std::lock_guard<std::mutex> render_lock(render_mutex_);
    r = render_scene(scene, settings);
  }
  // write_image's own encoders, as the CLI writes the file: into a private folder, read back.
  char dir_template[] = "/tmp/penumbra-view-XXXXXX";
  if (!mkdtemp(dir_template)) throw Error("/api/frame: cannot create a temporary folder: {}", std::strerror(errno));
  const fs::path dir = dir_template, file = dir / ("frame." + request.format);
  FrameFile out;
  try {
    write_image(file.string(), r.color, {{"V", &r.visibility}});
    std::ifstream in(file, std::ios::binary);
    out.bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  } catch (...) {
    std::error_code ec;
    fs::remove_all(dir, ec);
    throw;
  }
  std::error_code ec;
  fs::remove_all(dir, ec);
  out.content_type = request.format == "png" ? "image/png" : "image/x-exr";
  out.stats = {{"method", request.method},     {"light_samples", request.spp}, {"seed", request.seed},
               {"frames", request.frames},     {"params", r.resolved_params},  {"total_ms", r.total_ms},
               {"resolution", {scene.camera.width, scene.camera.height}}};
  return out;
}

// ---------------------------------------------------------------- the render thread

void ViewerSession::set_status(json status) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto& [k, v] : status.items()) status_[k] = v;
}

bool ViewerSession::publish(const std::string& name, uint64_t generation, json meta, const Image& image,
                            uint64_t Counters::*count) {
  std::vector<uint8_t> rgba = to_rgba8(image);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    // Never a frame of an old view: the page would jump back to where the user was.
    if (generation != generation_) {
      ++counters_.stale_dropped;
      return false;
    }
    meta["generation"] = generation;
    meta["width"] = image.width();
    meta["height"] = image.height();
    Layer& l = layers_[name];
    l.meta = std::move(meta);
    l.rgba = std::move(rgba);
    l.seq = ++seq_;
    // Counted with the publication, so whoever sees the frame sees the count.
    if (count) ++(counters_.*count);
  }
  frames_cv_.notify_all();
  return true;
}

std::string ViewerSession::renderer_key(const std::string& method, const Snapshot& s) const {
  const json params = merged_method_params(scene_, s.settings);
  return fmt::format("{}|{}|{}", method, s.settings.spp, params.contains(method) ? params[method].dump() : "{}");
}

Renderer& ViewerSession::renderer(const std::string& method, const Snapshot& s) {
  const std::string key = renderer_key(method, s);
  auto it = renderers_.find(key);
  if (it == renderers_.end()) {
    // Each holds a copy of the scene and its own Embree (or GPU) scene: keep those in use (the
    // preview setting, the auto preview's current choices, the final and compare methods) and
    // drop the others.
    for (auto e = renderers_.begin(); e != renderers_.end();) {
      const std::string m = e->first.substr(0, e->first.find('|'));
      const bool in_use = m == auto_camera_ || m == auto_light_ || m == s.settings.preview ||
                          m == s.settings.final_method || m == s.settings.compare;
      e = in_use && e->first == renderer_key(m, s) ? std::next(e) : renderers_.erase(e);
    }
    RenderSettings rs;
    rs.method = method;
    rs.light_samples = s.settings.spp;
    rs.device = options_.device;
    // The map cache is the CPU's (lam's maps); a GPU render refuses it.
    if (!options_.device.gpu) rs.map_cache = options_.map_cache;
    it = renderers_.emplace(key, std::make_unique<Renderer>(scene_for(s.settings, s.view), rs)).first;
  }
  Renderer& r = *it->second;
  r.set_lights(s.view.parsed_lights);
  r.set_camera(s.view.parsed_camera);
  r.set_first_frame(0);
  return r;
}

ViewerSession::Job ViewerSession::next_job(Clock::time_point now) {
  Job job;
  if (frame_requests_ > 0) {
    job.wake_at = Clock::time_point::max();  // woken when the frame request is done
    return job;
  }
  if (pending_preview_) {
    job.kind = JobKind::Preview;
    job.camera_changed = pending_camera_;
    job.lights_changed = pending_lights_;
    pending_preview_ = pending_camera_ = pending_lights_ = false;
    return job;
  }
  if (refined_generation_ != generation_) {
    const auto start = last_change_ + std::chrono::milliseconds(options_.idle_ms);
    if (!refine_requested_ && now < start) {
      job.wake_at = start;
      status_["phase"] = "idle";
      return job;
    }
    job.kind = JobKind::Refine;
    return job;
  }
  if (!settings_.compare.empty() && compared_generation_ != generation_) {
    job.kind = JobKind::Compare;
    return job;
  }
  // Idle with a refined view: measure the auto preview's next candidate against it.
  if (reset_measurements_) {
    chooser_.reset_errors();
    calibrated_generation_ = 0;
    reset_measurements_ = false;
  }
  if (settings_.preview == "auto" && calibrated_generation_ != generation_) {
    job.kind = JobKind::Calibrate;
    return job;
  }
  status_["phase"] = "done";
  job.wake_at = Clock::time_point::max();
  return job;
}

void ViewerSession::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stop_) {
    Job job = next_job(Clock::now());
    if (job.kind == JobKind::None) {
      if (job.wake_at == Clock::time_point::max()) work_cv_.wait(lock);
      else work_cv_.wait_until(lock, job.wake_at);
      continue;
    }
    auto token = std::make_shared<CancelToken>();
    job_token_ = token;
    Snapshot s{generation_, view_, settings_};
    lock.unlock();
    bool stopped = false;
    try {
      ScopedCancelToken scope(token.get());
      std::lock_guard<std::mutex> render_lock(render_mutex_);
      switch (job.kind) {
        case JobKind::Preview: run_preview(s, job); break;
        case JobKind::Refine: run_accumulation(s, final_, s.settings.final_method, "main"); break;
        case JobKind::Compare: run_accumulation(s, compare_, s.settings.compare, "compare"); break;
        case JobKind::Calibrate: run_calibration(s); break;
        case JobKind::None: break;
      }
    } catch (const Cancelled&) {
      std::lock_guard<std::mutex> l(mutex_);
      ++counters_.cancelled;
    } catch (const Interrupted&) {
      stopped = true;  // Ctrl-C: the server is going down
    } catch (const std::exception& e) {
      // The method refused (a parameter, the memory budget): say so, keep the last frame, and
      // do not retry this generation.
      std::lock_guard<std::mutex> l(mutex_);
      status_["error"] = e.what();
      status_["phase"] = "error";
      if (job.kind == JobKind::Refine && s.generation == generation_) refined_generation_ = s.generation;
      if (job.kind == JobKind::Compare && s.generation == generation_) compared_generation_ = s.generation;
      ++seq_;  // the page learns about the error at its next poll
      frames_cv_.notify_all();
    }
    lock.lock();
    job_token_.reset();
    if (stopped) stop_ = true;
  }
  frames_cv_.notify_all();
}

bool ViewerSession::renderer_ready(const std::string& m, const Snapshot& s) {
  auto it = renderers_.find(renderer_key(m, s));
  if (it == renderers_.end()) return false;
  it->second->set_lights(s.view.parsed_lights);  // keeps the structures of unchanged lights
  return it->second->prepared();
}

void ViewerSession::run_preview(const Snapshot& s, const Job& job) {
  std::string method = s.settings.preview;
  json auto_status = nullptr;
  if (method == "auto") {
    // From the session's measurements on its device (preview_choice.h), never a fixed list.
    auto ready = [&](const std::string& m) { return renderer_ready(m, s); };
    const PreviewChooser::Choice light = chooser_.choose(true, ready, s.settings.final_method);
    const PreviewChooser::Choice camera = chooser_.choose(false, ready, s.settings.final_method);
    auto_light_ = light.method;
    auto_camera_ = camera.method;
    const PreviewChooser::Choice& c = job.lights_changed ? light : camera;
    method = c.method;
    auto_status = {{"method", c.method},
                   {"move", job.lights_changed ? "light" : "camera"},
                   {"ms", c.ms < 0 ? json(nullptr) : json(c.ms)},
                   {"error", c.error < 0 ? json(nullptr) : json(c.error)},
                   {"reason", c.reason}};
  }
  set_status({{"phase", "preview"}, {"method", method}, {"frame", 0}, {"frames", 0}, {"error", ""},
              {"auto", auto_status}});
  float& scale = preview_scale_.try_emplace(method, 1.0f).first->second;
  const float used = s.settings.preview_scale > 0 ? s.settings.preview_scale : scale;
  Camera cam = s.view.parsed_camera;
  cam.width = std::max(16, static_cast<int>(std::lround(cam.width * used)));
  cam.height = std::max(16, static_cast<int>(std::lround(cam.height * used)));
  Renderer& r = renderer(method, s);
  r.set_camera(cam);
  Timer timer;
  RenderResult res = r.render();
  const double ms = timer.elapsed_ms();
  if (s.settings.preview_scale <= 0) {
    // Auto scale: aim at 80% of the frame-time target; the pixel count goes with the time.
    const double target = options_.preview_target_ms * 0.8;
    if (ms > options_.preview_target_ms || (ms < target * 0.5 && scale < 1.0f))
      scale = std::clamp(static_cast<float>(scale * std::sqrt(target / std::max(ms, 1.0))), 0.125f, 1.0f);
  }
  publish("main", s.generation,
          {{"method", method}, {"kind", "preview"}, {"frame", 1}, {"frames", 1}, {"ms", ms},
           {"scale", used}, {"auto", auto_status}, {"light_samples", light_samples_json(method, s.settings.spp)}},
          res.color, &Counters::previews);
}

void ViewerSession::run_calibration(const Snapshot& s) {
  // Against the final method's refined V of this very view (run_accumulation finished it).
  if (final_.key != accumulation_key(s, s.settings.final_method) || final_.frames_done < s.settings.frames) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (s.generation == generation_) calibrated_generation_ = s.generation;
    return;
  }
  const std::string method = chooser_.next_to_calibrate();
  if (method.empty()) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (s.generation == generation_) calibrated_generation_ = s.generation;
    status_["calibration"] = chooser_.to_json();
    return;
  }
  set_status({{"phase", "measuring"}, {"method", method}});
  Camera cam = s.view.parsed_camera;
  const float scale = std::min(1.0f, std::sqrt(static_cast<float>(options_.calibration_pixels) /
                                               std::max(1, cam.width * cam.height)));
  cam.width = std::max(16, static_cast<int>(std::lround(cam.width * scale)));
  cam.height = std::max(16, static_cast<int>(std::lround(cam.height * scale)));
  try {
    // A renderer of its own: its first frame builds the light-space structures (a light move's
    // cost), its second reuses them (a camera move's). It is kept for the previews after.
    Scene scene = scene_for(s.settings, s.view);
    scene.camera = cam;
    RenderSettings rs;
    rs.method = method;
    rs.light_samples = s.settings.spp;
    rs.device = options_.device;
    if (!options_.device.gpu) rs.map_cache = options_.map_cache;  // lam's maps: read or written there
    auto r = std::make_unique<Renderer>(scene, rs);
    Timer t1;
    r->render();
    const double light_ms = t1.elapsed_ms();
    Timer t2;
    const RenderResult second = r->render();
    const double camera_ms = t2.elapsed_ms();
    const Image truth = downsample(final_.mean_visibility(), second.visibility.width(), second.visibility.height());
    double sum = 0;
    for (size_t i = 0; i < truth.data().size(); ++i) sum += std::abs(truth.data()[i] - second.visibility.data()[i]);
    const double error = truth.data().empty() ? 0 : sum / static_cast<double>(truth.data().size());
    chooser_.record_calibration(method, light_ms, camera_ms, error, scale);
    renderers_[renderer_key(method, s)] = std::move(r);
  } catch (const Interrupted&) {
    throw;  // a newer view (the measurement starts over for the next) or Ctrl-C
  } catch (const std::exception&) {
    chooser_.record_failure(method);  // it cannot render this scene here: never chosen
  }
  std::lock_guard<std::mutex> lock(mutex_);
  ++counters_.calibrations;
  status_["calibration"] = chooser_.to_json();
}

std::string ViewerSession::accumulation_key(const Snapshot& s, const std::string& method) const {
  const json params = merged_method_params(scene_, s.settings);
  return json{{"camera", s.view.camera},
              {"lights", s.view.lights},
              {"method", method},
              {"spp", s.settings.spp},
              {"params", params.contains(method) ? params[method] : json::object()}}
      .dump();
}

void ViewerSession::run_accumulation(const Snapshot& s, Accumulation& acc, const std::string& method,
                                     const char* layer) {
  const bool is_final = std::string(layer) == "main";
  const int frames = s.settings.frames;
  // A change of something else (the compare method, the number of frames, a cancellation by
  // /api/frame) keeps the frames already summed.
  const std::string key = accumulation_key(s, method);
  if (acc.key != key || acc.frames_done > frames) {
    acc = Accumulation{};
    acc.key = key;
  }
  auto meta = [&](double ms) {
    return json{{"method", method}, {"kind", "final"}, {"frame", acc.frames_done}, {"frames", frames}, {"ms", ms},
                {"scale", 1.0}, {"light_samples", light_samples_json(method, s.settings.spp)}, {"mean_dv", nullptr}};
  };
  if (acc.frames_done == frames) publish(layer, s.generation, meta(acc.last_ms), acc.mean_color());
  Renderer& r = renderer(method, s);
  while (acc.frames_done < frames) {
    set_status({{"phase", is_final ? "refining" : "comparing"},
                {"method", method},
                {"frame", acc.frames_done},
                {"frames", frames},
                {"error", ""}});
    // Frame k draws the light samples of --frames' frame k (RenderSettings::first_frame).
    r.set_first_frame(acc.frames_done);
    Timer timer;
    RenderResult res = r.render();
    const double ms = timer.elapsed_ms();
    add_into(acc.color_sum, res.color);
    add_into(acc.vis_sum, res.visibility);
    ++acc.frames_done;
    acc.last_ms = ms;
    publish(layer, s.generation, meta(ms), acc.mean_color(),
            is_final ? &Counters::final_frames : &Counters::compare_frames);
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (s.generation == generation_) {
      (is_final ? refined_generation_ : compared_generation_) = s.generation;
      status_["frame"] = acc.frames_done;
    }
  }
  if (!is_final || !s.settings.compare.empty()) publish_diff(s);
}

void ViewerSession::publish_diff(const Snapshot& s) {
  if (final_.key != accumulation_key(s, s.settings.final_method) || compare_.key != accumulation_key(s, s.settings.compare))
    return;
  if (final_.frames_done != s.settings.frames || compare_.frames_done != s.settings.frames) return;
  const Image a = final_.mean_visibility(), b = compare_.mean_visibility();
  if (a.width() != b.width() || a.height() != b.height()) return;
  Image d(a.width(), a.height(), 1);
  double sum = 0;
  for (size_t i = 0; i < d.pixel_count(); ++i) {
    d.data()[i] = std::abs(a.data()[i] - b.data()[i]);
    sum += d.data()[i];
  }
  const double mean_dv = d.pixel_count() ? sum / static_cast<double>(d.pixel_count()) : 0.0;
  // The compare report's colour scale (eval/heatmap.h: magma on [0, scale]).
  const Heatmap h = absolute_heatmap(d, s.settings.heatmap_scale);
  publish("diff", s.generation,
          {{"method", s.settings.final_method + " vs " + s.settings.compare}, {"kind", "final"},
           {"frame", s.settings.frames}, {"frames", s.settings.frames}, {"ms", 0}, {"scale", 1.0},
           {"light_samples", nullptr}, {"mean_dv", mean_dv},
           {"heatmap", {{"lo", h.lo}, {"hi", h.hi}, {"legend", h.legend()}}}},
          h.image);
  std::lock_guard<std::mutex> lock(mutex_);
  if (s.generation == generation_) {
    auto it = layers_.find("compare");
    if (it != layers_.end()) {
      it->second.meta["mean_dv"] = mean_dv;
      it->second.seq = ++seq_;
    }
    status_["mean_dv"] = mean_dv;
  }
}

}  // namespace penumbra::viewer
