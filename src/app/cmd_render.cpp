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
#include "penumbra/render/renderer.h"

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
};

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
  RenderResult r = render_scene(scene, settings);

  write_image(out, r.color, {{"V", &r.visibility}});
  if (!o.visibility_out.empty()) write_image(o.visibility_out, r.visibility, {}, /*linear_png=*/true);
  if (!o.stats_json.empty()) {
    nlohmann::json j = render_stats_json(scene, o.method, settings, r);
    write_text_file_atomic(o.stats_json, j.dump(2) + "\n");
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
  return [o] { return run_render(*o); };
});

}  // namespace
}  // namespace penumbra::app
