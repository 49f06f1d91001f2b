// Helpers shared by the CLI subcommands.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "penumbra/render/renderer.h"
#include "penumbra/scene/scene.h"

namespace penumbra::app {

// --resolution N or WxH and --pixel-samples N applied to the scene's camera (0/empty: keep).
void apply_camera_overrides(Scene& scene, const std::string& resolution, int pixel_samples);
// Checks an output path before any work: a known extension and an existing folder.
void check_output_path(const std::string& path, const std::vector<std::string>& extensions);
// "--memory-limit" values: bytes, or a number with K, M, G or T (binary units: 8G = 8 GiB).
uint64_t parse_memory_size(const std::string& text, const std::string& option);
// Creates the output folder `dir` (and its parents); throws naming it if that fails or
// it is a file.
void make_output_folder(const std::string& dir);
// The command line of this process, as typed (arguments with spaces quoted), for reports.
std::string command_line();

}  // namespace penumbra::app
