// penumbra render SCENE [-m METHOD] [--spp N] [--frames K] [--resolution N|WxH] [--crop X0,Y0,X1,Y1] [-o OUT] ...
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>

#include "app/command.h"
#include "app/common.h"
#include "penumbra/core/file_util.h"
#include "penumbra/core/image.h"
#include "penumbra/core/parallel.h"
#include "penumbra/eval/run_setup.h"
#include "penumbra/render/renderer.h"
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
  bool coherent_shading = false;
  std::vector<std::string> params;
  std::string memory_limit;
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
  RunSetup setup = RunSetup::from_file(o.scene);
  if (!o.resolution.empty()) setup.apply("resolution", o.resolution);
  if (o.pixel_samples > 0) setup.apply("pixel_samples", std::to_string(o.pixel_samples));
  setup.light_samples = setup.reference_samples = o.spp;
  setup.seed = o.seed;
  const nlohmann::json request = {{"command", "render"}, {"setup", run_setup_json(setup)},
                                  {"method", o.method},   {"params", o.params},
                                  {"spp", o.spp},         {"seed", o.seed},
                                  {"frames", o.frames},   {"tile", o.tile},
                                  {"meshes", o.meshes},   {"frame_out", ""},
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

int run_render(const RenderOptions& o) {
  ThreadLimit limit(o.threads);
  Scene scene = load_scene(o.scene);
  apply_camera_overrides(scene, o.resolution, o.pixel_samples);
  PixelWindow crop;
  if (!o.crop.empty()) {
    if (!parse_pixel_window(o.crop, &crop))
      throw Error("--crop {}: expected X0,Y0,X1,Y1 (pixels, X0 < X1, Y0 < Y1), e.g. 0,0,256,128", o.crop);
    if (!crop.inside(scene.camera.width, scene.camera.height))
      throw Error("--crop {}: outside the {}x{} image", o.crop, scene.camera.width, scene.camera.height);
  }
  std::string out = o.output.empty()
                        ? fmt::format("{}-{}.png", std::filesystem::path(o.scene).stem().string(), o.method)
                        : o.output;
  check_output_path(out, {".png", ".exr"});
  if (!o.visibility_out.empty()) check_output_path(o.visibility_out, {".png", ".exr"});

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
    std::string samples =
        MethodRegistry::get(o.method).samples_light ? fmt::format(", {} light samples", o.spp) : std::string();
    const std::string window = o.crop.empty() ? std::string() : " cropped to " + crop.to_string();
    std::fprintf(stderr, "%s: %s, %dx%d%s%s: %.1f ms (%.1f ms camera pass), %llu shadow rays -> %s\n", o.scene.c_str(),
                 o.method.c_str(), scene.camera.width, scene.camera.height, window.c_str(), samples.c_str(), r.total_ms,
                 r.camera_pass_ms, static_cast<unsigned long long>(r.stats.rays_traced), out.c_str());
  }
  return 0;
}

const CommandRegistration registration("render", 10, [](CLI::App& app) {
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
  cmd->add_option("-o,--output", o->output, "output image, .png (sRGB) or .exr (linear, with a V channel)");
  cmd->add_option("--visibility-out", o->visibility_out, "also write V alone (.png or .exr)");
  cmd->add_option("--stats-json", o->stats_json, "write timings and counters as JSON");
  cmd->add_option("--seed", o->seed, "random seed")->capture_default_str();
  cmd->add_option("--threads", o->threads, "worker threads (0 = all cores)")->capture_default_str()->check(CLI::Range(0, 1024));
  cmd->add_option("--frames", o->frames,
                  "progressive accumulation: average this many frames, each with new light samples (sintorn2008 §4.2)")
      ->capture_default_str()->check(CLI::Range(1, 100000));
  cmd->add_flag("--coherent-shading", o->coherent_shading,
                "bend the shading of smooth closed meshes toward their faces (sintorn2008 §4.3, c = 3): no light on "
                "light back-facing triangles");
  cmd->add_option("-p,--param", o->params, "method parameter key=value (repeatable)");
  cmd->add_option("--memory-limit", o->memory_limit,
                  "refuse a render whose view samples, images and method maps would need more (e.g. 8G; default: "
                  "80% of physical memory)");
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
