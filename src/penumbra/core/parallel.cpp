#include "penumbra/core/parallel.h"

#include "penumbra/core/interrupt.h"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/blocked_range2d.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

// ThreadSanitizer (the PENUMBRA_TSAN build, scripts/tsan.sh, docs/reliability.md) sees only
// instrumented code, and Debian's libtbb is not: TBB hands a loop's ranges and bodies from
// thread to thread inside libtbb, where TSan cannot see the synchronisation, so every loop
// reads as a race. In that build the loops below run on plain std::threads instead (an
// atomic counter hands out the grains; join is the synchronisation, which TSan sees), so
// what TSan checks is penumbra's own bodies and the data they share. Every parallel loop of
// penumbra goes through this file. Same grains, same results (keyed by index, not thread).
#if defined(__SANITIZE_THREAD__)
#define PENUMBRA_THREAD_SANITIZER 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define PENUMBRA_THREAD_SANITIZER 1
#endif
#endif

namespace penumbra {

#ifdef PENUMBRA_THREAD_SANITIZER
namespace {
// The loops' threads in the ThreadSanitizer build: persistent, like TBB's workers, so that
// per-thread state (tbb::enumerable_thread_specific, keyed by thread) is never handed from a
// finished thread to a new one, which TSan would rightly flag. A loop started inside another
// loop's body runs on its calling thread alone.
class TsanThreadPool {
 public:
  // item(0), ..., item(count - 1) on max_threads() threads (the caller one of them); the
  // first exception stops the others from taking new items and is rethrown after all finish.
  void run(size_t count, const std::function<void(size_t)>& item) {
    if (inside_loop_) {
      for (size_t i = 0; i < count; ++i) item(i);
      return;
    }
    std::lock_guard<std::mutex> one_loop_at_a_time(run_mutex_);
    const int helpers = std::max(0, max_threads() - 1);
    {
      std::unique_lock<std::mutex> lock(mutex_);
      while (static_cast<int>(threads_.size()) < helpers) {
        const int index = static_cast<int>(threads_.size());
        threads_.emplace_back([this, index] { work(index); });
      }
      item_ = &item;
      count_ = count;
      next_ = 0;
      error_ = nullptr;
      failed_ = false;
      helpers_ = helpers;
      running_ = helpers;
      ++generation_;
    }
    wake_.notify_all();
    take_items();
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [&] { return running_ == 0; });
    item_ = nullptr;
    if (error_) std::rethrow_exception(error_);
  }

  ~TsanThreadPool() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : threads_) t.join();
  }

 private:
  void take_items() {
    inside_loop_ = true;
    for (size_t i; !failed_.load() && (i = next_.fetch_add(1)) < count_;) {
      try {
        (*item_)(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!error_) error_ = std::current_exception();
        failed_ = true;
      }
    }
    inside_loop_ = false;
  }
  void work(int index) {
    uint64_t seen = 0;
    for (;;) {
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
        if (stop_) return;
        seen = generation_;
        if (index >= helpers_) continue;  // fewer threads allowed now (ThreadLimit)
      }
      take_items();
      std::lock_guard<std::mutex> lock(mutex_);
      if (--running_ == 0) done_.notify_all();
    }
  }

  std::mutex run_mutex_, mutex_;
  std::condition_variable wake_, done_;
  std::vector<std::thread> threads_;
  const std::function<void(size_t)>* item_ = nullptr;
  size_t count_ = 0;
  std::atomic<size_t> next_{0};
  std::atomic<bool> failed_{false};
  std::exception_ptr error_;
  int helpers_ = 0, running_ = 0;
  uint64_t generation_ = 0;
  bool stop_ = false;
  static thread_local bool inside_loop_;
};
thread_local bool TsanThreadPool::inside_loop_ = false;

void run_on_threads(size_t count, const std::function<void(size_t)>& item) {
  static TsanThreadPool pool;
  pool.run(count, item);
}
}  // namespace
#endif

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
  // The caller's cancel token goes with each grain to whichever thread runs it.
  const CancelToken* token = current_cancel_token();
  const size_t step = grain == 0 ? 1 : grain;
  // TBB's chunks can hold thousands of grains (it splits further only when a thread is idle),
  // so the body runs grain by grain and Ctrl-C is checked before each (core/interrupt.h):
  // the exception cancels the loop within one grain's work. The same check sees the caller's
  // CancelToken (the viewer cancelling stale work).
#ifdef PENUMBRA_THREAD_SANITIZER
  run_on_threads((n + step - 1) / step, [&](size_t g) {
    ScopedCancelToken carried(token);
    throw_if_interrupted();
    body(g * step, std::min(n, (g + 1) * step));
  });
#else
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, step), [&](const tbb::blocked_range<size_t>& r) {
    ScopedCancelToken carried(token);
    for (size_t b = r.begin(); b < r.end(); b += step) {
      throw_if_interrupted();
      body(b, std::min(r.end(), b + step));
    }
  });
#endif
}

void parallel_for_tiles(int width, int height, int tile,
                        const std::function<void(int, int, int, int)>& body) {
  if (width <= 0 || height <= 0) return;
  int tx = (width + tile - 1) / tile, ty = (height + tile - 1) / tile;
  throw_if_interrupted();
  const CancelToken* token = current_cancel_token();
#ifdef PENUMBRA_THREAD_SANITIZER
  run_on_threads(static_cast<size_t>(tx) * ty, [&](size_t t) {
    ScopedCancelToken carried(token);
    throw_if_interrupted();
    const int i = static_cast<int>(t % tx), j = static_cast<int>(t / tx);
    body(i * tile, j * tile, std::min(width, (i + 1) * tile), std::min(height, (j + 1) * tile));
  });
#else
  tbb::parallel_for(tbb::blocked_range2d<int>(0, ty, 1, 0, tx, 1),
                    [&](const tbb::blocked_range2d<int>& r) {
                      ScopedCancelToken carried(token);
                      throw_if_interrupted();
                      for (int j = r.rows().begin(); j < r.rows().end(); ++j)
                        for (int i = r.cols().begin(); i < r.cols().end(); ++i)
                          body(i * tile, j * tile, std::min(width, (i + 1) * tile),
                               std::min(height, (j + 1) * tile));
                    });
#endif
}

}  // namespace penumbra
