// Running another program from the CLI (ffmpeg for `render -o movie.mp4`, Python for `--dask`).
#pragma once

#include <string>
#include <vector>

namespace penumbra::app {

// Whether `name` is an executable file in one of $PATH's folders (what running it would find).
bool on_path(const std::string& name);

struct ProgramOptions {
  // "NAME=value" entries set in the program's environment (replacing ours of that name).
  std::vector<std::string> environment;
  // On Ctrl-C or SIGTERM: 0 kills the program at once; otherwise it is sent SIGINT first, to
  // stop cleanly (Python's KeyboardInterrupt), and killed when it has not after this many ms.
  int interrupt_grace_ms = 0;
};

// Runs args[0] (looked up on $PATH) with `args`, its standard input closed, and waits for it.
// Returns its exit status (128 + the signal's number when a signal ended it). Ctrl-C or
// SIGTERM stops it (options.interrupt_grace_ms) and throws Interrupted, so nothing it would
// write appears after we exit. Throws an Error naming the program when it cannot be started.
int run_program(const std::vector<std::string>& args, const ProgramOptions& options = {});

}  // namespace penumbra::app
