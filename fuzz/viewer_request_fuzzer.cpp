// libFuzzer target: what `penumbra view`'s server does with a request before any render
// (src/penumbra/viewer/viewer_requests.h). The first line of the input names the endpoint
// ("view", "settings", "frame", "poll"; anything else: "view"), the rest is the request:
// a JSON body for POST /api/view and /api/settings, a request target ("/api/frame?...") for
// the GET endpoints, parsed as the server parses it. Bad input must end in a penumbra::Error
// (the server's 400); anything else (a crash, a sanitizer report, another exception, a hang)
// is a finding. A view that parses is applied twice in a row (the state the server keeps).
// Seeds: fuzz/corpus/viewer_request.
//
//   build-san/fuzz_viewer_request -max_total_time=600 -timeout=10 out/corpus-vr fuzz/corpus/viewer_request
#include <cstddef>
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "penumbra/core/error.h"
#include "penumbra/viewer/viewer_requests.h"
#include "penumbra/viewer/viewer_server.h"

namespace {

const char* const kScene = R"({
  "camera": {"eye": [0, 1.6, 3.2], "target": [0, 0.4, 0], "fov_y": 40, "resolution": [32, 32]},
  "lights": [{"type": "rect", "center": [-1.2, 3.0, -0.8], "normal": [0.4, -0.9, 0.3], "size": [1.5, 1.5]},
             {"type": "sphere", "center": [1, 2, 0], "radius": 0.2}],
  "objects": [{"name": "ground", "shape": "plane", "size": [8, 8]},
              {"shape": "box", "size": [0.5, 0.5, 0.5], "translate": [0, 0.3, 0]}],
  "methods": {"pcss": {"blocker_samples": 16}}
})";

struct Fixture {
  nlohmann::json doc = nlohmann::json::parse(kScene);
  penumbra::Scene scene = penumbra::parse_scene(doc, "fuzz.json");
  penumbra::viewer::ViewState view = penumbra::viewer::view_from_document(doc, scene);
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace penumbra::viewer;
  static const Fixture f;
  const std::string input(reinterpret_cast<const char*>(data), size);
  const size_t nl = input.find('\n');
  const std::string endpoint = input.substr(0, nl), request = nl == std::string::npos ? "" : input.substr(nl + 1);
  try {
    if (endpoint == "settings") {
      ViewerSettings s = apply_settings(ViewerSettings{}, parse_request_body(request, "POST /api/settings"), f.scene);
      merged_method_params(f.scene, s);
      parse_frame_request({}, s);
    } else if (endpoint == "frame" || endpoint == "poll") {
      const auto query = parse_query_string(request);
      if (endpoint == "frame") parse_frame_request(query, ViewerSettings{});
      for (const auto& [key, value] : query) {
        parse_query_integer(key, value, 0, 30000);
        is_loopback_host_header(value);
      }
    } else {
      bool camera = false, lights = false;
      const nlohmann::json patch = parse_request_body(request, "POST /api/view");
      ViewState next = apply_view_patch(f.view, patch, f.scene.bounds(), &camera, &lights);
      apply_view_patch(next, patch, f.scene.bounds(), &camera, &lights);
      if (camera || lights) __builtin_trap();  // the same patch twice must change nothing the second time
    }
  } catch (const penumbra::Error&) {
    // A bad request, named: the server answers 400.
  }
  return 0;
}
