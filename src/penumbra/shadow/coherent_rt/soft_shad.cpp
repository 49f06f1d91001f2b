#include "penumbra/shadow/coherent_rt/soft_shad.h"

#include "penumbra/core/error.h"

namespace penumbra::coherent_rt {

void SoftShadCounters::add(const SoftShadCounters& o) {
  points += o.points;
  rays += o.rays;
  resets += o.resets;
  predicted_wrong += o.predicted_wrong;
  shortcut_cells += o.shortcut_cells;
  blocker_points += o.blocker_points;
}

AreaLight sampled_light(const AreaLight& light) {
  if (light.shape != LightShape::Sphere) return light;
  AreaLight disk = light;
  disk.shape = LightShape::Disk;
  return disk;
}

void check_light(const AreaLight& light) {
  if (!supports_light(light.shape))
    throw Error("coherent-rt does not support {} lights (the one at [{}, {}, {}]); only rect, disk and sphere lights",
                to_string(light.shape), light.center.x, light.center.y, light.center.z);
}

SoftShad::SoftShad(const AreaLight& light, int cols, int rows, const SoftShadOptions& options)
    : light_(light.geometry()) {
  // Cells on a rect or a disk only (a sphere comes as its disk: sampled_light).
  if (light.shape != LightShape::Rect && light.shape != LightShape::Disk)
    throw Error("coherent-rt: coherence sampling does not support {} lights; only rect and disk lights",
                to_string(light.shape));
  if (options.sub_grid < 1) throw Error("coherent-rt: sub_grid {} must be at least 1", options.sub_grid);
  state_ = shader::ss_make(cols, rows, options.sub_grid, options.coherence, options.shortcut, options.reset_distance);
  const size_t cells = static_cast<size_t>(cols) * rows;
  stamp_.resize(static_cast<size_t>(state_.scols) * state_.srows);
  visible_.resize(cells);
  predicted_blocked_.resize(cells);
  cell_state_.resize(cells);
  queue_.resize(cells);
  shader::ss_clear(arrays(nullptr), state_);
}

}  // namespace penumbra::coherent_rt
