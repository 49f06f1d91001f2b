// Running another program from the CLI (ffmpeg for `render -o movie.mp4`).
#pragma once

#include <string>
#include <vector>

namespace penumbra::app {

// Whether `name` is an executable file in one of $PATH's folders (what running it would find).
bool on_path(const std::string& name);

// Runs args[0] (looked up on $PATH) with `args`, its standard input closed, and waits for it.
// Returns its exit status (128 + the signal's number when a signal ended it). Ctrl-C or
// SIGTERM kills it and throws Interrupted, so nothing it would write appears after we exit.
// Throws an Error naming the program when it cannot be started.
int run_program(const std::vector<std::string>& args);

}  // namespace penumbra::app
