#include "app/common.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "penumbra/core/error.h"

namespace penumbra::app {

namespace fs = std::filesystem;

void apply_camera_overrides(Scene& scene, const std::string& resolution, int pixel_samples) {
  if (!resolution.empty() &&
      !parse_resolution(resolution, &scene.camera.width, &scene.camera.height))
    throw Error("--resolution {}: expected N or WxH with sides in [1, 16384], e.g. 256 or 512x384", resolution);
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

}  // namespace penumbra::app
