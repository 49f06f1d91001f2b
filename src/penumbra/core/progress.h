// A progress bar on stderr for long runs, drawn only when stderr is a terminal. Safe to
// advance from worker threads; redraws at most every 1%.
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>
#include <string>

namespace penumbra {

class Progress {
 public:
  // enabled=false (or stderr not a terminal) makes every call a no-op.
  Progress(std::string label, uint64_t total, bool enabled);
  ~Progress();
  void set_total(uint64_t total) { total_ = total; }
  uint64_t total() const { return total_.load(); }
  // Units added so far (0 when disabled: add() is then a no-op).
  uint64_t done() const { return done_.load(); }
  // The text before the bar (e.g. the method now running in a comparison).
  void set_label(std::string label);
  void add(uint64_t n);
  void finish();

 private:
  void draw(uint64_t done);
  std::string label_;
  std::atomic<uint64_t> total_;
  std::atomic<uint64_t> done_{0};
  std::atomic<int> last_percent_{-1};
  std::mutex mutex_;
  bool enabled_;
  bool finished_ = false;
};

}  // namespace penumbra
