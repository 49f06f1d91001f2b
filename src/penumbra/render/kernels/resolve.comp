#version 460
// View samples into pixels (Renderer::render's resolve): per pixel of the window, the mean over
// its camera rays, misses counting as background (black, V = 1).
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/render/frame_kernels_shared.h"
#include "penumbra/shadow/view_samples_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { ResolveParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };

void main() {
  uint px = pn_thread_index();
  if (px >= uint(pc.p.window_width * pc.p.window_height)) return;
  uint spp = uint(pc.p.spp);
  vec3 c = vec3(0.0f);
  float v_sum = 0.0f;
  uint hits = 0u;
  for (uint k = 0u; k < spp; ++k) {
    uint i = px * spp + k;
    if (ViewSamplesIn(pc.p.samples).v[i].object == kMissObject) continue;
    // V over several lights: weighted by each light's unshadowed irradiance (one light gives
    // its V exactly).
    float w = Floats(pc.p.v_weight).v[i];
    v_sum += w > 0.0f ? Floats(pc.p.v_weighted).v[i] / w : Floats(pc.p.v_plain).v[i] / pc.p.lights;
    c += Vec3s(pc.p.radiance).v[i];
    ++hits;
  }
  float inv_spp = 1.0f / float(spp);
  Vec3s(pc.p.color).v[px] = c * inv_spp;
  Floats(pc.p.visibility).v[px] = (v_sum + float(spp - hits)) * inv_spp;
}
