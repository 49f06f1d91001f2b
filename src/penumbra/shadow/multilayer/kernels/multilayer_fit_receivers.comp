#version 460
// `mlsm`/`mtsm` on the GPU, the first fit pass (multilayer_kernels_shared.h): one thread per
// view-sample slot. The receivers (view samples in front of the light: multilayer.cpp evaluate),
// their bounds (the rule that keeps a map while they stay the same), and for each planar object
// whether some receiver lies behind it (caster_boxes: a ground plane shadows nothing above it).
#include "penumbra/shadow/multilayer/kernels/multilayer_fit.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { MlFitReceiversParams p; } pc;
layout(buffer_reference, scalar) buffer ReceiversRef { MlReceivers r; };
layout(buffer_reference, scalar) readonly buffer PlanesRef { MlPlane v[]; };

void main() {
  uint i = pn_thread_index();
  vec3 p;
  bool receiver = fit_receiver(pc.p.samples, pc.p.slots, i, pc.p.light_center, pc.p.light_n, p);
  uint count = subgroupAdd(receiver ? 1u : 0u);
  uint lx = subgroupMin(receiver ? raster_order_bits(p.x) : 0xffffffffu);
  uint ly = subgroupMin(receiver ? raster_order_bits(p.y) : 0xffffffffu);
  uint lz = subgroupMin(receiver ? raster_order_bits(p.z) : 0xffffffffu);
  uint hx = subgroupMax(receiver ? raster_order_bits(p.x) : 0u);
  uint hy = subgroupMax(receiver ? raster_order_bits(p.y) : 0u);
  uint hz = subgroupMax(receiver ? raster_order_bits(p.z) : 0u);
  Uints behind = Uints(pc.p.behind);
  PlanesRef planes = PlanesRef(pc.p.planes);
  for (uint k = 0u; k < pc.p.n_planes; ++k) {
    MlPlane pl = planes.v[k];
    bool b = receiver && ml_behind_plane(pl.n, pl.d, pl.side, pl.tol, p);
    uint any = subgroupMax(b ? 1u : 0u);
    if (any != 0u && subgroupElect()) atomicMax(behind.v[k], 1u);
  }
  if (!subgroupElect() || count == 0u) return;
  ReceiversRef state = ReceiversRef(pc.p.state);
  atomicAdd(state.r.count, count);
  atomicMin(state.r.lo_x, lx);
  atomicMin(state.r.lo_y, ly);
  atomicMin(state.r.lo_z, lz);
  atomicMax(state.r.hi_x, hx);
  atomicMax(state.r.hi_y, hy);
  atomicMax(state.r.hi_z, hz);
}
