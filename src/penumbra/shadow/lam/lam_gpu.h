// `lam` on the GPU (lam_gpu.cpp): what its tests reach.
#pragma once

#include <cstdint>

namespace penumbra::lam {

// The splat lists' slots per texel of every LDI built from now on (0: the method's own choice), to
// make them overflow: a texel whose list is full gathers its splats itself (the same layers).
void set_splat_list_capacity_for_testing(uint32_t slots);

}  // namespace penumbra::lam
