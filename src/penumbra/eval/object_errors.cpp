#include "penumbra/eval/object_errors.h"

#include <fnmatch.h>

#include <algorithm>
#include <limits>

#include <fmt/format.h>

#include "penumbra/core/error.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene/scene.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {
namespace {

// The scene's object names for a message: the first few distinct ones, and how many more.
std::string names_for_message(const Scene& scene) {
  constexpr size_t kShown = 8;
  std::vector<std::string> names;
  for (const SceneObject& o : scene.objects)
    if (std::find(names.begin(), names.end(), o.name) == names.end()) names.push_back(o.name);
  std::string out;
  for (size_t i = 0; i < names.size() && i < kShown; ++i) out += (i ? ", " : "") + names[i];
  if (names.size() > kShown) out += fmt::format(" and {} more", names.size() - kShown);
  return out;
}

}  // namespace

std::vector<std::vector<uint8_t>> match_object_patterns(const Scene& scene, const std::vector<std::string>& patterns) {
  std::vector<std::vector<uint8_t>> matches;
  for (const std::string& pattern : patterns) {
    if (pattern.empty()) throw Error("--objects: an empty pattern (give object names or shell-style patterns, comma-separated)");
    std::vector<uint8_t> match(scene.objects.size(), 0);
    bool any = false;
    for (size_t i = 0; i < scene.objects.size(); ++i)
      if (fnmatch(pattern.c_str(), scene.objects[i].name.c_str(), 0) == 0) match[i] = 1, any = true;
    if (!any)
      throw Error("--objects: '{}' matches no object of the scene (its objects: {})", pattern, names_for_message(scene));
    matches.push_back(std::move(match));
  }
  return matches;
}

std::vector<ObjectGroup> object_groups(const Scene& scene, const std::vector<std::string>& patterns, uint64_t seed) {
  const std::vector<std::vector<uint8_t>> matches = match_object_patterns(scene, patterns);
  std::vector<ObjectGroup> groups(patterns.size());
  for (size_t k = 0; k < groups.size(); ++k) {
    groups[k].pattern = patterns[k];
    groups[k].objects = static_cast<size_t>(std::count(matches[k].begin(), matches[k].end(), uint8_t{1}));
  }
  if (groups.empty()) return groups;
  const RayTracer tracer(scene);
  const ViewSamples view = camera_pass(scene, tracer, seed);
  for (ObjectGroup& g : groups) g.mask = Image(view.width, view.height, 1, 0.0f);
  for (const ViewSample& s : view.samples) {
    if (s.sub != 0) continue;  // a pixel counts by its first camera ray
    const int x = static_cast<int>(s.pixel % static_cast<uint32_t>(view.width));
    const int y = static_cast<int>(s.pixel / static_cast<uint32_t>(view.width));
    for (size_t k = 0; k < groups.size(); ++k)
      if (matches[k][s.object] && groups[k].mask.at(x, y) == 0.0f) {
        groups[k].mask.at(x, y) = 1.0f;
        ++groups[k].pixels;
      }
  }
  return groups;
}

std::vector<ErrorStats> object_errors(const Image& test, const Image& reference, const std::vector<ObjectGroup>& groups) {
  std::vector<ErrorStats> out;
  for (const ObjectGroup& g : groups) {
    if (g.pixels == 0) {
      ErrorStats none;
      none.mae = none.rmse = none.max_abs = none.mean_signed = none.psnr = std::numeric_limits<double>::quiet_NaN();
      out.push_back(none);
      continue;
    }
    MetricOptions options;
    options.mask = &g.mask;
    out.push_back(compare_images(test, reference, options));
  }
  return out;
}

}  // namespace penumbra
