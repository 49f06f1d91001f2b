// penumbra render SCENE [-m METHOD] [--spp N] [--frames K] [--resolution N|WxH] [--crop X0,Y0,X1,Y1] [-o OUT] ...
//                      [--frame-range A:B -o out/frame_####.exr | -o movie.mp4]
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>

#include <fmt/format.h>

#include "app/command.h"
#include "app/common.h"
#include "app/sequence.h"
#include "penumbra/core/file_util.h"
#include "penumbra/core/image.h"
#include "penumbra/core/parallel.h"
#include "penumbra/eval/run_setup.h"
#include "penumbra/core/progress.h"
#include "penumbra/render/renderer.h"
#include "penumbra/render/sequence_renderer.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/json_reader.h"

namespace penumbra::app {
namespace {

struct RenderOptions {
  std::string scene;
  std::string method = "reference";
  int spp = 256;
  std::string resolution;
  std::string crop;
  int pixel_samples = 0;
  std::string output;
  std::string visibility_out;
  std::string stats_json;
  uint64_t seed = 0;
  int threads = 0;
  int frames = 1;
  std::string frame_range;  // an animated scene's frames A:B (half-open)
  bool coherent_shading = false;
  std::vector<std::string> params;
  std::string memory_limit;
  std::string map_cache;  // a folder of light-space data kept between runs
  std::string device = "cpu";  // --device cpu | gpu | gpu:N
  bool quiet = false;
  std::string dask;             // a Dask scheduler's address: the frame's tiles render there
  int tile = 256;               // with --dask: the tiles' side in pixels
  std::string meshes = "ship";  // with --dask: ship the mesh files, or read them from a shared path
};

// The frame as tiles on a Dask cluster (penumbra.distributed, docs/distributed.md): the same
// pixels as the local render, read back from the frame the cluster's client writes. A
// non-zero *exit_status: the cluster's side failed (and printed its one-line error).
RenderResult render_on_dask(const RenderOptions& o, nlohmann::json* stats, int* exit_status) {
  if (!o.crop.empty()) throw Error("--crop: not available with --dask (render a window locally)");
  if (o.coherent_shading) throw Error("--coherent-shading: not available with --dask");
  if (!o.memory_limit.empty()) throw Error("--memory-limit: not available with --dask (each worker has its own)");
  if (!o.map_cache.empty()) throw Error("--map-cache: not available with --dask");
  RunSetup setup = RunSetup::from_file(o.scene);
  if (!o.resolution.empty()) setup.apply("resolution", o.resolution);
  if (o.pixel_samples > 0) setup.apply("pixel_samples", std::to_string(o.pixel_samples));
  setup.light_samples = setup.reference_samples = o.spp;
  setup.seed = o.seed;
  setup.device = gpu::DeviceChoice::parse(o.device).to_string();  // each tile on its worker's GPU
  const nlohmann::json request = {{"command", "render"}, {"setup", run_setup_json(setup)},
                                  {"method", o.method},   {"params", o.params},
                                  {"spp", o.spp},         {"seed", o.seed},
                                  {"frames", o.frames},   {"tile", o.tile},
                                  {"meshes", o.meshes},   {"frame_out", ""},
                                  {"device", setup.device},
                                  {"stats_out", ""}};
  RenderResult r;
  *exit_status = run_on_dask(request, o.dask, [&](const nlohmann::json& sent) {
    const std::string frame = sent["frame_out"].get<std::string>();
    r.color = read_image(frame);
    r.visibility = read_exr_channel(frame, "V");
    *stats = read_json_file(sent["stats_out"].get<std::string>());
  });
  if (*exit_status != 0) return r;
  (*stats)["dask"] = o.dask;
  r.total_ms = stats->value("wall_ms", 0.0);
  r.camera_pass_ms = stats->value("camera_pass_ms", 0.0);
  r.stats.rays_traced = (*stats)["stats"].value("rays_traced", uint64_t{0});
  return r;
}

// --crop, checked against the scene's image.
PixelWindow read_crop(const RenderOptions& o, const Scene& scene) {
  PixelWindow crop;
  if (o.crop.empty()) return crop;
  if (!parse_pixel_window(o.crop, &crop))
    throw Error("--crop {}: expected X0,Y0,X1,Y1 (pixels, X0 < X1, Y0 < Y1), e.g. 0,0,256,128", o.crop);
  if (!crop.inside(scene.camera.width, scene.camera.height))
    throw Error("--crop {}: outside the {}x{} image", o.crop, scene.camera.width, scene.camera.height);
  return crop;
}

RenderSettings render_settings(const RenderOptions& o, const PixelWindow& crop) {
  RenderSettings settings;
  settings.method = o.method;
  settings.params = o.params;
  settings.light_samples = o.spp;
  settings.seed = o.seed;
  settings.frames = o.frames;
  settings.coherent_shading = o.coherent_shading;
  settings.crop = crop;
  settings.progress = !o.quiet;
  if (!o.memory_limit.empty()) settings.memory_limit = parse_memory_size(o.memory_limit, "--memory-limit");
  settings.map_cache = o.map_cache;
  settings.device = gpu::DeviceChoice::parse(o.device);
  return settings;
}

// "reference, 512x512 cropped to ..., 256 light samples": what the summary line says was rendered.
std::string render_description(const RenderOptions& o, const Scene& scene, const PixelWindow& crop) {
  const std::string samples =
      MethodRegistry::get(o.method).samples_light ? fmt::format(", {} light samples", o.spp) : std::string();
  const std::string window = o.crop.empty() ? std::string() : " cropped to " + crop.to_string();
  const std::string device = o.device == "cpu" ? std::string() : " on " + o.device;
  return fmt::format("{}{}, {}x{}{}{}", o.method, device, scene.camera.width, scene.camera.height, window, samples);
}

// `--frame-range A:B` (or `-o movie.mp4`): the frames of an animated scene, one render each
// (docs/scene-format.md, "Animation"), written to a numbered file each or encoded to an MP4.
// Every frame renders with the same seed, so frame t equals a render of the scene at t alone.
int run_render_sequence(const RenderOptions& o) {
  const bool movie = is_mp4(o.output);
  // The option that asked for a sequence, for messages.
  const std::string asked = o.frame_range.empty() ? "-o " + o.output : "--frame-range " + o.frame_range;
  if (!o.dask.empty()) throw Error("{}: not available with --dask (render the frames locally)", asked);
  if (o.output.empty())
    throw Error("{}: give -o out/frame_####.exr (a run of # for the frame number) or -o movie.mp4", asked);
  // Every output is checked, and ffmpeg looked for, before the scene is loaded.
  if (movie) {
    check_output_path(o.output, {".mp4"});
    require_ffmpeg("-o", o.output);
  } else {
    check_frame_pattern(o.output, "-o");
    check_output_path(o.output, {".png", ".exr"});
  }
  if (!o.visibility_out.empty()) {
    check_frame_pattern(o.visibility_out, "--visibility-out");
    check_output_path(o.visibility_out, {".png", ".exr"});
  }
  ThreadLimit limit(o.threads);
  Scene current = load_scene(o.scene);
  if (!current.animation) throw Error("{}: {} has no \"animation\" block (docs/scene-format.md)", asked, o.scene);
  const Animation& animation = *current.animation;
  const FrameRange range = parse_frame_range(o.frame_range.empty() ? ":" : o.frame_range, animation.frames,
                                             "--frame-range");
  apply_camera_overrides(current, o.resolution, o.pixel_samples);
  const PixelWindow crop = read_crop(o, current);
  RenderSettings settings = render_settings(o, crop);

  // One bar over the frames: each frame's renders advance it by at most their share (a view
  // sample per camera ray that hits), topped up when the frame is written.
  const PixelWindow window = crop_window(crop, current.camera);
  const uint64_t frame_units = static_cast<uint64_t>(window.width()) * window.height() *
                               current.camera.samples_per_pixel * current.lights.size() * std::max(1, o.frames);
  Progress bar("render", frame_units * range.count(), !o.quiet);
  settings.progress_bar = &bar;

  // The movie's frames go to a private folder, removed whatever happens.
  std::string frames_folder;
  struct RemoveFolder {
    std::string path;
    ~RemoveFolder() {
      std::error_code ec;
      if (!path.empty()) std::filesystem::remove_all(path, ec);
    }
  } remove_frames;
  if (movie) {
    char folder_template[] = "/tmp/penumbra-frames-XXXXXX";
    if (!::mkdtemp(folder_template)) throw Error("{}: cannot create a temporary folder in /tmp for the frames", o.output);
    frames_folder = remove_frames.path = folder_template;
  }

  SequenceRenderer sequence(current, settings);
  double total_ms = 0;
  uint64_t rays = 0;
  int moved_frames = 0, refit_frames = 0;
  nlohmann::json stats = nlohmann::json::array();
  for (int f = range.begin; f < range.end; ++f) {
    bar.set_label(fmt::format("render frame {} ({}/{})", f, f - range.begin + 1, range.count()));
    const SequenceRenderer::Frame frame = sequence.render(f);
    const RenderResult& r = frame.result;
    total_ms += r.total_ms + frame.geometry_update_ms;
    rays += r.stats.rays_traced;
    moved_frames += frame.moved_objects > 0;
    refit_frames += frame.refit;
    const std::string out = movie ? (std::filesystem::path(frames_folder) / mp4_frame_name(f)).string()
                                  : frame_path(o.output, f);
    write_image(out, r.color, {{"V", &r.visibility}});
    if (!o.visibility_out.empty())
      write_image(frame_path(o.visibility_out, f), r.visibility, {}, /*linear_png=*/true);
    if (!o.stats_json.empty()) {
      nlohmann::json frame_stats = render_stats_json(sequence.scene(), o.method, settings, r);
      frame_stats["frame"] = f;
      frame_stats["new_renderer"] = frame.new_renderer;
      frame_stats["moved_objects"] = frame.moved_objects;
      frame_stats["refit"] = frame.refit;
      frame_stats["geometry_update_ms"] = frame.geometry_update_ms;
      stats.push_back(std::move(frame_stats));
      // Rewritten after every frame: an interrupted sequence keeps the stats of its frames.
      write_text_file_atomic(o.stats_json, stats.dump(2) + "\n");
    }
    const uint64_t done = frame_units * (f - range.begin + 1);
    if (bar.done() < done) bar.add(done - bar.done());
  }
  bar.finish();
  if (movie) encode_mp4(frames_folder, range.begin, animation.fps, o.output);
  if (!o.quiet) {
    // Frames where objects moved, and whether their BVHs were refit (rather than rebuilt).
    const std::string moves =
        moved_frames == 0 ? std::string()
                          : fmt::format(", objects moved in {}, {}", moved_frames,
                                        refit_frames == moved_frames ? "refit"
                                                                     : fmt::format("{} refit", refit_frames));
    std::fprintf(stderr, "%s: %s, frames %d:%d (%d%s): %.1f ms, %.1f ms per frame, %llu shadow rays -> %s\n",
                 o.scene.c_str(), render_description(o, current, crop).c_str(), range.begin, range.end, range.count(),
                 moves.c_str(), total_ms, total_ms / range.count(), static_cast<unsigned long long>(rays),
                 o.output.c_str());
  }
  return 0;
}

int run_render(const RenderOptions& o) {
  if (!o.frame_range.empty() || is_mp4(o.output)) return run_render_sequence(o);
  ThreadLimit limit(o.threads);
  Scene scene = load_scene(o.scene);
  apply_camera_overrides(scene, o.resolution, o.pixel_samples);
  const PixelWindow crop = read_crop(o, scene);
  std::string out = o.output.empty()
                        ? fmt::format("{}-{}.png", std::filesystem::path(o.scene).stem().string(), o.method)
                        : o.output;
  check_output_path(out, {".png", ".exr"});
  if (!o.visibility_out.empty()) check_output_path(o.visibility_out, {".png", ".exr"});

  RenderSettings settings = render_settings(o, crop);
  nlohmann::json stats;
  if (!o.dask.empty()) resolve_method_params(o.method, scene, o.params);  // bad ones fail before the cluster is asked
  int exit_status = 0;
  RenderResult r = o.dask.empty() ? render_scene(scene, settings) : render_on_dask(o, &stats, &exit_status);
  if (exit_status != 0) return exit_status;

  write_image(out, r.color, {{"V", &r.visibility}});
  if (!o.visibility_out.empty()) write_image(o.visibility_out, r.visibility, {}, /*linear_png=*/true);
  if (!o.stats_json.empty()) {
    if (o.dask.empty()) stats = render_stats_json(scene, o.method, settings, r);
    write_text_file_atomic(o.stats_json, stats.dump(2) + "\n");
  }
  if (!o.quiet) {
    // On a GPU, the GPU time of the frame's stages beside the wall time (which includes the upload).
    const std::string gpu = r.gpu_ms.is_object()
                                ? fmt::format(", GPU {:.2f} ms on {}", r.gpu_ms.value("total", 0.0), r.device)
                                : std::string();
    std::fprintf(stderr, "%s: %s: %.1f ms (%.1f ms camera pass%s), %llu shadow rays -> %s\n", o.scene.c_str(),
                 render_description(o, scene, crop).c_str(), r.total_ms, r.camera_pass_ms, gpu.c_str(),
                 static_cast<unsigned long long>(r.stats.rays_traced), out.c_str());
  }
  return 0;
}

const CommandRegistration render_command("render", 10, [](CLI::App& app) {
  auto o = std::make_shared<RenderOptions>();
  CLI::App* cmd = app.add_subcommand("render", "render a scene with one shadow method");
  cmd->add_option("scene", o->scene, "scene file (JSON)")->required();
  cmd->add_option("-m,--method", o->method, "shadow method (see `penumbra methods`)")->capture_default_str();
  cmd->add_option("--spp", o->spp, "light samples per shading point, for every method that samples the light")
      ->capture_default_str()->check(CLI::Range(1, 1 << 20));
  cmd->add_option("--resolution", o->resolution, "image size N or WxH (overrides the scene's camera)");
  cmd->add_option("--crop", o->crop,
                  "render only the pixels [X0,X1) x [Y0,Y1) of the image and write that window (a tile of a frame "
                  "rendered in parts; see `penumbra methods NAME` for the methods whose tiles equal the whole "
                  "frame bit for bit)");
  cmd->add_option("--pixel-samples", o->pixel_samples, "jittered camera samples per pixel (overrides the scene)")
      ->check(CLI::Range(1, 1024));
  cmd->add_option("-o,--output", o->output,
                  "output image, .png (sRGB) or .exr (linear, with a V channel); with --frame-range a pattern whose "
                  "run of # is the frame number (out/frame_####.exr), or a .mp4 (encoded by ffmpeg; all frames "
                  "without --frame-range)");
  cmd->add_option("--visibility-out", o->visibility_out,
                  "also write V alone (.png or .exr; with --frame-range a pattern, as -o)");
  cmd->add_option("--stats-json", o->stats_json,
                  "write timings and counters as JSON (with --frame-range an array, one object per frame)");
  cmd->add_option("--frame-range", o->frame_range,
                  "render the frames A to B-1 of an animated scene (A:B; A: to the last, :B from the first), one "
                  "output per frame (docs/scene-format.md, Animation)");
  cmd->add_option("--seed", o->seed, "random seed")->capture_default_str();
  cmd->add_option("--threads", o->threads, "worker threads (0 = all cores)")->capture_default_str()->check(CLI::Range(0, 1024));
  cmd->add_option("--frames", o->frames,
                  "progressive accumulation: average this many frames, each with new light samples (sintorn2008 §4.2); "
                  "with --frame-range, for each frame of the animation")
      ->capture_default_str()->check(CLI::Range(1, 100000));
  cmd->add_flag("--coherent-shading", o->coherent_shading,
                "bend the shading of smooth closed meshes toward their faces (sintorn2008 §4.3, c = 3): no light on "
                "light back-facing triangles");
  cmd->add_option("-p,--param", o->params, "method parameter key=value (repeatable)");
  cmd->add_option("--memory-limit", o->memory_limit,
                  "refuse a render whose view samples, images and method maps would need more (e.g. 8G; default: "
                  "80% of physical memory)");
  cmd->add_option("--map-cache", o->map_cache,
                  "keep light-space maps in this folder between runs (created if needed): a method that can (lam) "
                  "reads them instead of precomputing when the geometry, lights, parameters, seed and --spp are "
                  "the same; hits and sizes in --stats-json (docs/animation.md)");
  cmd->add_option("--device", o->device,
                  "where the frame renders: cpu, gpu (the first usable Vulkan device) or gpu:N (`penumbra devices`); "
                  "`penumbra methods` shows which methods run on the GPU (docs/gpu.md)")
      ->capture_default_str();
  cmd->add_flag("-q,--quiet", o->quiet, "no progress bar or summary");
  cmd->add_option("--dask", o->dask,
                  "render the frame as tiles on the Dask scheduler at tcp://HOST:PORT (docs/distributed.md)");
  cmd->add_option("--tile", o->tile, "with --dask: the side of a tile in pixels")
      ->capture_default_str()->check(CLI::Range(1, 16384));
  cmd->add_option("--meshes", o->meshes, "with --dask: ship the mesh files to the workers, or read them from a shared path")
      ->check(CLI::IsMember({"ship", "shared"}))->capture_default_str();
  return [o] { return run_render(*o); };
});

}  // namespace
}  // namespace penumbra::app
