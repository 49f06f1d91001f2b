// Coherence-based light sampling, agrawala2000 §5.2 (procedure SoftShad). The light's
// stratified cells form a cols x rows visibility image; surface points are shaded one
// after another in a coherent order, and the visibility image of point p_i is predicted
// from the blocker points found for earlier points, projected from p_i onto the light.
// Only cells where the prediction is uncertain are traced (cellsTodo: cells on the light's
// border and cells whose 8 neighbours do not all share their predicted value); when a traced
// ray disagrees with the prediction, its 8 neighbours still trusted (cellsUsePrev) are
// traced too (8-connected flood). Everything else keeps the predicted value.
//
// The blocker points list (§5.2.2) holds the blocker of each blocked ray traced; on each
// prediction it is pruned to points that project onto the light and to one point per cell
// of a 3 x 3 (sub_grid) grid inside each light cell; a light cell whose jittered sample
// falls in a sub-cell holding a blocker point is done (blocked) without a ray. The
// prediction is dropped (every cell traced) when p_i is farther from p_{i-1} than
// reset_distance times p_i's distance to the light's centre (§5.2.1), and for the first
// point; otherwise an empty list predicts the whole light visible and only its border is
// traced (§5.2.1's missed-blocker argument).
//
// Planar lights whose samples are a map of the unit square that keeps neighbours neighbours: a
// rect (affine) and a disk (concentric_disk): a blocker point projects through p_i onto the
// light's plane and back to the square (ss_project). supports_light says which.
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/scene/light.h"
#include "penumbra/shadow/coherent_rt/soft_shad_shared.h"

namespace penumbra::coherent_rt {

// The light shapes coherent-rt samples (both devices): a rect, agrawala2000's, and a disk, its
// cells the rect's under concentric_disk; a sphere through its central disk facing the scene
// (sampled_light). An ellipsoid's central ellipse has no such cells: not supported.
inline bool supports_light(LightShape s) { return s != LightShape::Ellipsoid; }
// The light whose cells coherent-rt samples for `light`: the light itself, or for a sphere the disk
// of its radius through its centre, facing the scene (frame.n, which Scene::orient_sphere_lights
// points at the scene's centre), as afsm and every light-space method sample a sphere. V is then
// the fraction of that disk a point sees, not of the sphere's solid angle (`reference`'s), and E
// the sphere's closed form times V (sphere_emitter).
AreaLight sampled_light(const AreaLight& light);
inline bool sphere_emitter(const AreaLight& light) { return light.shape == LightShape::Sphere; }
// The one-line error for a light coherent-rt does not sample, naming it by its centre (the
// renderer's index of a light is not the scene file's where it splits a light into several:
// render/renderer.h drawn_lights).
void check_light(const AreaLight& light);

struct SoftShadOptions {
  bool coherence = true;        // off: every cell traced (plain stratified sampling)
  int sub_grid = 3;             // blocker-point sub-cells per light cell along each axis
  float reset_distance = 0.02f; // relative to the distance to the light's centre
  bool shortcut = true;         // the sub-grid shortcut of §5.2.2
};

struct SoftShadCounters {
  uint64_t points = 0;
  uint64_t rays = 0;            // shadow rays traced
  uint64_t resets = 0;          // points shaded without a prediction
  uint64_t predicted_wrong = 0; // traced rays that disagreed with the prediction
  uint64_t shortcut_cells = 0;  // cells done by the sub-grid shortcut (§5.2.2)
  uint64_t blocker_points = 0;  // sum over points of the pruned list's size
  void add(const SoftShadCounters& o);
};

// A traced ray's answer: blocked, and if so the blocker point when known.
struct RayAnswer {
  bool blocked = false;
  bool has_point = false;
  Vec3f point;
};

class SoftShad {
 public:
  // cols x rows cells (stratification_grid of the light sample count).
  SoftShad(const AreaLight& light, int cols, int rows, const SoftShadOptions& options);

  // Forget the prediction (e.g. at the start of a tile).
  void reset() {
    state_.blockers = 0;
    state_.has_prev = 0;
  }

  // Light visibility of point p: samples[j] is cell j's jittered sample on the unit square
  // (cell j = (j % cols, j / cols)); trace(j) traces the ray to it and returns a RayAnswer.
  // On return visible()[j] is 1 where cell j is unblocked. The state machine is
  // soft_shad_shared.h's, which the GPU's tiles run too.
  template <class Trace>
  void shade(Vec3f p, const Vec2f* samples, Trace&& trace, SoftShadCounters* counters);

  const std::vector<uint8_t>& visible() const { return visible_; }
  size_t blocker_count() const { return state_.blockers; }

  // What a sampler of `cells` light cells holds at most: a stamp per sub-cell, three flags
  // and a queue entry per cell, and the blocker points (at most one per sub-cell).
  static uint64_t bytes(int cells, int sub_grid) {
    const uint64_t n = static_cast<uint64_t>(cells);
    return n * static_cast<uint64_t>(sub_grid) * static_cast<uint64_t>(sub_grid) * (sizeof(uint32_t) + sizeof(Vec3f)) +
           n * (3 + sizeof(int));
  }

 private:
  shader::SoftShadArrays arrays(const Vec2f* samples) {
    return {stamp_.data(), visible_.data(), predicted_blocked_.data(), cell_state_.data(), samples, queue_.data(),
            &blockers_};
  }

  shader::LightGeometry light_;
  shader::SoftShadState state_;
  std::vector<Vec3f> blockers_;
  std::vector<uint32_t> stamp_;  // per sub-cell: the prediction generation that holds a point
  std::vector<uint8_t> visible_, predicted_blocked_, cell_state_;
  std::vector<int> queue_;
};

template <class Trace>
void SoftShad::shade(Vec3f p, const Vec2f* samples, Trace&& trace, SoftShadCounters* c) {
  shader::SoftShadCounts k{};
  const shader::SoftShadArrays r = arrays(samples);
  shader::ss_begin(r, state_, light_, p, k);
  for (int j; (j = shader::ss_next(r, state_)) >= 0;) {
    const RayAnswer a = trace(j);
    shader::ss_answer(r, state_, light_, p, j, a.blocked, a.has_point, a.point, k);
  }
  c->points += k.points;
  c->rays += k.rays;
  c->resets += k.resets;
  c->predicted_wrong += k.predicted_wrong;
  c->shortcut_cells += k.shortcut_cells;
  c->blocker_points += k.blocker_points;
}

}  // namespace penumbra::coherent_rt
