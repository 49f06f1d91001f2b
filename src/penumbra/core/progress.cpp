#include "penumbra/core/progress.h"

#include "penumbra/core/interrupt.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace penumbra {

Progress::Progress(std::string label, uint64_t total, bool enabled)
    : label_(std::move(label)), total_(total), enabled_(enabled && ::isatty(STDERR_FILENO)) {}

Progress::~Progress() { finish(); }

void Progress::set_label(std::string label) {
  std::lock_guard<std::mutex> lock(mutex_);
  label_ = std::move(label);
}

void Progress::add(uint64_t n) {
  throw_if_interrupted();
  if (!enabled_) return;
  uint64_t done = done_.fetch_add(n) + n;
  uint64_t total = total_.load();
  int percent = total ? static_cast<int>(100 * std::min(done, total) / total) : 100;
  int last = last_percent_.load();
  if (percent > last && last_percent_.compare_exchange_strong(last, percent)) draw(done);
}

void Progress::draw(uint64_t done) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (finished_) return;
  uint64_t total = total_.load();
  double f = total ? std::min(1.0, static_cast<double>(done) / total) : 1.0;
  const int width = 30;
  int filled = static_cast<int>(f * width);
  std::string bar(filled, '#');
  bar.resize(width, '.');
  std::fprintf(stderr, "\r%s [%s] %3d%%\033[K", label_.c_str(), bar.c_str(), static_cast<int>(f * 100));
  std::fflush(stderr);
}

void Progress::finish() {
  if (!enabled_) return;
  std::lock_guard<std::mutex> lock(mutex_);
  if (finished_) return;
  finished_ = true;
  std::fprintf(stderr, "\r\033[K");
  std::fflush(stderr);
}

}  // namespace penumbra
