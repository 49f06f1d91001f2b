// Tests only: while an SsvSamplesPerDispatchForTesting lives, every GPU `ssv-rt` made splits its
// light samples over dispatches of `samples` each from the start (the path lavapipe's loop limit
// takes, gpu/loop_limit.h), on any device.
#pragma once

namespace penumbra::ssv {

struct SsvSamplesPerDispatchForTesting {
  explicit SsvSamplesPerDispatchForTesting(int samples);
  ~SsvSamplesPerDispatchForTesting();
  SsvSamplesPerDispatchForTesting(const SsvSamplesPerDispatchForTesting&) = delete;
  SsvSamplesPerDispatchForTesting& operator=(const SsvSamplesPerDispatchForTesting&) = delete;
};

}  // namespace penumbra::ssv
