// For the test of a list buffer too small for the scene (issue 29: never drop work silently):
// while an AfsmListCapacityForTesting lives, every GPU `afsm-hard` made starts with room for
// `slots` listed view samples, so its renders must grow the lists; grows() counts those. One at
// a time; defined in alias_free_gpu.cpp.
#pragma once

#include <cstdint>

namespace penumbra::afsm {

class AfsmListCapacityForTesting {
 public:
  explicit AfsmListCapacityForTesting(uint32_t slots);
  ~AfsmListCapacityForTesting();
  AfsmListCapacityForTesting(const AfsmListCapacityForTesting&) = delete;
  AfsmListCapacityForTesting& operator=(const AfsmListCapacityForTesting&) = delete;

  // How many times a list buffer was found too small and grown since this was made.
  int grows() const;
};

}  // namespace penumbra::afsm
