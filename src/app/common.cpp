#include "app/common.h"

#include <algorithm>
#include <filesystem>
#include <functional>
#include <fstream>
#include <iterator>
#include <regex>
#include <tuple>

#include <unistd.h>

#include "app/process.h"
#include "penumbra/core/error.h"
#include "penumbra/core/file_util.h"

namespace penumbra::app {

namespace fs = std::filesystem;

std::pair<int, int> resolution_option(const std::string& resolution) {
  int w = 0, h = 0;
  if (!parse_resolution(resolution, &w, &h))
    throw Error("--resolution {}: expected N or WxH with sides in [1, 16384], e.g. 256 or 512x384", resolution);
  return {w, h};
}

void apply_camera_overrides(Scene& scene, const std::string& resolution, int pixel_samples) {
  if (!resolution.empty()) std::tie(scene.camera.width, scene.camera.height) = resolution_option(resolution);
  if (pixel_samples > 0) scene.camera.samples_per_pixel = pixel_samples;
}

void check_output_path(const std::string& path, const std::vector<std::string>& extensions) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (std::find(extensions.begin(), extensions.end(), ext) == extensions.end()) {
    std::string list;
    for (const auto& e : extensions) list += (list.empty() ? "" : ", ") + e;
    throw Error("{}: unsupported output extension '{}' (use {})", path, ext, list);
  }
  fs::path parent = fs::path(path).parent_path();
  if (!parent.empty() && !fs::is_directory(parent)) throw Error("{}: folder {} does not exist", path, parent.string());
}

void make_output_folder(const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir)) throw Error("{}: cannot create the output folder{}", dir, ec ? ": " + ec.message() : std::string(" (a file of that name exists)"));
}

std::string command_line() {
  std::ifstream f("/proc/self/cmdline", std::ios::binary);
  std::string all((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  std::string out, arg;
  auto flush = [&] {
    bool quote = arg.empty() || arg.find_first_of(" \t\"'$&|;<>()*?") != std::string::npos;
    out += (out.empty() ? "" : " ") + (quote ? "'" + arg + "'" : arg);
    arg.clear();
  };
  for (char c : all) {
    if (c == '\0') flush();
    else arg += c;
  }
  if (!arg.empty()) flush();
  return out;
}

uint64_t parse_memory_size(const std::string& text, const std::string& option) {
  size_t used = 0;
  double value = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  std::string unit = text.substr(used);
  double scale = 1;
  if (unit == "K" || unit == "k") scale = 1024.0;
  else if (unit == "M" || unit == "m") scale = 1024.0 * 1024;
  else if (unit == "G" || unit == "g") scale = 1024.0 * 1024 * 1024;
  else if (unit == "T" || unit == "t") scale = 1024.0 * 1024 * 1024 * 1024;
  else if (!unit.empty()) used = 0;
  if (used == 0 || !(value > 0) || value * scale > 1.8e19)
    throw Error("{} {}: expected a size in bytes, or with K, M, G or T (e.g. 8G)", option, text);
  return static_cast<uint64_t>(value * scale);
}

namespace {

// The interpreter and the folder holding the `penumbra` package: $PENUMBRA_PYTHON and
// $PENUMBRA_PYTHONPATH, else what CMake built (the build tree's python/ folder while it
// exists, else the installed package's folder).
std::pair<std::string, std::string> python_and_path() {
  std::string python, path, missing;
#ifdef PENUMBRA_PYTHON_EXECUTABLE
  python = PENUMBRA_PYTHON_EXECUTABLE;
  path = fs::exists(fs::path(PENUMBRA_PYTHON_BUILD_DIR) / "penumbra" / "distributed.py") ? PENUMBRA_PYTHON_BUILD_DIR
                                                                                         : PENUMBRA_PYTHON_INSTALL_PATH;
  // README command 1 builds the tool alone.
  missing = fmt::format("neither built in {} (scripts/setup.sh --with-python builds it) nor installed in {}",
                        PENUMBRA_PYTHON_BUILD_DIR, PENUMBRA_PYTHON_INSTALL_PATH);
#endif
  if (const char* p = std::getenv("PENUMBRA_PYTHON"); p && *p) python = p;
  const char* env_path = std::getenv("PENUMBRA_PYTHONPATH");
  if (env_path && *env_path) path = env_path;
  if (python.empty())
    throw Error("--dask: this penumbra was built without its Python module (cmake -DPENUMBRA_BUILD_PYTHON=ON), "
                "or set PENUMBRA_PYTHON and PENUMBRA_PYTHONPATH");
  if (!missing.empty() && !(env_path && *env_path) && !fs::exists(fs::path(path) / "penumbra" / "distributed.py"))
    throw Error("--dask: penumbra's Python module is {}; or set PENUMBRA_PYTHONPATH", missing);
  return {python, path};
}

}  // namespace

int run_on_dask(nlohmann::json request, const std::string& address,
                const std::function<void(const nlohmann::json&)>& on_success) {
  static const std::regex kAddress(R"((tcp|tls)://[A-Za-z0-9._\-\[\]:]+:[0-9]{1,5})");
  if (!std::regex_match(address, kAddress))
    throw Error("--dask {}: expected the scheduler's address, tcp://HOST:PORT", address);
  const auto [python, path] = python_and_path();
  request["scheduler"] = address;
  request["progress"] = ::isatty(2) == 1;
  // The request goes through a private temporary folder, removed whatever happens.
  char folder_template[] = "/tmp/penumbra-dask-XXXXXX";
  if (!::mkdtemp(folder_template)) throw Error("--dask: cannot create a temporary folder in /tmp");
  const fs::path folder = folder_template;
  struct Remove {
    fs::path p;
    ~Remove() {
      std::error_code ec;
      fs::remove_all(p, ec);
    }
  } remove{folder};
  const fs::path request_file = folder / "request.json";
  if (request.contains("frame_out")) request["frame_out"] = (folder / "frame.exr").string();
  if (request.contains("stats_out")) request["stats_out"] = (folder / "stats.json").string();
  write_text_file_atomic(request_file, request.dump());

  std::string pythonpath = path;
  if (const char* old = std::getenv("PYTHONPATH"); old && *old) pythonpath += std::string(":") + old;
  // Ctrl-C or SIGTERM: the client gets SIGINT (KeyboardInterrupt) and is killed if it has not
  // stopped before the interrupt watchdog's deadline, so nothing writes outputs after we exit.
  ProgramOptions options;
  options.environment = {"PYTHONPATH=" + pythonpath};
  options.interrupt_grace_ms = 600;
  const int code =
      run_program({python, "-m", "penumbra.distributed", "--request", request_file.string()}, options);
  if (code != 0) return code;
  if (on_success) on_success(request);  // reads the outputs in `folder` before it goes
  return 0;
}

}  // namespace penumbra::app
