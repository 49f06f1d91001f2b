#include "penumbra/shadow/partitions/light_partitions.h"

#include <algorithm>
#include <bit>
#include <cmath>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/shadow/shadow_map_common.h"

namespace penumbra::partitions {

std::vector<ParamSpec> param_specs(int default_partitions, double default_density, double default_receivers) {
  return {
      {"partitions", ParamType::Int, default_partitions,
       "most light-space partitions a side (1, 2, 4, 8, 16): where more caster triangles project into a part of the "
       "fitted view than partition_density x the map's texels, the view samples are split there and each part gets a "
       "map fitted to it alone (penumbra's addition, after sample distribution shadow maps; 1 = one map)",
       {}, 1, 16},
      {"partition_density", ParamType::Float, default_density,
       "caster triangles per map texel above which a light-space partition splits in four (0 = always split to "
       "`partitions`)",
       {}, 0.0, 1e6},
      {"partition_receivers", ParamType::Float, default_receivers,
       "view samples per map texel, in the densest part of a light-space partition, above which it splits in four "
       "(where the camera sees that part from near: sample distribution shadow maps' rule; 0 = off: only the "
       "casters split)",
       {}, 0.0, 1e9},
  };
}

Settings settings_from(const ParamSet& p, int map_resolution) {
  Settings s;
  s.max_side = p.get_int("partitions");
  if (!std::has_single_bit(static_cast<unsigned>(s.max_side)))
    throw Error("partitions = {} must be a power of two (1, 2, 4, 8 or 16)", s.max_side);
  s.density = p.get_float("partition_density");
  s.receiver_density = p.get_float("partition_receivers");
  s.map_texels = map_resolution * map_resolution;
  s.max_fov = p.get_float("max_fov");
  return s;
}

ShadowViewFrame light_frame(const AreaLight& light, const Bounds3f& scene_bounds) {
  ShadowViewFit fit;
  return shadow_view_frame(light.center, light.frame.n, light.frame.t, scene_bounds, {}, fit);
}

void CasterCentroids::gather(const Scene& scene, const ShadowViewFrame& frame) {
  xyz.clear();
  z_min = kInfinity;
  for (const SceneObject& o : scene.objects) {
    const TriangleMesh& m = o.mesh;
    for (size_t t = 0; t < m.triangle_count(); ++t) {
      const Vec3f a = m.vertex(t, 0), b = m.vertex(t, 1), c = m.vertex(t, 2);
      float x, y, z;
      if (!shader::shadow_view_project(frame.axes, (a + b + c) * (1.0f / 3.0f), x, y, z)) continue;
      xyz.push_back({x, y, z});
      z_min = std::min(z_min, z);
    }
  }
}

int grid_cells(const Settings& s) { return std::max(8, 8 * s.max_side); }

shader::PartitionGrid grid_over(const ShadowViewFrame& frame, const ShadowViewRange& range, int grid) {
  // Receivers beyond 80 degrees off the axis are clamped to the border cells (no map reaches
  // that far: the methods' max_fov is at most 179).
  const float cap = std::tan(radians(80.0f));
  const float x0 = std::max(range.x0, -cap), x1 = std::min(range.x1, cap);
  const float y0 = std::max(range.y0, -cap), y1 = std::min(range.y1, cap);
  const float wx = std::max(x1 - x0, 1e-6f) * (1 + 1e-4f), wy = std::max(y1 - y0, 1e-6f) * (1 + 1e-4f);
  shader::PartitionGrid g{};
  g.axes = frame.axes;
  g.x0 = x0 - 0.5e-4f * wx;
  g.y0 = y0 - 0.5e-4f * wy;
  g.cells_per_x = float(grid) / wx;
  g.cells_per_y = float(grid) / wy;
  return g;
}

namespace {

// The most receivers one grid cell of a node `size` cells a side may hold before the node splits:
// receiver_density x the texels a map of the node gives one cell.
double receiver_limit(const Settings& s, int size) {
  if (!(s.receiver_density > 0)) return kInfinity;  // off
  return double(s.receiver_density) * double(s.map_texels) / (double(size) * double(size));
}

}  // namespace

bool receivers_could_split(uint64_t view_samples, const Settings& s) {
  return s.max_side > 1 && double(view_samples) > receiver_limit(s, grid_cells(s));
}

bool could_split(const CasterCentroids& casters, const Settings& s, uint64_t view_samples) {
  return s.max_side > 1 && (double(casters.xyz.size()) > double(s.density) * double(s.map_texels) ||
                            receivers_could_split(view_samples, s));
}

bool may_split(const ShadowViewFrame& frame, const ShadowViewRange& receivers, const CasterCentroids& casters,
               const Settings& s, uint64_t view_samples) {
  if (s.max_side <= 1 || !(receivers.x1 >= receivers.x0)) return false;
  if (receivers_could_split(view_samples, s)) return true;
  const shader::PartitionGrid g = grid_over(frame, receivers, 1);
  const double limit = double(s.density) * double(s.map_texels);
  uint64_t count = 0;
  for (Vec3f c : casters.xyz) {
    if (!(c.z <= receivers.z1)) continue;
    const float fx = (c.x - g.x0) * g.cells_per_x, fy = (c.y - g.y0) * g.cells_per_y;
    count += fx >= 0 && fx < 1 && fy >= 0 && fy < 1;
    if (double(count) > limit) return true;
  }
  return false;
}

Plan make_plan(const ShadowViewFrame& frame, const ReceiverGrid& receivers, const CasterCentroids& casters,
               const AreaLight& light, const Settings& s) {
  Plan plan;
  plan.grid = receivers.grid;
  const int G = plan.grid;
  plan.g = grid_over(frame, receivers.range, G);
  plan.leaf_of_cell.assign(static_cast<size_t>(G) * G, -1);
  // Casters per cell: the centroids no deeper than the deepest receiver (nothing farther
  // shadows a receiver) and inside the root.
  std::vector<uint32_t> casters_in(static_cast<size_t>(G) * G, 0);
  for (Vec3f c : casters.xyz) {
    if (!(c.z <= receivers.range.z1)) continue;
    const float fx = (c.x - plan.g.x0) * plan.g.cells_per_x, fy = (c.y - plan.g.y0) * plan.g.cells_per_y;
    if (!(fx >= 0 && fx < G && fy >= 0 && fy < G)) continue;
    ++casters_in[static_cast<size_t>(fy) * G + static_cast<size_t>(fx)];
  }
  // The quadtree over cells: a node is (x, y, size) in cells, the root G cells a side; its
  // deepest level has max_side nodes a side, each G / max_side (>= 8) cells.
  const int min_size = G / std::max(1, s.max_side);
  const double limit = double(s.density) * double(s.map_texels);
  struct Node { int x, y, size; };
  std::vector<Node> stack{{0, 0, G}}, leaves;
  while (!stack.empty()) {
    const Node n = stack.back();
    stack.pop_back();
    uint64_t occupied = 0, count = 0;
    uint32_t densest = 0;  // the most receivers in one cell
    for (int y = n.y; y < n.y + n.size; ++y)
      for (int x = n.x; x < n.x + n.size; ++x) {
        const uint32_t r = receivers.counts[static_cast<size_t>(y) * G + x];
        occupied += r > 0;
        densest = std::max(densest, r);
        count += casters_in[static_cast<size_t>(y) * G + x];
      }
    if (occupied == 0) continue;
    if (n.size > min_size && (double(count) > limit || double(densest) > receiver_limit(s, n.size))) {
      const int h = n.size / 2;
      // Pushed in reverse so leaves come out in row order of the quadrants.
      for (int q = 3; q >= 0; --q) stack.push_back({n.x + (q & 1) * h, n.y + (q >> 1) * h, h});
      continue;
    }
    leaves.push_back(n);
  }
  plan.leaves = static_cast<int>(leaves.size());
  // The blocker search margin (xie2007 eq. 1 in x/z units): a receiver at depth z_r sees casters
  // at depth >= z_min within r (1/z_min - 1/z_r) of its own x/z, r the light's extent radius.
  const float z_r = receivers.range.z1;
  const float z_min = std::max(std::min(casters.z_min, z_r), frame.axes.min_near);
  const float margin = light.extent_radius() * std::max(0.0f, 1.0f / z_min - 1.0f / z_r);
  const Vec3f eye = frame.axes.eye, right = frame.axes.right, up = frame.axes.up, fwd = frame.axes.forward;
  const float inside = std::tan(radians(0.45f * s.max_fov));
  // Whether cell (x, y) lies wholly within `inside` of the axis (its receivers are in any fit).
  auto cell_inside = [&](int x, int y) {
    const float cx0 = plan.g.x0 + float(x) / plan.g.cells_per_x, cx1 = plan.g.x0 + float(x + 1) / plan.g.cells_per_x;
    const float cy0 = plan.g.y0 + float(y) / plan.g.cells_per_y, cy1 = plan.g.y0 + float(y + 1) / plan.g.cells_per_y;
    return cx0 >= -inside && cx1 <= inside && cy0 >= -inside && cy1 <= inside;
  };
  for (int i = 0; i < plan.leaves; ++i) {
    const Node& n = leaves[i];
    bool fits = false;  // some occupied cell wholly inside
    for (int y = n.y; y < n.y + n.size; ++y)
      for (int x = n.x; x < n.x + n.size; ++x) {
        plan.leaf_of_cell[static_cast<size_t>(y) * G + x] = i;
        fits = fits || (receivers.counts[static_cast<size_t>(y) * G + x] > 0 && cell_inside(x, y));
      }
    plan.guarded.push_back(s.guards == GuardSamples::AtTheMargin || !fits);
    const float x0 = plan.g.x0 + float(n.x) / plan.g.cells_per_x - margin;
    const float x1 = plan.g.x0 + float(n.x + n.size) / plan.g.cells_per_x + margin;
    const float y0 = plan.g.y0 + float(n.y) / plan.g.cells_per_y - margin;
    const float y1 = plan.g.y0 + float(n.y + n.size) / plan.g.cells_per_y + margin;
    std::array<Vec3f, 4> corners;
    for (int c = 0; c < 4; ++c) {
      const float x = std::clamp((c & 1) ? x1 : x0, -inside, inside);
      const float y = std::clamp((c & 2) ? y1 : y0, -inside, inside);
      corners[c] = eye + (right * x + up * y + fwd) * z_r;
    }
    plan.guards.push_back(corners);
  }
  return plan;
}

namespace {

using shadow_map::in_front_of_light;  // a receiver: a hit in front of the light, as every fit counts it

// The receivers (their points, their light-centre range `range`) on the plan's grid.
ReceiverGrid receiver_grid(const ShadowViewFrame& frame, std::span<const Vec3f> points, const ShadowViewRange& range,
                           int grid) {
  ReceiverGrid r;
  r.grid = grid;
  r.range = range;
  r.counts.assign(static_cast<size_t>(grid) * grid, 0);
  if (!(r.range.x1 >= r.range.x0)) return r;
  const shader::PartitionGrid g = grid_over(frame, r.range, grid);
  for (Vec3f p : points) {
    const int cell = shader::partition_cell(g, grid, p);
    if (cell >= 0) ++r.counts[cell];
  }
  return r;
}

class PartitionedMethod final : public ShadowMethod {
 public:
  PartitionedMethod(std::unique_ptr<ShadowMethod> inner, const Settings& s) : inner_(std::move(inner)), settings_(s) {}

  void prepare(const ShadowContext& ctx) override {
    inner_->stats() = stats_;
    inner_->prepare(ctx);
    stats_ = inner_->stats();
    ScopedPhase phase(stats_, "partition plan");
    frame_ = light_frame(*ctx.light, ctx.scene->bounds());
    casters_.gather(*ctx.scene, frame_);
  }

  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override {
    Plan plan;
    if (could_split(casters_, settings_, vs.size())) {
      ScopedPhase phase(stats_, "partition plan");
      // The fits' own receivers and reduction (shadow_map_common.h, raster/shadow_view.h).
      const std::vector<Vec3f> points = shadow_map::receiver_points(vs, *ctx.light);
      const ShadowViewRange range = reduce_receivers(frame_, points);
      if (may_split(frame_, range, casters_, settings_, points.size()))
        plan = make_plan(frame_, receiver_grid(frame_, points, range, grid_cells(settings_)), casters_, *ctx.light,
                         settings_);
    }
    stats_.extra["partitions"] = std::max(1, plan.leaves);
    inner_->stats() = stats_;
    if (!plan.split()) {
      inner_->evaluate(ctx, vs, out);
      stats_ = inner_->stats();
      stats_.extra["partitions"] = 1;
      return;
    }
    // The view samples of each leaf, in their order; those in no leaf (not receivers) are the
    // method's to judge: they join the first partition.
    std::vector<std::vector<uint32_t>> members(plan.leaves);
    for (size_t i = 0; i < vs.size(); ++i) {
      const ViewSample& s = vs.samples[i];
      const int cell = in_front_of_light(*ctx.light, s.p) ? shader::partition_cell(plan.g, plan.grid, s.p) : -1;
      const int leaf = cell >= 0 ? plan.leaf_of_cell[cell] : -1;
      members[leaf >= 0 ? leaf : 0].push_back(static_cast<uint32_t>(i));
    }
    ShadowContext part_ctx = ctx;
    part_ctx.progress = nullptr;  // counted here, without the guard samples
    ViewSamples part;
    part.width = vs.width;
    part.height = vs.height;
    part.window = vs.window;
    part.samples_per_pixel = vs.samples_per_pixel;
    std::vector<float> v;
    std::vector<Vec3f> e;
    const bool irradiance = inner_->computes_irradiance();
    for (int leaf = 0; leaf < plan.leaves; ++leaf) {
      const std::vector<uint32_t>& m = members[leaf];
      if (m.empty()) continue;
      part.samples.clear();
      for (uint32_t i : m) part.samples.push_back(vs.samples[i]);
      for (int c = 0; c < plan.guard_count(leaf); ++c) {
        const Vec3f g = plan.guards[leaf][c];
        ViewSample guard = vs.samples[m.front()];
        guard.p = g;
        guard.ng = guard.ns = -ctx.light->frame.n;  // facing the light
        guard.albedo = Vec3f(0.0f);
        part.samples.push_back(guard);
      }
      v.assign(part.size(), 1.0f);
      e.assign(irradiance ? part.size() : 0, Vec3f(0.0f));
      ShadowOutput part_out{v, e};
      inner_->evaluate(part_ctx, part, part_out);
      for (size_t j = 0; j < m.size(); ++j) {
        out.visibility[m[j]] = v[j];
        if (irradiance) out.irradiance[m[j]] = e[j];
      }
      if (ctx.progress) ctx.progress->add(m.size());
    }
    stats_ = inner_->stats();
    stats_.extra["partitions"] = plan.leaves;
  }

  bool computes_irradiance() const override { return inner_->computes_irradiance(); }

 private:
  std::unique_ptr<ShadowMethod> inner_;
  Settings settings_;
  ShadowViewFrame frame_{};
  CasterCentroids casters_;
};

}  // namespace

void add_memory(MemoryTally& tally, const ParamSet& p, const MemoryQuery& q) {
  if (p.get_int("partitions") <= 1) return;
  tally.add(q.triangles * sizeof(Vec3f), kTrianglesSetting);
  tally.add(q.view_samples * (sizeof(ViewSample) + 2 * sizeof(uint32_t) + sizeof(float) + sizeof(Vec3f)),
            kViewSamplesSetting);
}

std::unique_ptr<ShadowMethod> wrap(std::unique_ptr<ShadowMethod> inner, const ParamSet& p, int map_resolution,
                                   GuardSamples guards) {
  Settings s = settings_from(p, map_resolution);
  s.guards = guards;
  if (s.max_side == 1) return inner;
  return std::make_unique<PartitionedMethod>(std::move(inner), s);
}

}  // namespace penumbra::partitions
