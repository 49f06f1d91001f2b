// libFuzzer target: scene file text -> parse_json_text -> parse_scene, the path every
// `penumbra render SCENE` takes. Bad input must end in a penumbra::Error (the one-line
// message the CLI prints); anything else (a crash, a sanitizer report, another exception,
// a hang, running out of memory) is a finding. Seeds: the suite's scenes (fuzz/corpus/scene).
//
//   build-san/fuzz_scene -max_total_time=600 -timeout=10 -rss_limit_mb=4096 out/corpus-scene fuzz/corpus/scene
#include <cstddef>
#include <cstdint>
#include <string>

#include "penumbra/core/error.h"
#include "penumbra/scene/json_reader.h"
#include "penumbra/scene/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    // Relative mesh paths resolve against a folder that does not exist, so the fuzzer
    // explores the parser, not the file system.
    const nlohmann::json doc = penumbra::parse_json_text(text, "fuzz.json");
    penumbra::Scene scene = penumbra::parse_scene(doc, "/nonexistent-penumbra-fuzz/fuzz.json");
  } catch (const penumbra::Error&) {
  }
  return 0;
}
