#include "penumbra/core/interrupt.h"

#include <semaphore.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <set>
#include <thread>

namespace penumbra {
namespace {

std::atomic<bool> g_interrupted{false};
std::atomic<bool> g_message_claimed{false};  // "interrupted" is printed once (claim_interrupt_message)
sem_t g_signalled;  // posted by the handler (sem_post is async-signal-safe)

std::mutex& files_mutex() {
  static std::mutex m;
  return m;
}
std::set<std::string>& files() {
  static std::set<std::string> f;
  return f;
}

extern "C" void on_signal(int) {
  if (!g_interrupted.exchange(true)) sem_post(&g_signalled);
}

// Waits for the first signal, gives the run a second to unwind by itself, then removes what
// is left and ends the process.
void watchdog() {
  while (sem_wait(&g_signalled) != 0) {
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(900));
  {
    std::unique_lock<std::mutex> lock(files_mutex(), std::try_to_lock);
    if (lock.owns_lock())
      for (const std::string& f : files()) ::unlink(f.c_str());
  }
  // The run may have printed its line already and be slow to exit (static destructors, a
  // sanitizer's shutdown): end it without a second line.
  if (claim_interrupt_message()) {
    static const char msg[] = "penumbra: error: interrupted\n";
    [[maybe_unused]] ssize_t n = ::write(STDERR_FILENO, msg, sizeof(msg) - 1);
  }
  ::_exit(130);
}

}  // namespace

void install_interrupt_handlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    sem_init(&g_signalled, 0, 0);
    struct sigaction sa {};
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
    std::thread(watchdog).detach();
  });
}

bool interrupted() { return g_interrupted.load(std::memory_order_relaxed); }

bool claim_interrupt_message() { return !g_message_claimed.exchange(true); }

namespace {
thread_local const CancelToken* t_cancel_token = nullptr;
}  // namespace

void throw_if_interrupted() {
  if (interrupted()) throw Interrupted();
  if (t_cancel_token && t_cancel_token->cancelled()) throw Cancelled();
}

ScopedCancelToken::ScopedCancelToken(const CancelToken* token) : previous_(t_cancel_token) { t_cancel_token = token; }
ScopedCancelToken::~ScopedCancelToken() { t_cancel_token = previous_; }

const CancelToken* current_cancel_token() { return t_cancel_token; }

void register_temporary_file(const std::string& path) {
  std::lock_guard<std::mutex> lock(files_mutex());
  files().insert(path);
}

void unregister_temporary_file(const std::string& path) {
  std::lock_guard<std::mutex> lock(files_mutex());
  files().erase(path);
}

}  // namespace penumbra
