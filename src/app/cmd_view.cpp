// penumbra view SCENE [--port N] [--bind ADDR] [--no-browser] [--resolution N|WxH]: the interactive viewer
// (docs/viewer.md). Serves until Ctrl-C.
#include <spawn.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <thread>

#include <fmt/format.h>

#include "app/command.h"
#include "penumbra/gpu/device.h"
#include "app/common.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/parallel.h"
#include "penumbra/render/map_cache.h"
#include "penumbra/scene/json_reader.h"
#include "penumbra/viewer/viewer_server.h"

extern char** environ;

namespace penumbra::app {
namespace {

struct ViewOptions {
  std::string scene;
  int port = 8421;
  std::string bind = "127.0.0.1";
  bool no_browser = false;
  int threads = 0;
  int idle_ms = 300;
  std::string map_cache;
  std::string resolution;
  std::string device = "cpu";
};

// Opens `url` with $BROWSER or xdg-open, without a shell; a failure is a note, not an error
// (the address is printed anyway).
void open_browser(const std::string& url) {
  const char* browser = std::getenv("BROWSER");
  std::string program = browser && *browser ? browser : "xdg-open";
  char* argv[] = {program.data(), const_cast<char*>(url.c_str()), nullptr};
  pid_t pid = 0;
  if (posix_spawnp(&pid, program.c_str(), nullptr, nullptr, argv, environ) != 0) {
    std::fprintf(stderr, "penumbra view: could not start %s; open %s yourself\n", program.c_str(), url.c_str());
    return;
  }
  // Reap it in the background (xdg-open returns once the browser has started).
  std::thread([pid] { waitpid(pid, nullptr, 0); }).detach();
}

int run_view(const ViewOptions& o) {
  ThreadLimit limit(o.threads);
  nlohmann::json doc = read_json_file(o.scene);
  // As the scene's own camera.resolution: the view, its frames and a saved scene file have it.
  if (!o.resolution.empty() && doc.is_object() && doc.contains("camera") && doc["camera"].is_object()) {
    const auto [w, h] = resolution_option(o.resolution);
    doc["camera"]["resolution"] = {w, h};
  }
  Scene scene = parse_scene(doc, o.scene);
  viewer::SessionOptions session_options;
  session_options.idle_ms = o.idle_ms;
  session_options.device = gpu::DeviceChoice::parse(o.device);
  if (!o.map_cache.empty() && session_options.device.gpu)
    throw Error("--map-cache: not available with --device {} (the maps are the CPU's)", o.device);
  if (!o.map_cache.empty()) {
    MapCache check(o.map_cache);  // a bad folder fails here, in one line, before the server starts
    session_options.map_cache = o.map_cache;
  }
  viewer::ViewerSession session(std::move(scene), std::move(doc), session_options);
  viewer::ServerOptions server_options;
  server_options.bind = o.bind;
  server_options.port = o.port;
  viewer::ViewerServer server(session, server_options);
  std::printf("penumbra view: serving %s\n", server.url().c_str());
  std::fflush(stdout);
  if (!o.no_browser) open_browser(server.url());
  // Ctrl-C or SIGTERM ends the server (core/interrupt.h's handler sets the flag).
  while (!interrupted()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  // The session first: that releases the long polls (up to 30 s each), which the server
  // waits for before it stops.
  session.stop();
  server.stop();
  claim_interrupt_message();  // a server's normal end: no "interrupted" line
  std::fprintf(stderr, "penumbra view: stopped\n");
  return 0;
}

const CommandRegistration view_command("view", 35, [](CLI::App& app) {
  auto o = std::make_shared<ViewOptions>();
  CLI::App* cmd = app.add_subcommand(
      "view", "interactive viewer in the browser: preview while moving, refine when still (docs/viewer.md)");
  cmd->add_option("scene", o->scene, "scene file (JSON)")->required();
  cmd->add_option("--port", o->port, "port to listen on (the next free one if taken)")
      ->capture_default_str()->check(CLI::Range(1, 65535));
  cmd->add_option("--bind", o->bind,
                  "address to listen on; other hosts are refused unless it is a non-loopback address")
      ->capture_default_str();
  cmd->add_flag("--no-browser", o->no_browser, "do not open a browser");
  cmd->add_option("--threads", o->threads, "worker threads (0 = all cores)")->capture_default_str()->check(CLI::Range(0, 1024));
  cmd->add_option("--device", o->device,
                  "where previews and final frames render: cpu, gpu or gpu:N (docs/gpu.md); the page offers the "
                  "methods that run there")
      ->capture_default_str();
  cmd->add_option("--map-cache", o->map_cache,
                  "keep lam's maps in this folder between sessions (created if needed; docs/animation.md)");
  cmd->add_option("--resolution", o->resolution, "image size N or WxH (overrides the scene's camera)");
  cmd->add_option("--idle-ms", o->idle_ms, "how long the view must be still before the final method refines")
      ->capture_default_str()->check(CLI::Range(0, 60000));
  return [o] { return run_view(*o); };
});

}  // namespace
}  // namespace penumbra::app
