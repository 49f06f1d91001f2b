// libFuzzer target: bytes -> a mesh file -> import_mesh, for every format penumbra reads. The
// first byte picks the extension (OBJ, PLY, STL, OFF, glTF, GLB), the rest is the file.
// Bad input must end in a penumbra::Error naming the file; a crash, sanitizer report, other
// exception, hang or out-of-memory is a finding (inside Assimp too: penumbra must not pass
// such files on). Seeds: small files of each format (fuzz/corpus/mesh).
//
//   build-san/fuzz_mesh -max_total_time=600 -timeout=10 -rss_limit_mb=4096 out/corpus-mesh fuzz/corpus/mesh
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "penumbra/core/error.h"
#include "penumbra/scene/mesh_import.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  static const char* const kExtensions[] = {".obj", ".ply", ".stl", ".off", ".gltf", ".glb"};
  const char* ext = kExtensions[data[0] % 6];
  // One folder per fuzzing process, removed when it exits.
  struct TempDir {
    std::filesystem::path path =
        std::filesystem::temp_directory_path() / ("penumbra-fuzz-mesh-" + std::to_string(::getpid()));
    TempDir() { std::filesystem::create_directories(path); }
    ~TempDir() {
      std::error_code ec;
      std::filesystem::remove_all(path, ec);
    }
  };
  static const TempDir dir;
  const std::filesystem::path file = dir.path / (std::string("input") + ext);
  {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data + 1), static_cast<std::streamsize>(size - 1));
  }
  try {
    penumbra::TriangleMesh mesh = penumbra::import_mesh(file);
  } catch (const penumbra::Error&) {
  }
  return 0;
}
