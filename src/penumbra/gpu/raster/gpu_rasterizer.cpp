#include "penumbra/gpu/raster/gpu_rasterizer.h"

#include <algorithm>
#include <atomic>
#include <cstddef>

#include "penumbra/core/error.h"
#include "penumbra/gpu/raster/raster_capacities_testing.h"
#include "penumbra/gpu/raster/raster_layout_shared.h"

namespace penumbra::gpu {
namespace {

using shader::GpuRasterItem;
using shader::GpuRasterState;
using shader::GpuRasterTriangle;

constexpr uint64_t kMaxCapacity = 0xffffffffu;  // items and triangles are indexed by uint32

uint64_t tiles(int width, int height) {
  const uint64_t t = shader::kRasterTile;
  return ((static_cast<uint64_t>(width) + t - 1) / t) * ((static_cast<uint64_t>(height) + t - 1) / t);
}

// The first capacities for a scene and a map (scratch_bytes counts these).
uint64_t initial_triangles(uint64_t triangles) { return triangles + triangles / 8 + 64; }
uint64_t initial_items(uint64_t triangles, int width, int height) {
  return 2 * triangles + 2 * tiles(width, height) + 1024;
}

// RasterCapacitiesForTesting's state: the first capacities of new rasterizers while one lives.
struct TestingCapacities {
  std::atomic<bool> active{false};
  uint32_t triangles = 0, items = 0;
  std::atomic<int> retries{0};
};
TestingCapacities& testing_capacities() {
  static TestingCapacities t;
  return t;
}

}  // namespace

RasterCapacitiesForTesting::RasterCapacitiesForTesting(uint32_t triangles, uint32_t items) {
  TestingCapacities& t = testing_capacities();
  if (t.active) throw Error("RasterCapacitiesForTesting: one is already in force");
  t.triangles = triangles;
  t.items = items;
  t.retries = 0;
  t.active = true;
}

RasterCapacitiesForTesting::~RasterCapacitiesForTesting() { testing_capacities().active = false; }

int RasterCapacitiesForTesting::retries() const { return testing_capacities().retries; }

void GpuDepthMap::resize(Device& device, int w, int h) {
  if (w == width_ && h == height_ && !keys_.empty()) return;
  const uint64_t n = static_cast<uint64_t>(w) * static_cast<uint64_t>(h);
  keys_ = Buffer(device, n * 8, "a depth map's keys");
  z_ = Buffer(device, n * 4, "a depth map's depths");
  depth_ = Buffer(device, n * 4, "a depth map's window depths");
  opacity_ = Buffer(device, n * 4, "a depth map's opacities");
  triangle_ = Buffer(device, n * 4, "a depth map's triangles");
  if (view_record_.empty()) view_record_ = Buffer(device, sizeof(shader::RasterView), "a depth map's view");
  width_ = w;
  height_ = h;
}

DepthMap GpuDepthMap::download() const {
  DepthMap m;
  m.resize(width_, height_);
  const uint64_t n = static_cast<uint64_t>(width_) * height_;
  z_.download(m.z.data(), n * 4);
  depth_.download(m.depth.data(), n * 4);
  opacity_.download(m.opacity.data(), n * 4);
  triangle_.download(m.triangle.data(), n * 4);
  return m;
}

uint64_t GpuDepthMap::device_bytes() const {
  uint64_t total = 0;
  for (const Buffer* b : {&keys_, &z_, &depth_, &opacity_, &triangle_, &view_record_}) total += b->bytes();
  return total;
}

uint64_t GpuDepthMap::bytes(int w, int h) {
  return static_cast<uint64_t>(w) * static_cast<uint64_t>(h) * (8 + 4 * 4) + sizeof(shader::RasterView);
}

GpuRasterizer::GpuRasterizer(Device& device)
    : device_(&device), scratch_(sizeof(GpuRasterTriangle), "the rasterizer") {
  state_ = Buffer(device, sizeof(GpuRasterState), "the rasterizer's counters");
  const TestingCapacities& t = testing_capacities();
  if (t.active) set_capacities_for_testing(t.triangles, t.items);
}

uint64_t GpuRasterizer::scratch_bytes(uint64_t triangles, int width, int height) {
  return initial_triangles(triangles) * sizeof(GpuRasterTriangle) +
         initial_items(triangles, width, height) * sizeof(GpuRasterItem) + sizeof(GpuRasterState);
}

void GpuRasterizer::set_capacities_for_testing(uint32_t triangles, uint32_t items) {
  scratch_.set_for_testing(*device_, triangles, items);
}

void GpuRasterizer::depth_map(CommandList& cl, const Submit& submit, std::string_view stage, const GpuScene& scene,
                              const LightView& view, const RasterFilter& filter, GpuDepthMap* out,
                              uint64_t object_flags) {
  // The host writes the view record and may reallocate buffers below: nothing recorded before
  // may still be waiting to read them.
  submit();
  out->resize(*device_, view.width(), view.height());
  out->view_ = view;
  const shader::RasterView record = view.shared();
  out->view_record_.upload(&record, sizeof(record));
  const uint64_t texels = static_cast<uint64_t>(view.width()) * view.height();
  const GpuRasterState s = render_passes(
      cl, submit, stage, scene, view, out->view_record_.address(), filter, object_flags,
      [&](const shader::RasterFillParams& setup) {
        shader::RasterFillParams fp = setup;
        fp.keys = out->keys_.address();
        cl.fill(out->keys_, kRasterEmptyWord);
        cl.dispatch_indirect("raster_fill", state_, offsetof(GpuRasterState, fill_groups_x), fp);
        shader::RasterResolveParams rp{};
        rp.scene = scene.address();
        rp.view = out->view_record_.address();
        rp.state = state_.address();
        rp.keys = out->keys_.address();
        rp.z = out->z_.address();
        rp.depth = out->depth_.address();
        rp.opacity = out->opacity_.address();
        rp.triangle = out->triangle_.address();
        cl.dispatch("raster_resolve", texels, rp);
      });
  out->z_min_ = s.z_min_bits == kRasterEmptyWord ? kInfinity : shader::raster_order_float(s.z_min_bits);
}

GpuRasterState GpuRasterizer::render_passes(CommandList& cl, const Submit& submit, std::string_view stage,
                                            const GpuScene& scene, const LightView& view, uint64_t view_record,
                                            const RasterFilter& filter, uint64_t object_flags, const RecordFill& fill) {
  const uint64_t triangles = scene.triangle_count();
  if (scratch_.empty())
    scratch_.ensure(*device_, std::min(kMaxCapacity, initial_triangles(triangles)),
                    std::min(kMaxCapacity, initial_items(triangles, view.width(), view.height())));
  stats_ = {};
  stats_.triangles = triangles;
  attempts_ = 0;
  for (;;) {
    ++attempts_;
    cl.stage(stage);
    cl.fill(state_, 0);
    cl.fill(state_, kRasterEmptyWord, offsetof(GpuRasterState, z_min_bits), 4);
    shader::RasterSetupParams sp{};
    sp.scene = scene.address();
    sp.view = view_record;
    sp.state = state_.address();
    sp.triangles = scratch_.triangles_address();
    sp.items = scratch_.items_address();
    sp.triangle_count = static_cast<uint32_t>(triangles);
    sp.triangle_capacity = scratch_.triangle_capacity();
    sp.item_capacity = scratch_.item_capacity();
    sp.culling = raster_culling_code(filter);
    sp.opaque_only = filter.opaque_only ? 1u : 0u;
    sp.object_flags = object_flags;
    cl.dispatch("raster_setup", triangles, sp);
    shader::RasterFillParams fp{};
    fp.scene = scene.address();
    fp.view = view_record;
    fp.state = state_.address();
    fp.triangles = scratch_.triangles_address();
    fp.items = scratch_.items_address();
    fp.triangle_capacity = scratch_.triangle_capacity();
    fp.item_capacity = scratch_.item_capacity();
    cl.dispatch("raster_fill_args", 1, fp);
    fill(fp);
    submit();
    GpuRasterState s{};
    state_.download(&s, sizeof(s));
    if (scratch_.fitted_or_grown(*device_, s, &stats_)) return s;
    if (testing_capacities().active) ++testing_capacities().retries;
  }
}

}  // namespace penumbra::gpu
