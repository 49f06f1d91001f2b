// The parameters of gpu/scan.h's kernel (kernels/scan_exclusive_one_group.comp), in the common
// subset of C++ and GLSL, 16 bytes: bytes 0-7 the values (uint[count + 1]), 8-11 count, 12-15 pad.
#ifndef PENUMBRA_GPU_SCAN_SHARED_H
#define PENUMBRA_GPU_SCAN_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

struct ExclusiveScanParams {
  uint64_t values;
  uint count;
  uint pad;
};

PN_SHARED_END

#endif  // PENUMBRA_GPU_SCAN_SHARED_H
