// `occlusion-textures` (eisemann2006) on the GPU: the CPU version's slicing plan (the casters,
// their depth range, the centre of projection and the view: OcclusionTextures::plan, on the
// host from the scene's vertices), the slicing pass as the GPU rasterizer's depth-bin mode
// (gpu/raster/gpu_depth_bins.h: the CPU's coverage and bins, planar non-casters left out and
// closed objects culled to their front faces by per-object flags), the prefiltered textures built
// on the device (kernels/ot_*: the CPU's 8-bit mipmaps and N-buffers byte for byte, or the GPU's
// summed-area tables of gpu/filtered/), and the lookups (kernels/ot_shade.comp), one thread per
// view sample running the CPU's per-point function (occlusion_shared.h ot_visibility). Stages
// slicing, filtering and shading, as the CPU's phases. Same parameters as method.cpp's table.
#include <algorithm>
#include <bit>

#include "penumbra/gpu/filtered/gpu_filtered_map.h"
#include "penumbra/gpu/raster/gpu_depth_bins.h"
#include "penumbra/gpu/raster/gpu_rasterizer.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/occlusion_textures/occlusion_kernels_shared.h"
#include "penumbra/shadow/occlusion_textures/occlusion_textures.h"

namespace penumbra {
namespace {

using occlusion::Options;
using occlusion::Prefilter;

uint32_t shared_prefilter(Prefilter p) {
  return p == Prefilter::Mipmap ? shader::kOtMipmap : p == Prefilter::NBuffer ? shader::kOtNBuffer : shader::kOtSat;
}

// The 8-bit pyramid of an R x R texture of S slices (prefilter.h BytePyramid's layout): the
// planes, the padding row after them (bilinear reads at the far edge, weighted 0, stay inside),
// in whole words (the fill clears it).
struct PyramidLayout {
  int levels = 0;
  uint64_t bytes = 0;
  PyramidLayout(Prefilter p, int R, int S) {
    shader::OtTextures t{};
    t.prefilter = shared_prefilter(p);
    t.width = t.height = R;
    t.slices = S;
    levels = std::bit_width(static_cast<unsigned>(R));  // square: mipmaps' and N-buffers' alike
    bytes = (shader::ot_plane_offset(t, levels, 0) + static_cast<uint64_t>(R) + 2 + 3) / 4 * 4;
  }
};

class OcclusionTexturesGpu final : public GpuShadowMethod {
 public:
  explicit OcclusionTexturesGpu(const ParamSet& p) : options_(occlusion::options_from(p)), plan_(options_) {}

  void prepare(const ShadowContext& ctx, GpuFrame& frame) override {
    stats_.prepare_count++;
    frame.flush();  // what was recorded may read the records rewritten below
    gpu::Device& d = *frame.device;
    if (!rasterizer_) {
      rasterizer_ = std::make_unique<gpu::GpuRasterizer>(d);
      bounds_ = gpu::Buffer(d, 4 * sizeof(float) * shader::kOtMaxSlices, "the slices' bounds");
      counters_ = gpu::Buffer(d, sizeof(shader::OtShadeCounters), "the occlusion textures' counters");
    }
    const Scene& scene = *ctx.scene;
    plan_.plan(scene, *ctx.light);
    // The set-up record, then the tiles' slices (occlusion_shared.h OtSetup).
    const shader::OtSetup& setup = plan_.setup();
    const std::vector<shader::OtTile>& tiles = plan_.tiles();
    gpu::ensure_buffer(d, setup_, sizeof(setup) + tiles.size() * sizeof(shader::OtTile), "the occlusion textures' set-up");
    setup_.upload(&setup, sizeof(setup));
    setup_.upload(std::span<const shader::OtTile>(tiles), sizeof(setup));
    stats_.extra["slices"] = options_.slices;
    stats_.extra["resolution"] = options_.resolution;
    stats_.extra["prefilter"] = occlusion::to_string(options_.prefilter);
    nlohmann::json culled = nlohmann::json::array();
    for (uint32_t i : plan_.culled_objects()) culled.push_back(scene.objects[i].name);
    stats_.extra["culled_objects"] = culled;
    if (!plan_.has_casters()) return;
    slice(scene, frame);
    prefilter(frame);
    stats_.memory_bytes =
        std::max<uint64_t>(stats_.memory_bytes, masks_.device_bytes() + nearest_masks_.device_bytes() + textures_bytes());
    stats_.extra["cop_distance"] = plan_.cop_distance();
    stats_.extra["depth_range"] = {plan_.top(), plan_.bottom()};
    stats_.extra["tiles"] = plan_.tiles_side();
    stats_.extra["own_slice"] = plan_.own_slice_active();
    if (plan_.own_slice_active()) stats_.extra["own_slice_scale"] = plan_.own_slice_scale();
  }

  void evaluate(const ShadowContext&, GpuFrame& frame, const GpuShadowOutput& out) override {
    gpu::CommandList& cl = *frame.commands;
    if (!counting_) cl.fill(counters_, 0);
    counting_ = true;
    cl.stage("shading");
    shader::OtShadeParams p{};
    p.samples = frame.view_samples;
    p.visibility = out.visibility;
    p.setup = setup_.address();
    p.textures = textures_address();
    p.bounds = bounds_.address();
    p.counters = counters_.address();
    p.scene = frame.scene->address();
    p.nearest = plan_.own_slice_active() ? own_slice_depths().nearest() : 0;
    p.nearest_scale = plan_.own_slice_scale();
    p.slots = frame.slots;
    p.prefilter = shared_prefilter(options_.prefilter);
    p.sat_counts = options_.sat_precision == occlusion::SatPrecision::UInt32 ? 1u : 0u;
    p.width = p.height = options_.resolution;
    p.levels = std::bit_width(static_cast<unsigned>(options_.resolution));
    p.sat = sat_.layout();
    cl.dispatch("ot_shade", frame.slots, p);
  }

  // The texels read and the lookups, counted on the device.
  void collect_stats() override {
    if (!counting_) return;
    shader::OtShadeCounters c{};
    counters_.download(&c, sizeof(c));
    stats_.texels_visited += c.reads;
    stats_.extra["lookups"] = c.lookups;
    stats_.extra["lookups_outside"] = c.outside;
    stats_.extra["lookups_strips"] = c.strips;
    stats_.extra["near_field_rays"] = c.near_rays;
    counting_ = false;
  }

  // One light's instance on the device: the coverage masks and the prefiltered textures (the
  // pyramid's bytes or the summed-area tables), the rasterizer's scratch and a flag per object
  // (at most one per triangle), the records.
  static MemoryEstimate memory(const ParamSet& params, const MemoryQuery& q) {
    const Options o = occlusion::options_from(params);
    const int R = o.resolution;
    MemoryTally tally;
    // The own slice's nearest depths: in the slicing pass's masks, or a pass of their own above R.
    const int RN = occlusion::own_slice_side(o, q.triangles);
    const uint64_t own = RN > R ? gpu::GpuDepthBinMasks::bytes(RN, RN, o.slices) : DepthBinMasks::nearest_bytes(RN, RN, o.slices);
    tally.add(gpu::GpuDepthBinMasks::bytes(R, R) + own + textures_bytes(o), "resolution");
    const int raster_side = std::max(R, RN);  // the larger pass
    tally.add(gpu::GpuRasterizer::scratch_bytes(q.triangles, raster_side, raster_side) + q.triangles * sizeof(uint32_t),
              kTrianglesSetting);
    tally.add(sizeof(shader::OtSetup) + 4 * sizeof(float) * shader::kOtMaxSlices + sizeof(shader::OtShadeCounters),
              "resolution");
    return tally.estimate();
  }

 private:
  static uint64_t textures_bytes(const Options& o) {
    const int R = o.resolution, S = o.slices;
    if (o.prefilter != Prefilter::Sat) return PyramidLayout(o.prefilter, R, S).bytes;
    return gpu::GpuSummedAreaTable::bytes(R, R, S,
                                          o.sat_precision == occlusion::SatPrecision::UInt32
                                              ? gpu::GpuSummedAreaTable::Entries::Uint32
                                              : gpu::GpuSummedAreaTable::Entries::Double);
  }
  uint64_t textures_bytes() const { return options_.prefilter == Prefilter::Sat ? sat_.device_bytes() : pyramid_.bytes(); }
  uint64_t textures_address() const {
    return options_.prefilter == Prefilter::Sat ? sat_.address() : pyramid_.address();
  }

  // eisemann2006 §3.4's slicing (stage "slicing"): one pass of the rasterizer from the centre of
  // projection, a bit per slice and texel; with thin_fix each slice's coverage also into the next.
  void slice(const Scene& scene, GpuFrame& frame) {
    gpu::CommandList& cl = *frame.commands;
    std::vector<uint32_t> flags = plan_.slicing_object_flags(scene);
    if (flags.empty()) flags.push_back(0u);
    gpu::ensure_buffer(*frame.device, flags_, flags.size() * sizeof(uint32_t), "the slicing pass's object flags");
    flags_.upload(std::span<const uint32_t>(flags));
    const int S = options_.slices;
    std::vector<Vec2f> tile_bins;
    rasterizer_->depth_bin_masks(cl, frame.flush, "slicing", *frame.scene, plan_.view(), RasterFilter{},
                                 plan_.slicing_bins(&tile_bins), flags_.address(), &masks_);
    stats_.extra["slicing_fragments"] = rasterizer_->stats().fragments;
    // The own slice's nearest depths at their finer texels (own_slice_scale > 1): a pass of their own.
    if (plan_.own_slice_active() && plan_.own_slice_scale() > 1)
      rasterizer_->depth_bin_masks(cl, frame.flush, "slicing", *frame.scene, plan_.nearest_view(), RasterFilter{},
                                   plan_.nearest_bins(&tile_bins), flags_.address(), &nearest_masks_);
    if (options_.thin_fix && S > 1) {
      cl.stage("slicing");
      cl.dispatch("ot_thin_fix", static_cast<uint64_t>(masks_.width()) * masks_.height(), mask_params());
    }
  }

  shader::OtMaskParams mask_params() const {
    const int S = options_.slices;
    return {masks_.masks(), bounds_.address(), masks_.width(), masks_.height(), S, S == 32 ? ~0u : (1u << S) - 1};
  }

  // §3.2's prefiltering (stage "filtering"): the slices' bounds and the pyramid a level at a time,
  // or the summed-area tables.
  void prefilter(GpuFrame& frame) {
    gpu::CommandList& cl = *frame.commands;
    gpu::Device& d = *frame.device;
    const int R = options_.resolution, S = options_.slices;
    const PyramidLayout layout(options_.prefilter, R, S);
    if (options_.prefilter != Prefilter::Sat && pyramid_.bytes() < layout.bytes) {
      frame.flush();  // nothing recorded may still read the old pyramid
      gpu::ensure_buffer(d, pyramid_, layout.bytes, "the occlusion textures' pyramid");
    }
    cl.stage("filtering");
    if (options_.prefilter == Prefilter::Sat) {
      // A table that grows submits what was recorded first; the rest is timed as filtering too.
      const gpu::SubmitRecorded submit = [&] {
        frame.flush();
        cl.stage("filtering");
      };
      sat_.build_from_bits(d, cl, submit, masks_.masks(), R, R, S,
                           options_.sat_precision == occlusion::SatPrecision::UInt32
                               ? gpu::GpuSummedAreaTable::Entries::Uint32
                               : gpu::GpuSummedAreaTable::Entries::Double);
      return;
    }
    // Every slice's covered rectangle, from nothing.
    const float empty[4] = {static_cast<float>(R), static_cast<float>(R), 0.0f, 0.0f};
    for (int k = 0; k < shader::kOtMaxSlices; ++k)
      for (int c = 0; c < 4; ++c) cl.fill(bounds_, std::bit_cast<uint32_t>(empty[c]), (4 * k + c) * 4, 4);
    cl.dispatch("ot_slice_bounds", static_cast<uint64_t>(R) * R, mask_params());
    cl.fill(pyramid_, 0);  // the padding row
    shader::OtTextures t{};
    t.prefilter = shared_prefilter(options_.prefilter);
    t.width = t.height = R;
    t.slices = S;
    auto level = [&](int l) {
      const int w = shader::ot_level_side(t.prefilter, R, l);
      return std::pair<uint32_t, int>{shader::ot_plane_offset(t, l, 0), w};
    };
    shader::OtPyramidParams p{};
    p.masks = masks_.masks();
    p.bytes = pyramid_.address();
    p.slices = S;
    p.dst_offset = 0;
    p.dst_width = p.dst_height = R;
    p.dst_plane = static_cast<uint32_t>(R) * R;
    cl.dispatch("ot_expand_bits", static_cast<uint64_t>(p.dst_plane) * S, p);
    for (int l = 1; l < layout.levels; ++l) {
      const auto [src_offset, src_side] = level(l - 1);
      const auto [dst_offset, dst_side] = level(l);
      p.src_offset = src_offset;
      p.src_width = p.src_height = src_side;
      p.src_plane = static_cast<uint32_t>(src_side) * src_side;
      p.dst_offset = dst_offset;
      p.dst_width = p.dst_height = dst_side;
      p.dst_plane = static_cast<uint32_t>(dst_side) * dst_side;
      p.step = 1 << (l - 1);
      cl.dispatch(options_.prefilter == Prefilter::Mipmap ? "ot_mip_level" : "ot_nbuffer_level",
                  static_cast<uint64_t>(p.dst_plane) * S, p);
    }
  }

  Options options_;
  occlusion::OcclusionTextures plan_;  // the CPU version's set-up (plan() only)
  std::unique_ptr<gpu::GpuRasterizer> rasterizer_;
  gpu::GpuDepthBinMasks masks_;
  gpu::GpuDepthBinMasks nearest_masks_;  // own_slice_scale > 1
  const gpu::GpuDepthBinMasks& own_slice_depths() const { return plan_.own_slice_scale() == 1 ? masks_ : nearest_masks_; }
  gpu::GpuSummedAreaTable sat_;
  gpu::Buffer setup_, bounds_, counters_, flags_, pyramid_;
  bool counting_ = false;  // evaluate() ran since the last collect_stats()
};

const GpuMethodRegistration registration({"occlusion-textures",
                                          [](const ParamSet& p) { return std::make_unique<OcclusionTexturesGpu>(p); },
                                          OcclusionTexturesGpu::memory});

}  // namespace
}  // namespace penumbra
