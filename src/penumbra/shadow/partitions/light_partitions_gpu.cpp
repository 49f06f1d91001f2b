#include "penumbra/shadow/partitions/light_partitions_gpu.h"

#include <algorithm>

#include "penumbra/shadow/partitions/light_partitions.h"
#include "penumbra/shadow/shadow_map_common_gpu.h"
#include "penumbra/shadow/view_samples_shared.h"

namespace penumbra::partitions {
namespace {

class PartitionedGpuMethod final : public GpuShadowMethod {
 public:
  PartitionedGpuMethod(std::unique_ptr<GpuShadowMethod> inner, const Settings& s)
      : inner_(std::move(inner)), settings_(s) {}

  void prepare(const ShadowContext& ctx, GpuFrame& frame) override {
    inner_->stats() = stats_;
    inner_->prepare(ctx, frame);
    stats_ = inner_->stats();
    ScopedPhase phase(stats_, "partition plan");
    frame_ = light_frame(*ctx.light, ctx.scene->bounds());
    casters_.gather(*ctx.scene, frame_);
    if (range_.empty()) range_ = gpu::Buffer(*frame.device, sizeof(shader::GpuReceiverRange), "the partitions' range");
  }

  void evaluate(const ShadowContext& ctx, GpuFrame& frame, const GpuShadowOutput& out) override {
    const AreaLight& light = *ctx.light;
    gpu::Device& device = *frame.device;
    gpu::CommandList& cl = *frame.commands;
    if (!could_split(casters_, settings_, frame.slots)) {  // a single object, few samples: the method alone
      inner_->stats() = stats_;
      inner_->evaluate(ctx, frame, out);
      stats_ = inner_->stats();
      stats_.extra["partitions"] = 1;
      return;
    }
    const int G = grid_cells(settings_);
    const size_t cells = static_cast<size_t>(G) * G;
    // The receivers' range and which cells hold one (the CPU's receiver_grid, on the device).
    cl.stage("partition plan");
    ReceiverGrid receivers;
    receivers.grid = G;
    receivers.range = shadow_map::range_floats(shadow_map::reduce_receivers(light, frame, frame_, range_));
    Plan plan;
    if (may_split(frame_, receivers.range, casters_, settings_, frame.slots)) {
      const shader::PartitionGrid g = grid_over(frame_, receivers.range, G);
      gpu::ensure_buffer(device, grid_, sizeof(g), "the partitions' grid");
      grid_.upload(&g, sizeof(g));
      gpu::ensure_buffer(device, cells_, cells * sizeof(uint32_t), "the partitions' grid cells");
      cl.fill(cells_, 0);
      shader::PartitionClassifyParams cp = classify_params(light, frame, G);
      cp.occupancy = cells_.address();
      cl.dispatch("partition_occupancy", frame.slots, cp);
      frame.flush();
      receivers.counts = cells_.download_vector<uint32_t>(cells);
      plan = make_plan(frame_, receivers, casters_, light, settings_);
    }
    stats_.extra["partitions"] = std::max(1, plan.leaves);
    inner_->stats() = stats_;
    if (!plan.split()) {
      inner_->evaluate(ctx, frame, out);
      stats_ = inner_->stats();
      stats_.extra["partitions"] = 1;
      return;
    }
    const uint32_t L = static_cast<uint32_t>(plan.leaves);
    // Each slot's partition and the partitions' sizes.
    cells_.upload(std::span<const int32_t>(plan.leaf_of_cell));
    gpu::ensure_buffer(device, leaf_, uint64_t(frame.slots) * 4, "the view samples' partitions");
    gpu::ensure_buffer(device, counts_, uint64_t(L) * 4 * 3, "the partitions' sizes");
    cl.fill(counts_, 0);
    shader::PartitionClassifyParams cp = classify_params(light, frame, G);
    cp.leaf_of_cell = cells_.address();
    cp.leaf = leaf_.address();
    cp.counts = counts_.address();
    cl.dispatch("partition_assign", frame.slots, cp);
    frame.flush();
    const std::vector<uint32_t> counts = counts_.download_vector<uint32_t>(L);
    // Runs of the compact list: each partition's samples, then its guard samples (none or four).
    std::vector<uint32_t> first(L);
    uint32_t total = 0;
    for (uint32_t l = 0; l < L; ++l) {
      first[l] = total;
      total += counts[l] > 0 ? counts[l] + plan.guard_count(int(l)) : 0;
    }
    gpu::ensure_buffer(device, compact_, uint64_t(total) * sizeof(shader::GpuViewSample), "the partitions' view samples");
    gpu::ensure_buffer(device, slot_of_, uint64_t(total) * 4, "the partitions' slots");
    gpu::ensure_buffer(device, part_v_, uint64_t(total) * 4, "the partitions' visibility");
    const bool irradiance = inner_->computes_irradiance() && out.irradiance != 0;
    if (irradiance) gpu::ensure_buffer(device, part_e_, uint64_t(total) * 12, "the partitions' irradiance");
    counts_.upload(std::span<const uint32_t>(first), uint64_t(L) * 4);
    cl.fill(counts_, 0, uint64_t(L) * 8, uint64_t(L) * 4);
    cl.fill(slot_of_, 0xffffffffu);  // guard samples keep ~0u
    shader::PartitionCompactParams kp{};
    kp.samples = frame.view_samples;
    kp.leaf = leaf_.address();
    kp.first = counts_.address() + uint64_t(L) * 4;
    kp.fill = counts_.address() + uint64_t(L) * 8;
    kp.compact = compact_.address();
    kp.slot_of = slot_of_.address();
    kp.slots = frame.slots;
    cl.dispatch("partition_compact", frame.slots, kp);
    frame.flush();
    // The guard samples, written after their runs (the host writes them; nothing reads them yet).
    for (uint32_t l = 0; l < L; ++l) {
      if (counts[l] == 0 || plan.guard_count(int(l)) == 0) continue;
      shader::GpuViewSample guards[4]{};
      for (int c = 0; c < 4; ++c) {
        guards[c].p = plan.guards[l][c];
        guards[c].ng = guards[c].ns = -light.frame.n;  // facing the light
        guards[c].object = 0;
      }
      compact_.upload(guards, sizeof(guards), uint64_t(first[l] + counts[l]) * sizeof(shader::GpuViewSample));
    }
    // Each partition as a frame of its own.
    for (uint32_t l = 0; l < L; ++l) {
      if (counts[l] == 0) continue;
      GpuFrame part = frame;
      part.view_samples = compact_.address() + uint64_t(first[l]) * sizeof(shader::GpuViewSample);
      part.slots = counts[l] + plan.guard_count(int(l));
      GpuShadowOutput part_out;
      part_out.visibility = part_v_.address() + uint64_t(first[l]) * 4;
      part_out.irradiance = irradiance ? part_e_.address() + uint64_t(first[l]) * 12 : 0;
      cl.fill(part_v_, 0x3f800000u /* 1.0f */, uint64_t(first[l]) * 4, uint64_t(part.slots) * 4);
      if (irradiance) cl.fill(part_e_, 0, uint64_t(first[l]) * 12, uint64_t(part.slots) * 12);
      inner_->evaluate(ctx, part, part_out);
      // What the method uploads for the next partition must not overtake this one's kernels.
      frame.flush();
    }
    cl.stage("partition scatter");
    shader::PartitionScatterParams sp{};
    sp.slot_of = slot_of_.address();
    sp.part_visibility = part_v_.address();
    sp.visibility = out.visibility;
    sp.part_irradiance = irradiance ? part_e_.address() : 0;
    sp.irradiance = irradiance ? out.irradiance : 0;
    sp.count = total;
    cl.dispatch("partition_scatter", total, sp);
    stats_ = inner_->stats();
    stats_.extra["partitions"] = plan.leaves;
  }

  bool computes_irradiance() const override { return inner_->computes_irradiance(); }
  void collect_stats() override {
    inner_->stats() = stats_;
    inner_->collect_stats();
    stats_ = inner_->stats();
  }

 private:
  shader::PartitionClassifyParams classify_params(const AreaLight& light, const GpuFrame& frame, int G) const {
    shader::PartitionClassifyParams p{};
    p.grid = grid_.address();
    p.samples = frame.view_samples;
    p.light_center = light.center;
    p.slots = frame.slots;
    p.light_n = light.frame.n;
    p.cells = G;
    return p;
  }

  std::unique_ptr<GpuShadowMethod> inner_;
  Settings settings_;
  ShadowViewFrame frame_{};
  CasterCentroids casters_;
  gpu::Buffer range_, grid_, cells_, leaf_, counts_, compact_, slot_of_, part_v_, part_e_;
};

}  // namespace

void add_gpu_memory(MemoryTally& tally, const ParamSet& p, const MemoryQuery& q) {
  if (p.get_int("partitions") <= 1) return;
  // Per slot: the compact sample (64 bytes), its slot, its partition, V and E (4 + 4 + 4 + 12).
  tally.add(q.view_samples * (sizeof(shader::GpuViewSample) + 24), kViewSamplesSetting);
}

std::unique_ptr<GpuShadowMethod> wrap_gpu(std::unique_ptr<GpuShadowMethod> inner, const ParamSet& p,
                                          int map_resolution, GuardSamples guards) {
  Settings s = settings_from(p, map_resolution);
  s.guards = guards;
  if (s.max_side == 1) return inner;
  return std::make_unique<PartitionedGpuMethod>(std::move(inner), s);
}

}  // namespace penumbra::partitions
