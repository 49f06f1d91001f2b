// Ctrl-C (SIGINT) and SIGTERM for the command-line tool: the run stops within a second and
// leaves no output and no temporary file behind (issue 17).
//
// The handler only sets a flag. Every parallel loop (core/parallel.h) and progress update
// checks it and throws Interrupted, so the run unwinds and AtomicFile's destructors remove
// their temporary files; main() prints one line and exits with 130. A long step that checks
// nowhere (a third-party call) is covered by a watchdog thread: a second after the signal it
// removes the temporary files still registered and ends the process with 130 itself.
#pragma once

#include <atomic>
#include <string>

#include "penumbra/core/error.h"

namespace penumbra {

// Thrown at the next check after SIGINT or SIGTERM.
class Interrupted : public Error {
 public:
  Interrupted() : Error("interrupted") {}

 protected:
  explicit Interrupted(const std::string& message) : Error(message) {}
};

// Installs the SIGINT and SIGTERM handlers and starts the watchdog (once; later calls do
// nothing). Libraries and tests that never call it are never interrupted.
void install_interrupt_handlers();

// Whether a signal has arrived; throw_if_interrupted() throws Interrupted if so, and
// Cancelled if the calling thread's CancelToken (below) is cancelled.
bool interrupted();
void throw_if_interrupted();
// True for the first caller only: whoever reports the interruption (the tool's main, or the
// watchdog when the run has not ended 0.9 s after the signal) prints the one line.
bool claim_interrupt_message();

// Cancelling one piece of work while the process goes on: the viewer (docs/viewer.md) cancels
// a refinement that a newer view made stale. The same checks that see Ctrl-C see a cancelled
// token: while a ScopedCancelToken lives on a thread, throw_if_interrupted() there throws
// Cancelled once the token is cancelled, and every parallel loop started there carries the
// token to its worker threads (core/parallel.cpp), so the work stops within one grain.
// An Interrupted, so every step that lets Ctrl-C through (catch Interrupted, rethrow) lets a
// cancellation through too; the code that cancelled catches it.
class Cancelled : public Interrupted {
 public:
  Cancelled() : Interrupted("cancelled") {}
};

class CancelToken {
 public:
  void cancel() { cancelled_.store(true, std::memory_order_relaxed); }
  bool cancelled() const { return cancelled_.load(std::memory_order_relaxed); }

 private:
  std::atomic<bool> cancelled_{false};
};

// Makes `token` the calling thread's token while it lives (null: none); restores the previous.
class ScopedCancelToken {
 public:
  explicit ScopedCancelToken(const CancelToken* token);
  ~ScopedCancelToken();
  ScopedCancelToken(const ScopedCancelToken&) = delete;
  ScopedCancelToken& operator=(const ScopedCancelToken&) = delete;

 private:
  const CancelToken* previous_;
};

// The calling thread's token (null when none).
const CancelToken* current_cancel_token();

// Temporary files the watchdog removes if it has to end the process (AtomicFile registers
// its own).
void register_temporary_file(const std::string& path);
void unregister_temporary_file(const std::string& path);

}  // namespace penumbra
