// The host's half of shadow/light_fans.glsl: the parameters of the reference's light fans for
// one light and frame, which every kernel drawing them takes (reference_fans, rt-denoised's
// dn_fans). The caller sets where the results go (visibility, irradiance: the kernel's own).
#pragma once

#include <algorithm>

#include "penumbra/core/sampling.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/shadow_rays_shared.h"

namespace penumbra {

// n stratified light samples per view sample of frame.view_samples (solid-angle samples, or
// uniform area samples with `area_sampling`), keyed as the CPU keys them; rays counted in `rays`.
inline shader::LightFansParams light_fans_params(const ShadowContext& ctx, const GpuFrame& frame, int n,
                                                 bool area_sampling, uint64_t rays) {
  n = std::max(1, n);
  const StratifiedGrid grid(n);
  shader::LightFansParams p{};
  p.scene = frame.scene->address();
  p.samples = frame.view_samples;
  p.light = frame.light;
  p.rays = rays;
  p.seed = ctx.seed;
  p.slots = frame.slots;
  p.light_index = ctx.light_index;
  p.frame = ctx.frame;
  p.n = n;
  p.grid_cols = grid.cols();
  p.inv_cols = grid.inv_cols();
  p.inv_rows = grid.inv_rows();
  p.area_sampling = area_sampling ? 1u : 0u;
  return p;
}

}  // namespace penumbra
