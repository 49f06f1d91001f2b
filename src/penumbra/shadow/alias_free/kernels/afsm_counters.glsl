// The counters of afsm's cover kernels (AfsmCounters, after the RasterView in the view's buffer).
#ifndef PENUMBRA_SHADOW_ALIAS_FREE_AFSM_COUNTERS_GLSL
#define PENUMBRA_SHADOW_ALIAS_FREE_AFSM_COUNTERS_GLSL

#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"
#include "penumbra/shadow/alias_free/alias_free_shared.h"

layout(buffer_reference, scalar) buffer AfsmCountersRef { AfsmCounters c; };

// Adds one thread's texel visits and pair tests.
void afsm_count(uint64_t view, uint visits, uint tests) {
  AfsmCountersRef r = AfsmCountersRef(view + 160ul);  // sizeof(RasterView)
  if (visits > 0u) atomicAdd(r.c.texel_visits, uint64_t(visits));
  if (tests > 0u) atomicAdd(r.c.sample_tests, uint64_t(tests));
}

#endif
