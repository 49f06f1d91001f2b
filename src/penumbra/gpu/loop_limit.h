// Long per-thread loops under a driver's loop limit. lavapipe (llvmpipe) stops every loop of an
// invocation once its loops have run 65535 iterations in all, without an error (docs/gpu.md):
// a kernel whose thread loops over many items (light samples, a tile's points) comes out silently
// short. Such a kernel takes its items as a range [first, first + count), ends with
// pn_loop_limit_hit(kLoopLimitCanary) (gpu/kernel_common.glsl) and raises a flag; the host runs
// the work through LoopLimitSplit, which retries with shorter ranges until no thread was cut.
// A GPU without such a limit runs every item in one dispatch, once.
#pragma once

#include <algorithm>
#include <string>
#include <string_view>

#include "penumbra/core/error.h"

namespace penumbra::gpu {

// The push constant a kernel passes to pn_loop_limit_hit.
inline constexpr int kLoopLimitCanary = 2;

class LoopLimitSplit {
 public:
  // Items per dispatch (0: not learned yet, all in one) and how often a cut forced a retry.
  int items_per_dispatch() const { return per_dispatch_; }
  int retries() const { return retries_; }
  // Starts with `items` per dispatch (tests of a method's split path on any device).
  void start_with(int items) { per_dispatch_ = items; }

  // Runs items [0, n): record(first, count) records one dispatch's range; run() submits what was
  // recorded, waits, and returns true when some thread was cut short (its results are then
  // discarded: run must reset what the retry recomputes). Learned once: later calls start with the
  // shorter ranges. One item alone cut short is a one-line error naming `what`.
  template <class Record, class Run>
  void execute(int n, std::string_view what, std::string_view device, Record record, Run run) {
    if (per_dispatch_ <= 0 || per_dispatch_ > n) per_dispatch_ = std::max(1, n);
    for (;;) {
      for (int first = 0; first < n; first += per_dispatch_) record(first, std::min(per_dispatch_, n - first));
      if (!run()) return;
      if (per_dispatch_ == 1)
        throw Error("{} on {}: one item's loops exceed the driver's loop limit (65535 iterations a thread)", what,
                    device);
      per_dispatch_ = std::max(1, per_dispatch_ / 4);
      ++retries_;
    }
  }

 private:
  int per_dispatch_ = 0;
  int retries_ = 0;
};

}  // namespace penumbra::gpu
