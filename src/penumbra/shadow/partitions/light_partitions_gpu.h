// Light-space partitions on the GPU (light_partitions.h, the same plan): the receivers' range
// and grid occupancy reduced on the device and read back (a few KiB), the plan made on the host
// by the CPU's code, then each view sample's partition, one compact list of samples per
// partition (plus its guard samples), the wrapped method run on each list as a frame of its
// own, and every V (and E) put back into its slot (partitions/kernels/partition_*.comp).
#pragma once

#include <memory>

#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/params.h"
#include "penumbra/shadow/partitions/light_partitions.h"

namespace penumbra::partitions {

// A GPU method that fits to its view samples, rendered partition by partition; with
// `partitions` = 1 the wrapped method itself.
// What the wrapper holds on the device, added to a method's `tally`: a compact copy of the view
// samples with their slots, partitions and results (nothing with `partitions` = 1).
void add_gpu_memory(MemoryTally& tally, const ParamSet& p, const MemoryQuery& q);

std::unique_ptr<GpuShadowMethod> wrap_gpu(std::unique_ptr<GpuShadowMethod> inner, const ParamSet& p,
                                          int map_resolution, GuardSamples guards = GuardSamples::AtTheMargin);

}  // namespace penumbra::partitions
