// `rt-denoised` on the GPU: the CPU version's few-sample ray tracing and SVGF filter
// (denoised.cpp, atrous_filter.h) in compute. kernels/dn_fans.comp traces each view sample's fan
// of the reference's light samples (shadow/light_fans.glsl: the CPU's samples, traced through the
// GPU's BVH) into guided images kept in the view-sample slots (one per camera-ray index, as the
// CPU's); the filter's kernels (dn_gradients, dn_spatial_variance, dn_prefilter_variance,
// dn_atrous, dn_ratio: V and E) run the CPU's per-pixel functions (atrous_shared.h), a pass per
// kernel where the CPU has a loop over the image. Stages trace and filter, as the CPU's phases. Same
// parameters as denoised.cpp's table.
#include <algorithm>

#include "penumbra/shadow/denoised/atrous_filter.h"
#include "penumbra/shadow/denoised/denoised_kernels_shared.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/light_fans_gpu.h"

namespace penumbra {
namespace {

// Bytes per slot: valid, depth, normal, gradient, prefiltered variance, and S, U, A and the
// variance twice (denoised_kernels_shared.h DnPlanes).
constexpr uint64_t kBytesPerSlot = 1 + 4 + 12 + 8 + 4 + 2 * (4 + 4 + 4 + 4);

class DenoisedGpu final : public GpuShadowMethod {
 public:
  explicit DenoisedGpu(const ParamSet& p)
      : samples_(p.get_int("samples")), settings_(denoise::atrous_settings_from(p)) {}

  void prepare(const ShadowContext&, GpuFrame& frame) override {
    stats_.prepare_count++;
    if (rays_.empty()) rays_ = gpu::Buffer(*frame.device, sizeof(uint64_t), "rt-denoised's ray counter");
  }
  // Nothing prepared: every evaluate() traces the geometry as the GPU holds it now.
  bool keeps_prepared_after_moving(std::span<const uint32_t>) override { return true; }
  // E = the denoised ratio times the closed-form unshadowed irradiance; V is the area fraction.
  bool computes_irradiance() const override { return true; }

  void evaluate(const ShadowContext& ctx, GpuFrame& frame, const GpuShadowOutput& out) override {
    size_planes(frame);
    gpu::CommandList& cl = *frame.commands;
    if (!counting_) cl.fill(rays_, 0);
    counting_ = true;
    const Camera& camera = ctx.scene->camera;
    cl.stage("trace");
    shader::DnFansParams fp{};
    fp.fans = light_fans_params(ctx, frame, samples_, /*area_sampling=*/false, rays_.address());
    fp.planes = record_.address();
    fp.eye = camera.eye;
    fp.forward = normalize(camera.target - camera.eye);
    cl.dispatch("dn_fans", frame.slots, fp);

    cl.stage("filter");
    shader::DnFilterParams p{};
    p.planes = record_.address();
    p.visibility = out.visibility;
    p.irradiance = out.irradiance;
    p.samples = frame.view_samples;
    p.light = frame.light;
    p.unit_circle = frame.unit_circle;
    p.slots = frame.slots;
    p.width = frame.window.width();
    p.height = frame.window.height();
    p.spp = std::max(1, frame.samples_per_pixel);
    p.sigma_z = settings_.sigma_z;
    p.sigma_n = settings_.sigma_n;
    p.sigma_l = settings_.sigma_l;
    if (settings_.iterations > 0) {
      cl.dispatch("dn_gradients", frame.slots, p);
      if (samples_ < denoise::kMinSamplesForOwnVariance) {
        cl.dispatch("dn_spatial_variance", frame.slots, p);
        cl.copy(prefiltered_, variance_[0], static_cast<uint64_t>(frame.slots) * sizeof(float));
      }
      // SVGF §4.2: iteration i's taps 2^i pixels apart, each pass from one set into the other.
      for (int it = 0; it < settings_.iterations; ++it) {
        p.step = 1 << it;
        cl.dispatch("dn_prefilter_variance", frame.slots, p);
        cl.dispatch("dn_atrous", frame.slots, p);
        p.current = 1u - p.current;
      }
    }
    cl.dispatch("dn_ratio", frame.slots, p);
  }

  void collect_stats() override {
    if (!counting_) return;
    stats_.rays_traced += rays_.download_vector<uint64_t>(1)[0];
    stats_.extra["light_samples"] = samples_;
    stats_.extra["iterations"] = settings_.iterations;
    stats_.memory_bytes = std::max<uint64_t>(stats_.memory_bytes, planes_bytes_);
    counting_ = false;
  }

 private:
  // The planes for frame.slots slots (allocated again only when the frame grows).
  void size_planes(GpuFrame& frame) {
    const uint64_t slots = std::max<uint32_t>(frame.slots, 1);
    if (slots <= capacity_) return;
    frame.flush();  // nothing recorded may still read the old planes
    gpu::Device& d = *frame.device;
    auto plane = [&](gpu::Buffer& b, uint64_t bytes_per_slot) {
      b = gpu::Buffer();
      b = gpu::Buffer(d, slots * bytes_per_slot, "rt-denoised's guided images");
      return b.address();
    };
    shader::DnPlanes r{};
    r.valid = plane(valid_, 1);
    r.depth = plane(depth_, 4);
    r.normal = plane(normal_, 12);
    r.grad = plane(grad_, 8);
    r.prefiltered = plane(prefiltered_, 4);
    for (int k = 0; k < 2; ++k) {
      r.shadowed[k] = plane(shadowed_[k], 4);
      r.unshadowed[k] = plane(unshadowed_[k], 4);
      r.area[k] = plane(area_[k], 4);
      r.variance[k] = plane(variance_[k], 4);
    }
    if (record_.empty()) record_ = gpu::Buffer(d, sizeof(r), "rt-denoised's planes");
    record_.upload(&r, sizeof(r));
    capacity_ = slots;
    planes_bytes_ = slots * kBytesPerSlot + sizeof(r);
  }

  int samples_;
  denoise::AtrousSettings settings_;
  gpu::Buffer rays_, record_, valid_, depth_, normal_, grad_, prefiltered_;
  gpu::Buffer shadowed_[2], unshadowed_[2], area_[2], variance_[2];
  uint64_t capacity_ = 0, planes_bytes_ = 0;
  bool counting_ = false;  // evaluate() ran since the last collect_stats()
};

// One light's instance on the device: the planes, per view-sample slot (every camera ray of the
// window; MemoryQuery::view_samples bounds them), and a few bytes of record and counter.
MemoryEstimate memory(const ParamSet&, const MemoryQuery& q) {
  MemoryTally tally;
  tally.add(std::max<uint64_t>(q.view_samples, 1) * kBytesPerSlot + sizeof(shader::DnPlanes) + sizeof(uint64_t),
            kViewSamplesSetting);
  return tally.estimate();
}

const GpuMethodRegistration registration({"rt-denoised", [](const ParamSet& p) { return std::make_unique<DenoisedGpu>(p); },
                                          memory});

}  // namespace
}  // namespace penumbra
