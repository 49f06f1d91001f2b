// The state behind `penumbra view` (docs/viewer.md): the scene, the current view and
// settings, and one render thread that turns them into frames. agrawala2000 §1's workflow:
// while the view changes, the render thread draws previews with a fast method; once the
// view has been still for a moment, the final method refines the frame progressively
// (sintorn2008 §4.2's accumulation); a newer view cancels whatever runs (core/interrupt.h's
// CancelToken) and no frame of an old view is ever published.
//
// Everything here is independent of HTTP: ViewerServer (viewer_server.h) maps requests to
// these calls, and tests drive a session directly too.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "penumbra/core/image.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene/scene.h"
#include "penumbra/viewer/preview_choice.h"
#include "penumbra/viewer/viewer_requests.h"

namespace penumbra::viewer {

struct SessionOptions {
  // How long the view must be still before the final method starts (agrawala2000's
  // "stops moving"; docs/viewer.md).
  int idle_ms = 300;
  // The preview's frame-time target in auto scale: above it the preview resolution drops.
  double preview_target_ms = 1000.0 / 15;
  // RenderSettings::map_cache for every render (`penumbra view --map-cache DIR`): lam's maps,
  // built once the view is still, are written there and read back by a later session with
  // the same geometry and lights, whose first camera move then previews at display cost.
  std::filesystem::path map_cache;
  // Where every render of the session runs (`penumbra view --device`): the CPU or a GPU. The
  // methods offered are those with a version on it.
  gpu::DeviceChoice device;
  // The most pixels the auto preview's candidates are measured at (the view scaled down to it).
  int calibration_pixels = 128 * 128;
};

// One finished frame of the current view as an image file (GET /api/frame).
struct FrameFile {
  std::string bytes;
  std::string content_type;  // image/png or image/x-exr
  nlohmann::json stats;      // the --stats-json document of the render
};

class ViewerSession {
 public:
  // `scene_doc` is the scene file's document, `scene` what it parsed to.
  ViewerSession(Scene scene, nlohmann::json scene_doc, SessionOptions options = {});
  ~ViewerSession();  // stops the render thread
  ViewerSession(const ViewerSession&) = delete;
  ViewerSession& operator=(const ViewerSession&) = delete;

  // GET /api/scene: the scene document with the current camera, lights and method parameters.
  nlohmann::json scene_document() const;
  // GET /api/scene-file: the same with mesh paths made absolute, so it renders from anywhere.
  nlohmann::json scene_file_document() const;
  // The name a saved scene file is offered under: "<scene file's stem>-view.json".
  std::string scene_file_name() const;
  // GET /api/methods: every method, with the devices it runs on and whether this session's does.
  nlohmann::json methods_json() const;
  // GET /api/state: the view (camera and lights resolved: every default filled in, so the page
  // reads no key a scene file may leave out), the settings, the status and the counters.
  nlohmann::json state() const;
  ViewerSettings settings() const;

  // POST /api/view, /api/settings, /api/refine, /api/reset. Each throws Error (one line) on a
  // bad request and changes nothing then; each returns the generation after the change.
  uint64_t update_view(const nlohmann::json& patch);
  nlohmann::json update_settings(const nlohmann::json& body);
  uint64_t refine_now();
  uint64_t reset_view();

  // GET /api/poll: the layers published after `after`, in the binary format of docs/viewer.md.
  // False when none came within timeout_ms (or the session stops).
  bool poll(uint64_t after, int timeout_ms, std::string* body);

  // GET /api/frame: a render of the current view with `request`'s method and samples, the
  // bytes `penumbra render` writes for the scene scene_file_document() describes.
  FrameFile render_frame(const FrameRequest& request);

  // What the render thread did (tests, GET /api/state).
  struct Counters {
    uint64_t previews = 0;        // preview frames published
    uint64_t final_frames = 0;    // frames of the final method published
    uint64_t compare_frames = 0;  // frames of the compare method published
    uint64_t cancelled = 0;       // renders stopped by a newer view, settings or frame request
    uint64_t stale_dropped = 0;   // finished frames of an old view, not published
    uint64_t calibrations = 0;    // auto-preview candidates measured
  };
  Counters counters() const;
  uint64_t generation() const;

  void stop();

 private:
  enum class JobKind { None, Preview, Refine, Compare, Calibrate };
  struct Job {
    JobKind kind = JobKind::None;
    std::chrono::steady_clock::time_point wake_at{};  // for None: when to look again (max: never)
    bool camera_changed = false, lights_changed = false;
  };
  struct Snapshot {  // what one job renders, copied under the lock
    uint64_t generation = 0;
    ViewState view;
    ViewerSettings settings;
  };
  // A progressive render of one method at the view's full resolution: the sums of its
  // frames 0 .. frames_done - 1, valid while `key` (accumulation_key) holds.
  struct Accumulation {
    std::string key;
    int frames_done = 0;
    double last_ms = 0;  // the last frame's time
    Image color_sum, vis_sum;
    Image mean_color() const;
    Image mean_visibility() const;
  };
  struct Layer {
    nlohmann::json meta;
    std::vector<uint8_t> rgba;
    uint64_t seq = 0;
  };

  void run();
  Job next_job(std::chrono::steady_clock::time_point now);  // with mutex_ held
  void run_preview(const Snapshot& s, const Job& job);
  // Measures the next auto-preview candidate at this view (PreviewChooser).
  void run_calibration(const Snapshot& s);
  // Whether method m's renderer holds light-space structures for the snapshot's lights.
  bool renderer_ready(const std::string& m, const Snapshot& s);
  void run_accumulation(const Snapshot& s, Accumulation& acc, const std::string& method, const char* layer);
  // What an accumulation of `method` depends on: the view, --spp and the method's parameters.
  std::string accumulation_key(const Snapshot& s, const std::string& method) const;
  void publish_diff(const Snapshot& s);
  // Publishes a layer unless `generation` is no longer current (then counts it as stale),
  // and then adds one to the counter `count` (if given).
  bool publish(const std::string& name, uint64_t generation, nlohmann::json meta, const Image& image,
               uint64_t Counters::*count = nullptr);
  void set_status(nlohmann::json status);
  // The renderer of `method` at the snapshot's settings (kept between frames while they hold).
  Renderer& renderer(const std::string& method, const Snapshot& s);
  // The key renderers_ keeps it under: the method, --spp and its parameters.
  std::string renderer_key(const std::string& method, const Snapshot& s) const;
  Scene scene_for(const ViewerSettings& settings, const ViewState& view) const;
  // Cancels the running job; with mutex_ held.
  void cancel_job();
  void changed(bool preview);  // a new generation; with mutex_ held

  const Scene scene_;
  const nlohmann::json doc_;
  const SessionOptions options_;
  const Bounds3f bounds_;
  const ViewState initial_view_;
  std::string device_name_ = "cpu";  // the device's name (a GPU's, from Vulkan)

  mutable std::mutex mutex_;  // everything below up to the render thread's own state
  std::condition_variable work_cv_, frames_cv_;
  ViewState view_;
  ViewerSettings settings_;
  uint64_t generation_ = 1;
  bool pending_preview_ = false, pending_camera_ = false, pending_lights_ = false;
  bool refine_requested_ = false;
  std::chrono::steady_clock::time_point last_change_;
  std::shared_ptr<CancelToken> job_token_;
  int frame_requests_ = 0;  // /api/frame renders waiting for or holding render_mutex_
  bool stop_ = false;
  uint64_t seq_ = 0;
  std::map<std::string, Layer> layers_;
  nlohmann::json status_;
  Counters counters_;
  uint64_t refined_generation_ = 0, compared_generation_ = 0;  // done (or failed) for these
  uint64_t calibrated_generation_ = 0;  // no candidate left to measure at this generation
  bool reset_measurements_ = false;      // the final method changed: its errors are stale
  // The auto preview's measurements and choice (render thread; to_json copied to status_).
  PreviewChooser chooser_;
  std::string auto_camera_, auto_light_;  // its current choices: their renderers are kept

  std::mutex render_mutex_;  // one render at a time: the render thread's or /api/frame's

  // The render thread's own state.
  std::map<std::string, std::unique_ptr<Renderer>> renderers_;  // by method + settings key
  std::map<std::string, float> preview_scale_;                  // auto scale per method
  Accumulation final_, compare_;
  std::thread thread_;
};

// Linear RGB (a render's colour, a Heatmap's image) to RGBA8 in sRGB, the bytes of the PNG
// write_image makes of it, with alpha 255.
std::vector<uint8_t> to_rgba8(const Image& image);

}  // namespace penumbra::viewer
