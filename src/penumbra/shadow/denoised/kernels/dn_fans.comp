#version 460
// `rt-denoised` on the GPU (denoised.cpp's trace): one thread per view-sample slot, the
// reference's fan of `n` light samples (shadow/light_fans.glsl: the CPU's samples), and the
// pixel's guide and signals in the planes' set 0 (atrous_shared.h: Heitz et al. 2018's shadowed
// and unshadowed estimates of the same samples, the area-weighted visibility A, the ratio's
// variance); a miss marks its slot invalid. Rays counted per subgroup, then one atomic.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/light_fans.glsl"
#include "penumbra/shadow/denoised/denoise_image.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { DnFansParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };

void main() {
  uint i = pn_thread_index();
  uint traced = 0u;
  if (i < pc.p.fans.slots) {
    DnPlanes planes = DnPlanesRef(pc.p.planes).p;
    GpuViewSample s = ViewSamplesIn(pc.p.fans.samples).v[i];
    bool hit = s.object != kMissObject;
    Bytes(planes.valid).v[i] = uint8_t(hit ? 1 : 0);
    if (hit) {
      scene_bind(pc.p.fans.scene);
      LightFansParams lf = pc.p.fans;
      LightFan fan = light_fan_begin(lf.light, lf.seed, lf.light_index, lf.frame, lf.area_sampling != 0u,
                                     lf.grid_cols, lf.inv_cols, lf.inv_rows, s);
      float ts[kDenoiseMaxSamples], fs[kDenoiseMaxSamples];
      int m = 0;
      DenoiseFanSums sums = dn_fan_begin();
      for (int k = 0; k < lf.n; ++k) {
        float t, f, a;
        if (!light_fan_trace(fan, k, t, f, a)) continue;
        dn_fan_add(sums, t, f, a);
        ts[m] = t;
        fs[m] = f;
        ++m;
      }
      for (int k = 0; k < m; ++k) dn_fan_add_spread(sums, ts[k], fs[k]);
      traced = uint(m);
      DenoisePixel px = dn_fan_pixel(sums, lf.n);
      Floats(planes.depth).v[i] = dn_view_depth(s.p, pc.p.eye, pc.p.forward);
      Vec3s(planes.normal).v[i] = s.ns;
      Floats(planes.shadowed[0]).v[i] = px.shadowed;
      Floats(planes.unshadowed[0]).v[i] = px.unshadowed;
      Floats(planes.area[0]).v[i] = px.area;
      Floats(planes.variance[0]).v[i] = px.variance;
    }
  }
  uint total = subgroupAdd(traced);
  if (subgroupElect() && total > 0u) atomicAdd(Uint64s(pc.p.fans.rays).v[0], uint64_t(total));
}
