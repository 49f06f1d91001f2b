// Ctrl-C (SIGINT) and SIGTERM for the command-line tool: the run stops within a second and
// leaves no output and no temporary file behind (issue 17).
//
// The handler only sets a flag. Every parallel loop (core/parallel.h) and progress update
// checks it and throws Interrupted, so the run unwinds and AtomicFile's destructors remove
// their temporary files; main() prints one line and exits with 130. A long step that checks
// nowhere (a third-party call) is covered by a watchdog thread: a second after the signal it
// removes the temporary files still registered and ends the process with 130 itself.
#pragma once

#include <string>

#include "penumbra/core/error.h"

namespace penumbra {

// Thrown at the next check after SIGINT or SIGTERM.
class Interrupted : public Error {
 public:
  Interrupted() : Error("interrupted") {}
};

// Installs the SIGINT and SIGTERM handlers and starts the watchdog (once; later calls do
// nothing). Libraries and tests that never call it are never interrupted.
void install_interrupt_handlers();

// Whether a signal has arrived; throw_if_interrupted() throws Interrupted if so.
bool interrupted();
void throw_if_interrupted();
// True for the first caller only: whoever reports the interruption (the tool's main, or the
// watchdog when the run has not ended 0.9 s after the signal) prints the one line.
bool claim_interrupt_message();

// Temporary files the watchdog removes if it has to end the process (AtomicFile registers
// its own).
void register_temporary_file(const std::string& path);
void unregister_temporary_file(const std::string& path);

}  // namespace penumbra
