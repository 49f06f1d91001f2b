#include "penumbra/core/parallel.h"

#include "penumbra/core/interrupt.h"

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/blocked_range2d.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

namespace penumbra {

struct ThreadLimit::Impl {
  std::unique_ptr<tbb::global_control> control;
};

int max_threads() { return static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)); }

ThreadLimit::ThreadLimit(int threads) : impl_(std::make_unique<Impl>()) {
  if (threads > 0)
    impl_->control = std::make_unique<tbb::global_control>(
        tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));
}

ThreadLimit::~ThreadLimit() = default;

void parallel_for(size_t n, size_t grain, const std::function<void(size_t, size_t)>& body) {
  if (n == 0) return;
  throw_if_interrupted();
  const size_t step = grain == 0 ? 1 : grain;
  // TBB's chunks can hold thousands of grains (it splits further only when a thread is idle),
  // so the body runs grain by grain and Ctrl-C is checked before each (core/interrupt.h):
  // the exception cancels the loop within one grain's work.
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, step), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t b = r.begin(); b < r.end(); b += step) {
      throw_if_interrupted();
      body(b, std::min(r.end(), b + step));
    }
  });
}

void parallel_for_tiles(int width, int height, int tile,
                        const std::function<void(int, int, int, int)>& body) {
  if (width <= 0 || height <= 0) return;
  int tx = (width + tile - 1) / tile, ty = (height + tile - 1) / tile;
  throw_if_interrupted();
  tbb::parallel_for(tbb::blocked_range2d<int>(0, ty, 1, 0, tx, 1),
                    [&](const tbb::blocked_range2d<int>& r) {
                      throw_if_interrupted();
                      for (int j = r.rows().begin(); j < r.rows().end(); ++j)
                        for (int i = r.cols().begin(); i < r.cols().end(); ++i)
                          body(i * tile, j * tile, std::min(width, (i + 1) * tile),
                               std::min(height, (j + 1) * tile));
                    });
}

}  // namespace penumbra
