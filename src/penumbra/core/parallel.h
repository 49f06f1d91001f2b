// Parallel loops over image tiles and index ranges (oneTBB). Work is split by index, never
// by thread, and randomness is keyed by index (rng.h), so results do not depend on the
// thread count.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>

namespace penumbra {

// Limits the worker threads of every parallel loop while it lives (0 = all cores).
class ThreadLimit {
 public:
  explicit ThreadLimit(int threads);
  ~ThreadLimit();
  ThreadLimit(const ThreadLimit&) = delete;
  ThreadLimit& operator=(const ThreadLimit&) = delete;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Worker threads a parallel loop may use now (the machine's cores, or a ThreadLimit's).
int max_threads();

// body(begin, end) over [0, n) in chunks of about `grain` indices.
void parallel_for(size_t n, size_t grain, const std::function<void(size_t, size_t)>& body);

// body(x0, y0, x1, y1) over width x height in square tiles of `tile` pixels.
void parallel_for_tiles(int width, int height, int tile,
                        const std::function<void(int, int, int, int)>& body);

}  // namespace penumbra
