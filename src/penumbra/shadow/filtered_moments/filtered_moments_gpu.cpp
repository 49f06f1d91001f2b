// `vsm`, `evsm` and `msm` on the GPU: the CPU version's map from the light's centre (fitted on
// the device, rendered by the GPU rasterizer: shadow/shadow_map_common_gpu.h), its texels turned
// into the model's moments on the device (kernels/fm_depth_range.comp, fm_encode.comp) and
// prefiltered by the GPU's summed-area tables or mip chains (gpu/filtered/, the CPU's layouts and
// sums), and the lookups (kernels/fm_filter.comp), one thread per view sample, running the CPU's
// per-sample function (filtered_moments_shared.h fm_shade) with the CPU's model arithmetic
// (moments_shared.h). Stages fit, raster, prefilter (when the map was rendered again) and filter,
// as the CPU's phases. Same parameters as the CPU's tables (vsm.cpp, evsm.cpp, msm.cpp).
#include "penumbra/gpu/filtered/gpu_filtered_map.h"
#include "penumbra/raster/shadow_view.h"
#include "penumbra/shadow/filtered_moments/filtered_moments.h"
#include "penumbra/shadow/filtered_moments/filtered_moments_kernels_shared.h"
#include "penumbra/shadow/filtered_moments/models.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/partitions/light_partitions_gpu.h"
#include "penumbra/shadow/shadow_map_common_gpu.h"

namespace penumbra::filtered_moments {
namespace {

class FilteredMomentsGpu final : public GpuShadowMethod {
 public:
  FilteredMomentsGpu(const ParamSet& p, std::unique_ptr<MomentModel> model)
      : params_(core_params(p)), model_(std::move(model)) {}

  void prepare(const ShadowContext& ctx, GpuFrame& frame) override {
    stats_.prepare_count++;
    map_.prepare(ctx, frame, /*hold_reach=*/false);  // as the CPU's (filtered_moments.cpp)
    built_from_ = 0;
    if (model_record_.empty()) {
      gpu::Device& d = *frame.device;
      const shader::FmModel m = model_->shared();
      model_record_ = gpu::Buffer(d, sizeof(m), "the moment model");
      model_record_.upload(&m, sizeof(m));
      shade_ = gpu::Buffer(d, sizeof(shader::FmShadeBlock), "the moment lookups' block");
      range_ = gpu::Buffer(d, sizeof(shader::FmDepthRange), "the moment map's depth range");
      bits_ = gpu::Buffer(d, sizeof(shader::FmDepthBits), "the moment map's depth extremes");
      map_record_ = gpu::Buffer(d, sizeof(shader::FmMapRecord), "the moment map's record");
    }
  }

  void evaluate(const ShadowContext& ctx, GpuFrame& frame, const GpuShadowOutput& out) override {
    // (update submits what was recorded before: the uploads below are safe.)
    const bool has_map = map_.update(ctx, frame, params_.view, shadow_map::BiasParams{}, stats_);
    gpu::CommandList& cl = *frame.commands;
    if (has_map) {
      if (built_from_ != map_.renders()) build_moments(frame);
      const gpu::GpuDepthMap& dm = map_.map();
      const shader::FmShadeBlock block = shade_block(params_, *ctx.light, shadow_map::shadow_map_view(dm.view(), dm.z_min()));
      shade_.upload(&block, sizeof(block));
    }
    cl.stage("filter");
    shader::FmFilterParams p{};
    p.io = map_.lookup_inputs(cl, frame, out, has_map);
    p.model = model_record_.address();
    p.shade = shade_.address();
    p.range = range_.address();
    p.map = map_record_.address();
    p.table = params_.prefilter == Prefilter::Sat ? sat_.address() : mip_.address();
    cl.dispatch("fm_filter", frame.slots, p);
    ran_ = true;
  }

  // The texels read (16 per channel and lookup), the lookups, the receivers outside the map, the
  // samples without blockers and the near fields traced, counted on the device; the memory held.
  void collect_stats() override {
    if (!ran_) return;
    const shader::GpuShadowMapCounters c = map_.collect(stats_);
    const uint64_t per_lookup = 16 * static_cast<uint64_t>(model_->channels());
    stats_.extra["filtered_lookups"] = c.texels / per_lookup;
    if (params_.blocker_search) stats_.extra["samples_without_blockers"] = c.no_blocker;
    stats_.extra["near_field_rays"] = c.near_rays;
    const uint64_t table = params_.prefilter == Prefilter::Sat ? sat_.device_bytes() : mip_.device_bytes();
    stats_.memory_bytes = std::max<uint64_t>(stats_.memory_bytes, map_.map().device_bytes() + texels_.bytes() + table);
    ran_ = false;
  }

  // One light's instance on the device: the light-centre map and its rasterizer's scratch, the
  // encoded texels and the prefiltered table (as the CPU's FilteredMomentMap::bytes), the records.
  static MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q, int channels) {
    MemoryTally tally;
    const CoreParams c = core_params(p);
    shadow_map::GpuLightCentreMap::add_memory(tally, c.view.resolution, q);
    const ViewSize v = fitted_view_bound(c.view.resolution);
    const uint64_t encoded = static_cast<uint64_t>(v.width) * v.height * channels * sizeof(float);
    const uint64_t table = c.prefilter == Prefilter::Sat
                               ? gpu::GpuSummedAreaTable::bytes(v.width, v.height, channels,
                                                                gpu::GpuSummedAreaTable::Entries::Double)
                               : gpu::GpuMipChain::bytes(v.width, v.height, channels);
    tally.add(encoded + table, "resolution");
    tally.add(sizeof(shader::FmModel) + sizeof(shader::FmShadeBlock) + sizeof(shader::FmDepthRange) +
                  sizeof(shader::FmDepthBits) + sizeof(shader::FmMapRecord),
              "resolution");
    partitions::add_gpu_memory(tally, p, q);
    return tally.estimate();
  }

 private:
  // The moments of the map just rendered, prefiltered (stage "prefilter", the CPU's phase).
  void build_moments(GpuFrame& frame) {
    gpu::CommandList& cl = *frame.commands;
    gpu::Device& d = *frame.device;
    const gpu::GpuDepthMap& dm = map_.map();
    const int C = model_->channels();
    const uint64_t texels = static_cast<uint64_t>(dm.width()) * dm.height();
    if (texels_.bytes() < texels * C * sizeof(float)) {
      frame.flush();  // nothing recorded may still read the old buffer
      gpu::ensure_buffer(d, texels_, texels * C * sizeof(float), "the moment map's texels");
    }
    cl.stage("prefilter");
    // A table that grows submits what was recorded first; the rest is timed as prefilter too.
    const gpu::SubmitRecorded submit = [&] {
      frame.flush();
      cl.stage("prefilter");
    };
    cl.fill(bits_, 0xffffffffu, offsetof(shader::FmDepthBits, lo), 4);
    cl.fill(bits_, 0u, offsetof(shader::FmDepthBits, hi), 4);
    cl.dispatch("fm_depth_range", texels,
                shader::FmDepthRangeParams{dm.z(), bits_.address(), static_cast<uint32_t>(texels), 0u});
    shader::FmEncodeParams e{};
    e.z = dm.z();
    e.bits = bits_.address();
    e.range = range_.address();
    e.model = model_record_.address();
    e.texels = texels_.address();
    e.near = FilteredMomentMap::kNear;
    e.far = FilteredMomentMap::kFar;
    e.tiny = FilteredMomentMap::kTinyRange;
    e.count = static_cast<uint32_t>(texels);
    cl.dispatch("fm_encode", texels, e);
    shader::FmMapRecord record{};
    record.width = dm.width();
    record.height = dm.height();
    if (params_.prefilter == Prefilter::Sat) {
      record.prefilter = shader::kFmPrefilterSat;
      sat_.build_from_floats(d, cl, submit, texels_.address(), dm.width(), dm.height(), C);
      record.sat = sat_.layout();
    } else {
      record.prefilter = shader::kFmPrefilterMip;
      float outside[4];
      model_->encode(1.0, outside);
      mip_.build(d, cl, submit, texels_.address(), dm.width(), dm.height(), C, std::span<const float>(outside, C));
      record.mip = mip_.view();
    }
    map_record_.upload(&record, sizeof(record));
    built_from_ = map_.renders();
  }

  CoreParams params_;
  std::unique_ptr<MomentModel> model_;
  shadow_map::GpuLightCentreMap map_;
  gpu::Buffer model_record_, shade_, range_, bits_, map_record_, texels_;
  gpu::GpuSummedAreaTable sat_;
  gpu::GpuMipChain mip_;
  uint64_t built_from_ = 0;  // map_.renders() the moments were built from
  bool ran_ = false;
};

GpuMethodInfo gpu_method(const std::string& name) {
  return {name,
          [name](const ParamSet& p) {
            return partitions::wrap_gpu(std::make_unique<FilteredMomentsGpu>(p, make_moment_model(name, p)), p,
                                        p.get_int("resolution"));
          },
          [name](const ParamSet& p, const MemoryQuery& q) {
            return FilteredMomentsGpu::memory(p, q, moment_channels(name, p));
          }};
}

const GpuMethodRegistration vsm_registration(gpu_method("vsm"));
const GpuMethodRegistration evsm_registration(gpu_method("evsm"));
const GpuMethodRegistration msm_registration(gpu_method("msm"));

}  // namespace
}  // namespace penumbra::filtered_moments
