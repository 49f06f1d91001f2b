// `single-sample` on the GPU (single_sample_gpu.cpp): what its tests reach.
#pragma once

namespace penumbra::single_sample {

// The most occluder-BVH levels the GPU search takes from now on (0: what its stack holds,
// shader::kSsStack - 1), to make a scene's BVH too deep: the render is then refused in one line.
void set_gpu_stack_levels_for_testing(int levels);

}  // namespace penumbra::single_sample
