#include "penumbra/gpu/ray_queries.h"

#include "penumbra/gpu/commands.h"
#include "penumbra/gpu/ray_queries_shared.h"

namespace penumbra::gpu {
namespace {
std::vector<shader::GpuRay> to_gpu(std::span<const ShadowRay> rays) {
  std::vector<shader::GpuRay> out(rays.size());
  for (size_t i = 0; i < rays.size(); ++i) out[i] = {rays[i].org, rays[i].tnear, rays[i].dir, rays[i].tfar};
  return out;
}
}  // namespace

std::vector<float> trace_transmittance(const GpuScene& scene, std::span<const ShadowRay> rays) {
  if (rays.empty()) return {};
  Device& d = scene.device();
  Buffer in = make_buffer<shader::GpuRay>(d, to_gpu(rays), "the rays to trace");
  Buffer out(d, rays.size() * sizeof(float), "the rays' transmittance");
  CommandList cl(d);
  cl.dispatch("trace_segments", rays.size(),
              shader::RayQueryParams{scene.address(), in.address(), out.address(), static_cast<uint32_t>(rays.size()), 0});
  cl.submit();
  return out.download_vector<float>(rays.size());
}

std::vector<Hit> trace_closest(const GpuScene& scene, std::span<const Ray> rays) {
  if (rays.empty()) return {};
  Device& d = scene.device();
  std::vector<shader::GpuRay> gpu_rays(rays.size());
  for (size_t i = 0; i < rays.size(); ++i) gpu_rays[i] = {rays[i].org, rays[i].tnear, rays[i].dir, rays[i].tfar};
  Buffer in = make_buffer<shader::GpuRay>(d, gpu_rays, "the rays to trace");
  Buffer out(d, rays.size() * sizeof(shader::GpuRayHit), "the rays' hits");
  CommandList cl(d);
  cl.dispatch("trace_closest_rays", rays.size(),
              shader::RayQueryParams{scene.address(), in.address(), out.address(), static_cast<uint32_t>(rays.size()), 0});
  cl.submit();
  const std::vector<shader::GpuRayHit> h = out.download_vector<shader::GpuRayHit>(rays.size());
  std::vector<Hit> hits(rays.size());
  for (size_t i = 0; i < rays.size(); ++i) {
    hits[i].t = h[i].t;
    hits[i].object = h[i].object == shader::kMissObject ? Hit::kMiss : h[i].object;
    hits[i].prim = h[i].prim;
    hits[i].u = h[i].u;
    hits[i].v = h[i].v;
  }
  return hits;
}

}  // namespace penumbra::gpu
