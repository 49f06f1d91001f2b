// Cancellation through the parallel loops (core/interrupt.h's CancelToken): what the viewer
// relies on to stop a stale refinement within one grain.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "penumbra/core/interrupt.h"
#include "penumbra/core/parallel.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

TEST(Parallel, WithoutATokenEveryGrainRuns) {
  std::atomic<size_t> sum{0};
  parallel_for(1000, 7, [&](size_t b, size_t e) { sum += e - b; });
  EXPECT_EQ(sum.load(), 1000u);
  EXPECT_EQ(current_cancel_token(), nullptr);
}

TEST(Parallel, ACancelledTokenStopsTheLoopWithinGrainsAndThrowsCancelled) {
  CancelToken token;
  ScopedCancelToken scope(&token);
  std::atomic<size_t> grains{0};
  // The body cancels at its 10th grain; every thread checks before each further grain, so
  // at most one grain per thread more runs.
  EXPECT_THROW(parallel_for(100000, 1,
                            [&](size_t, size_t) {
                              if (++grains == 10) token.cancel();
                            }),
               Cancelled);
  EXPECT_LE(grains.load(), 10u + static_cast<size_t>(max_threads()));
}

TEST(Parallel, TheTokenReachesLoopsNestedOnWorkerThreadsAndTiles) {
  CancelToken token;
  token.cancel();
  ScopedCancelToken scope(&token);
  EXPECT_THROW(parallel_for_tiles(64, 64, 8, [](int, int, int, int) {}), Cancelled);
  std::atomic<int> inner_checks{0};
  {
    // A token made current only inside the outer loop's grains (as on a worker thread).
    ScopedCancelToken none(nullptr);
    EXPECT_THROW(parallel_for(4, 1,
                              [&](size_t, size_t) {
                                ScopedCancelToken inner(&token);
                                ++inner_checks;
                                throw_if_interrupted();
                              }),
                 Cancelled);
  }
  EXPECT_GE(inner_checks.load(), 1);
  EXPECT_EQ(current_cancel_token(), &token);  // restored after the scopes
}

TEST(Parallel, ATokenOfAnotherThreadDoesNotCancelThisOne) {
  CancelToken token;
  token.cancel();
  std::atomic<size_t> sum{0};
  std::thread other([&] {
    ScopedCancelToken scope(&token);
    EXPECT_THROW(throw_if_interrupted(), Cancelled);
  });
  other.join();
  parallel_for(100, 1, [&](size_t b, size_t e) { sum += e - b; });
  EXPECT_EQ(sum.load(), 100u);
}

TEST(Parallel, CancelledIsAnInterruptionSoStepsThatLetCtrlCThroughLetItThrough) {
  try {
    throw Cancelled();
  } catch (const Interrupted& e) {
    EXPECT_STREQ(e.what(), "cancelled");
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
