// Helpers shared by the CLI subcommands.
#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "penumbra/render/renderer.h"
#include "penumbra/scene/scene.h"

namespace penumbra::app {

// --resolution N or WxH and --pixel-samples N applied to the scene's camera (0/empty: keep).
void apply_camera_overrides(Scene& scene, const std::string& resolution, int pixel_samples);
// --resolution's value (N or WxH) as width and height; a bad value is a one-line error.
std::pair<int, int> resolution_option(const std::string& resolution);
// Checks an output path before any work: a known extension and an existing folder.
void check_output_path(const std::string& path, const std::vector<std::string>& extensions);
// "--memory-limit" values: bytes, or a number with K, M, G or T (binary units: 8G = 8 GiB).
uint64_t parse_memory_size(const std::string& text, const std::string& option);
// Creates the output folder `dir` (and its parents); throws naming it if that fails or
// it is a file.
void make_output_folder(const std::string& dir);
// The command line of this process, as typed (arguments with spaces quoted), for reports.
std::string command_line();

// `--dask tcp://HOST:PORT` (compare, sweep, render): runs `request` (a JSON object: "command",
// "setup" (run_setup_json), the command's options and outputs) on that Dask scheduler through
// the Python package, `python3 -m penumbra.distributed --request FILE` (docs/distributed.md),
// and returns its exit status (it prints its own one-line error). Outputs it hands back (the
// request's "frame_out" and "stats_out", given any value, become files in a temporary folder)
// are read by `on_success`, called with the request as sent, before that folder is removed.
// Throws an Error when this penumbra was built without the Python module or the address is
// not tcp://HOST:PORT.
int run_on_dask(nlohmann::json request, const std::string& address,
                const std::function<void(const nlohmann::json&)>& on_success = {});

}  // namespace penumbra::app
