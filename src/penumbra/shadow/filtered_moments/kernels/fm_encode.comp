#version 460
// `vsm`, `evsm`, `msm` on the GPU (filtered_moments/filtered_moments_kernels_shared.h): every
// texel of the light-centre map as the model's moments of its normalised depth
// (FilteredMomentMap::build, filtered_moments_shared.h fm_depth_range and fm_encode_texel, in
// double as on the CPU), stored as floats; the first thread also writes the depth range record
// the lookups normalise receivers with.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/filtered_moments/filtered_moments_kernels_shared.h"
#include "penumbra/shadow/filtered_moments/filtered_moments_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { FmEncodeParams p; } pc;
layout(buffer_reference, scalar) readonly buffer DepthBitsRef { FmDepthBits b; };
layout(buffer_reference, scalar) readonly buffer ModelRef { FmModel m; };
layout(buffer_reference, scalar) buffer RangeRef { FmDepthRange r; };

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.count) return;
  FmDepthBits bits = DepthBitsRef(pc.p.bits).b;
  // An empty map: lo > hi, fm_depth_range's "nothing" range.
  float lo = bits.hi == 0u ? pn_inf() : raster_order_float(bits.lo);
  float hi = bits.hi == 0u ? -pn_inf() : raster_order_float(bits.hi);
  FmDepthRange range = fm_depth_range(lo, hi, pc.p.near, pc.p.far, pc.p.tiny);
  if (i == 0u) RangeRef(pc.p.range).r = range;
  FmModel model = ModelRef(pc.p.model).m;
  FilteredChannels m = fm_encode_texel(model, range, Floats(pc.p.z).v[i]);
  Floats texels = Floats(pc.p.texels);
  for (int c = 0; c < model.channels; ++c) texels.v[i * uint(model.channels) + uint(c)] = float(m.v[c]);
}
