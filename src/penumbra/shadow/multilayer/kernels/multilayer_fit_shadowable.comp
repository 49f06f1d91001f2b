#version 460
// `mlsm`/`mtsm` on the GPU, the second fit pass (multilayer_kernels_shared.h): one thread per
// view-sample slot. Whether a caster box can shadow the receiver (shadowable_receivers,
// multilayer_view_shared.h ml_shadowable: the map's texels go where shadows can fall), kept as a
// flag for the third pass; and the ranges of the kept receivers (0) and of all of them (1) in the
// view from the light's centre, for the fit there (the CPU fits all when none is kept).
#include "penumbra/shadow/multilayer/kernels/multilayer_fit.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { MlFitParams p; } pc;

void main() {
  uint i = pn_thread_index();
  MlFitBlock b = FitBlockRef(pc.p.block).b;
  vec3 p;
  bool receiver = fit_receiver(pc.p.samples, pc.p.slots, i, b.light_center, b.light_n, p);
  bool keep = receiver && ml_shadowable(p, b.light_center, Floats(pc.p.outline16), int(b.n_outline16),
                                        Floats(pc.p.boxes), int(b.n_boxes));
  if (i < pc.p.slots) Uints(pc.p.keep).v[i] = keep ? 1u : 0u;
  RangePart kept = range_part_empty(), all = range_part_empty();
  if (receiver) range_part_add(all, b.centre, p);
  if (keep) range_part_add(kept, b.centre, p);
  RangesRef ranges = RangesRef(pc.p.ranges);
  range_reduce(ranges, 0u, kept, keep ? 1u : 0u);
  range_reduce(ranges, 1u, all, receiver ? 1u : 0u);
}
