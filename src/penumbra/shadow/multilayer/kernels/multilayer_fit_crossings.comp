#version 460
// `mlsm`/`mtsm` on the GPU, the third fit pass (multilayer_kernels_shared.h; light_centre_view
// after eq. 4's push-back): one thread per view-sample slot. Each fitted receiver (the kept ones,
// or all when none was kept) and, where the caster boxes lie beyond the light (crossings), the
// points where its segments to the light's outline cross the boxes' smallest depth z_c
// (ml_segment_crossing), reduced to their range in the pushed-back view (range 2). Without
// crossings the host adds the outline itself.
#include "penumbra/shadow/multilayer/kernels/multilayer_fit.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { MlFitParams p; } pc;

void main() {
  uint i = pn_thread_index();
  MlFitBlock b = FitBlockRef(pc.p.block).b;
  vec3 p;
  bool fitted = fit_receiver(pc.p.samples, pc.p.slots, i, b.light_center, b.light_n, p);
  if (fitted && b.kept_only != 0u) fitted = Uints(pc.p.keep).v[i] != 0u;
  RangePart part = range_part_empty();
  if (fitted) {
    range_part_add(part, b.pushed, p);
    float zr = dot(p - b.eye, b.dir);
    if (b.crossings != 0u && zr > b.z_c) {
      Floats outline = Floats(pc.p.outline32);
      for (uint k = 0u; k < b.n_outline32; ++k) {
        vec3 q = vec3(outline.v[3u * k], outline.v[3u * k + 1u], outline.v[3u * k + 2u]);
        range_part_add(part, b.pushed, ml_segment_crossing(p, zr, q, b.eye, b.dir, b.z_c));
      }
    }
  }
  range_reduce(RangesRef(pc.p.ranges), 2u, part, fitted ? 1u : 0u);
}
