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

SoftShad::SoftShad(const AreaLight& light, int cols, int rows, const SoftShadOptions& options)
    : light_(&light), cols_(cols), rows_(rows), options_(options) {
  if (light.shape != LightShape::Rect)
    throw Error("coherent-rt: coherence sampling does not support {} lights; only rect lights", to_string(light.shape));
  if (options.sub_grid < 1) throw Error("coherent-rt: sub_grid {} must be at least 1", options.sub_grid);
  scols_ = cols * options.sub_grid;
  srows_ = rows * options.sub_grid;
  stamp_.assign(static_cast<size_t>(scols_) * srows_, 0);
  visible_.assign(static_cast<size_t>(cols) * rows, 1);
  predicted_blocked_.assign(visible_.size(), 0);
  state_.assign(visible_.size(), kTodo);
}

bool SoftShad::project(Vec3f p, Vec3f b, Vec2f* u) const {
  const AreaLight& l = *light_;
  const Vec3f n = l.frame.n;
  float denom = dot(b - p, n);
  if (denom == 0) return false;
  float tau = dot(l.center - p, n) / denom;
  if (!(tau >= 1.0f)) return false;  // b is not between p and the light's plane
  Vec3f q = p + (b - p) * tau - l.center;
  u->x = dot(q, l.frame.s) / l.size.x + 0.5f;
  u->y = dot(q, l.frame.t) / l.size.y + 0.5f;
  return u->x >= 0 && u->x < 1 && u->y >= 0 && u->y < 1;
}

void SoftShad::add_blocker(Vec3f p, Vec3f b) {
  Vec2f u;
  if (!project(p, b, &u)) return;
  uint32_t& s = stamp_[sub_index(u)];
  if (s == generation_) return;  // the sub-cell has its point
  s = generation_;
  blockers_.push_back(b);
}

void SoftShad::predict(Vec3f p, const Vec2f* samples, SoftShadCounters* c) {
  const int n = cols_ * rows_;
  // §5.2.1: no prediction for the first point, nor across a jump between consecutive
  // points. Otherwise an empty list is a prediction too: the light entirely visible, as
  // from p_{i-1} in §5.2.1's missed-blocker argument, where only the border is traced.
  const bool reset = !has_prev_ || distance(p, prev_) > options_.reset_distance * distance(p, light_->center);
  prev_ = p;
  has_prev_ = true;
  if (++generation_ == 0) {  // wrapped: clear the stamps
    std::fill(stamp_.begin(), stamp_.end(), 0u);
    generation_ = 1;
  }
  if (reset) {
    blockers_.clear();
    ++c->resets;
    for (int j = 0; j < n; ++j) {
      visible_[j] = 1;
      state_[j] = kTodo;
      queue_.push_back(j);
    }
    return;
  }
  // Project the blocker points; keep those on the light, one per sub-cell (§5.2.2).
  std::fill(predicted_blocked_.begin(), predicted_blocked_.end(), 0);
  size_t kept = 0;
  for (size_t i = 0; i < blockers_.size(); ++i) {
    Vec2f u;
    if (!project(p, blockers_[i], &u)) continue;
    int sub = sub_index(u);
    if (stamp_[sub] == generation_) continue;
    stamp_[sub] = generation_;
    blockers_[kept++] = blockers_[i];
    int sx = sub % scols_, sy = sub / scols_;
    predicted_blocked_[(sy / options_.sub_grid) * cols_ + sx / options_.sub_grid] = 1;
  }
  blockers_.resize(kept);
  c->blocker_points += kept;
  for (int j = 0; j < n; ++j) {
    visible_[j] = !predicted_blocked_[j];
    state_[j] = kUsePrev;
  }
  // The sub-grid shortcut: a blocker point in the sub-cell of a cell's sample blocks it.
  if (options_.shortcut)
    for (int j = 0; j < n; ++j)
      if (stamp_[sub_index(samples[j])] == generation_) {
        state_[j] = kDone;
        visible_[j] = 0;
        ++c->shortcut_cells;
      }
  // cellsTodo: the light's border and the edges of the predicted image (Figure 8).
  for (int cy = 0; cy < rows_; ++cy)
    for (int cx = 0; cx < cols_; ++cx) {
      const int j = cy * cols_ + cx;
      if (state_[j] == kDone) continue;
      bool todo = cx == 0 || cy == 0 || cx == cols_ - 1 || cy == rows_ - 1;
      for (int dy = -1; dy <= 1 && !todo; ++dy)
        for (int dx = -1; dx <= 1 && !todo; ++dx)
          todo = predicted_blocked_[(cy + dy) * cols_ + cx + dx] != predicted_blocked_[j];
      if (todo) {
        state_[j] = kTodo;
        queue_.push_back(j);
      }
    }
}

}  // namespace penumbra::coherent_rt
