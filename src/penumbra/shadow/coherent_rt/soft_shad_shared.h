// Coherence-based light sampling, agrawala2000 §5.2 (procedure SoftShad), in the common subset of
// C++ and GLSL (core/shader_compat.h): the CPU's SoftShad (soft_shad.h) and the GPU's tile
// threads (kernels/coherent_rt_tiles.comp) run this one state machine. GLSL has no callbacks, so
// shading a point is
//   ss_begin(point)           the prediction from the earlier points (or none), the cells to trace
//   j = ss_next()             the next cell to trace (-1: done)
//   ss_answer(j, answer)      its ray's answer: a disagreement floods the neighbours
// and the caller traces cell j's ray between ss_next and ss_answer. The arrays live where the
// language keeps them (C++: the SoftShad's vectors; GLSL: the tile's slice of a scratch buffer),
// behind the accessors each branch below defines.
#ifndef PENUMBRA_SHADOW_COHERENT_RT_SOFT_SHAD_SHARED_H
#define PENUMBRA_SHADOW_COHERENT_RT_SOFT_SHAD_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/scene/light_shared.h"

PN_SHARED_BEGIN

// Cell states.
PN_CONST uint kSsUsePrev = 0u;
PN_CONST uint kSsTodo = 1u;
PN_CONST uint kSsDone = 2u;

// The sampler's scalars, 64 bytes (SoftShad's members besides its arrays).
struct SoftShadState {
  int cols;   // light cells: cols x rows (stratification_grid of the sample count)
  int rows;
  int scols;  // blocker-point sub-cells: cols * sub_grid x rows * sub_grid
  int srows;
  int sub_grid;
  uint coherence;  // 0: every cell traced (plain stratified sampling)
  uint shortcut;   // the sub-grid shortcut of §5.2.2
  float reset_distance;
  vec3 prev;       // the last point shaded
  uint has_prev;
  uint generation;  // the prediction's stamp
  uint blockers;    // blocker points held
  uint queue_head;  // cells traced so far of queue_size
  uint queue_size;
};

// What shading counts (SoftShadCounters, per tile).
struct SoftShadCounts {
  uint points;
  uint rays;
  uint resets;
  uint predicted_wrong;
  uint shortcut_cells;
  uint blocker_points;
};

PN_SHARED_END

// The arrays: per sub-cell a stamp; per cell visible, predicted blocked, state, the cell's
// jittered sample on the unit square, a queue entry; the blocker points (at most one per
// sub-cell, so scols * srows of them).
#ifdef __cplusplus
#include <vector>

#include "penumbra/core/math.h"
namespace penumbra::shader {
struct SoftShadArrays {
  uint32_t* stamp;
  uint8_t* visible;
  uint8_t* predicted;
  uint8_t* state;
  const Vec2f* samples;
  int* queue;
  std::vector<Vec3f>* blockers;
};
using SoftShadRef = const SoftShadArrays&;
inline uint ss_stamp(SoftShadRef r, int i) { return r.stamp[i]; }
inline void ss_set_stamp(SoftShadRef r, int i, uint v) { r.stamp[i] = v; }
inline uint ss_visible(SoftShadRef r, int j) { return r.visible[j]; }
inline void ss_set_visible(SoftShadRef r, int j, uint v) { r.visible[j] = static_cast<uint8_t>(v); }
inline uint ss_predicted(SoftShadRef r, int j) { return r.predicted[j]; }
inline void ss_set_predicted(SoftShadRef r, int j, uint v) { r.predicted[j] = static_cast<uint8_t>(v); }
inline uint ss_state(SoftShadRef r, int j) { return r.state[j]; }
inline void ss_set_state(SoftShadRef r, int j, uint v) { r.state[j] = static_cast<uint8_t>(v); }
inline vec2 ss_sample(SoftShadRef r, int j) { return r.samples[j]; }
inline int ss_queue(SoftShadRef r, uint k) { return r.queue[k]; }
inline void ss_set_queue(SoftShadRef r, uint k, int j) { r.queue[k] = j; }
inline vec3 ss_blocker(SoftShadRef r, uint k) { return (*r.blockers)[k]; }
inline void ss_set_blocker(SoftShadRef r, uint k, vec3 b) {
  if (k >= r.blockers->size()) r.blockers->resize(k + 1);
  (*r.blockers)[k] = b;
}
}  // namespace penumbra::shader
#else
// A tile's slice of the GPU's scratch (kernels/coherent_rt_kernels_shared.h CrtTileScratch).
struct SoftShadRef {
  uint64_t stamp;      // uint per sub-cell
  uint64_t cells;      // uint per cell: bit 0 visible, bit 1 predicted blocked, bits 2-3 state
  uint64_t samples;    // vec2 per cell
  uint64_t queue;      // uint per cell
  uint64_t blockers;   // vec3 per sub-cell
};
uint ss_stamp(SoftShadRef r, int i) { return Uints(r.stamp).v[i]; }
void ss_set_stamp(SoftShadRef r, int i, uint v) { Uints(r.stamp).v[i] = v; }
uint ss_visible(SoftShadRef r, int j) { return Uints(r.cells).v[j] & 1u; }
void ss_set_visible(SoftShadRef r, int j, uint v) { Uints(r.cells).v[j] = (Uints(r.cells).v[j] & ~1u) | (v & 1u); }
uint ss_predicted(SoftShadRef r, int j) { return (Uints(r.cells).v[j] >> 1) & 1u; }
void ss_set_predicted(SoftShadRef r, int j, uint v) {
  Uints(r.cells).v[j] = (Uints(r.cells).v[j] & ~2u) | ((v & 1u) << 1);
}
uint ss_state(SoftShadRef r, int j) { return (Uints(r.cells).v[j] >> 2) & 3u; }
void ss_set_state(SoftShadRef r, int j, uint v) { Uints(r.cells).v[j] = (Uints(r.cells).v[j] & 3u) | (v << 2); }
vec2 ss_sample(SoftShadRef r, int j) { return Vec2s(r.samples).v[j]; }
int ss_queue(SoftShadRef r, uint k) { return int(Uints(r.queue).v[k]); }
void ss_set_queue(SoftShadRef r, uint k, int j) { Uints(r.queue).v[k] = uint(j); }
vec3 ss_blocker(SoftShadRef r, uint k) { return Vec3s(r.blockers).v[k]; }
void ss_set_blocker(SoftShadRef r, uint k, vec3 b) { Vec3s(r.blockers).v[k] = b; }
#endif

PN_SHARED_BEGIN

// A sampler with no point shaded yet (SoftShad's constructor; the arrays are ss_reset's).
PN_INLINE SoftShadState ss_make(int cols, int rows, int sub_grid, bool coherence, bool shortcut, float reset_distance) {
  SoftShadState s;
  s.cols = cols;
  s.rows = rows;
  s.scols = cols * sub_grid;
  s.srows = rows * sub_grid;
  s.sub_grid = sub_grid;
  s.coherence = coherence ? 1u : 0u;
  s.shortcut = shortcut ? 1u : 0u;
  s.reset_distance = reset_distance;
  s.prev = vec3(0.0f, 0.0f, 0.0f);
  s.has_prev = 0u;
  s.generation = 0u;
  s.blockers = 0u;
  s.queue_head = 0u;
  s.queue_size = 0u;
  return s;
}

// The arrays of a fresh sampler: stamps 0, every cell visible and to do.
PN_INLINE void ss_clear(SoftShadRef r, SoftShadState s) {
  for (int i = 0; i < s.scols * s.srows; ++i) ss_set_stamp(r, i, 0u);
  for (int j = 0; j < s.cols * s.rows; ++j) {
    ss_set_visible(r, j, 1u);
    ss_set_predicted(r, j, 0u);
    ss_set_state(r, j, kSsTodo);
  }
}

// Where the line from p through b meets the light's plane, on the unit square the light's cells
// tile; false if it does not (b not between p and the light's plane) or misses the light. A rect's
// square is the rect itself; a disk's is the square concentric_disk maps onto it (light_sample_area),
// so u is its inverse, concentric_square.
PN_INLINE bool ss_project(LightGeometry L, vec3 p, vec3 b, PN_OUT(vec2) u) {
  u = vec2(0.0f, 0.0f);
  float denom = dot(b - p, L.n);
  if (denom == 0.0f) return false;
  float tau = dot(L.center - p, L.n) / denom;
  if (!(tau >= 1.0f)) return false;
  vec3 q = p + (b - p) * tau - L.center;
  if (L.shape == kLightDisk) {
    vec2 d = vec2(dot(q, L.s) / L.radius, dot(q, L.t) / L.radius);
    if (!(d.x * d.x + d.y * d.y < 1.0f)) return false;
    u = concentric_square(d);
  } else {
    u = vec2(dot(q, L.s) / L.size_x + 0.5f, dot(q, L.t) / L.size_y + 0.5f);
  }
  return u.x >= 0.0f && u.x < 1.0f && u.y >= 0.0f && u.y < 1.0f;
}

PN_INLINE int ss_sub_index(SoftShadState s, vec2 u) {
  int sx = min(s.scols - 1, int(u.x * float(s.scols)));
  int sy = min(s.srows - 1, int(u.y * float(s.srows)));
  return sy * s.scols + sx;
}

PN_INLINE void ss_push(SoftShadRef r, PN_INOUT(SoftShadState) s, int j) {
  ss_set_queue(r, s.queue_size, j);
  s.queue_size += 1u;
}

// A blocker point b of a ray from p: kept when its sub-cell has none yet this prediction.
PN_INLINE void ss_add_blocker(SoftShadRef r, PN_INOUT(SoftShadState) s, LightGeometry L, vec3 p, vec3 b) {
  vec2 u;
  if (!ss_project(L, p, b, u)) return;
  int sub = ss_sub_index(s, u);
  if (ss_stamp(r, sub) == s.generation) return;  // the sub-cell has its point
  ss_set_stamp(r, sub, s.generation);
  ss_set_blocker(r, s.blockers, b);
  s.blockers += 1u;
}

// SoftShad's prediction for point p (soft_shad.cpp predict): none for the first point nor across a
// jump (every cell traced); otherwise the blocker points projected from p, one per sub-cell, the
// sub-grid shortcut, and cellsTodo: the light's border and the edges of the predicted image.
PN_INLINE void ss_predict(SoftShadRef r, PN_INOUT(SoftShadState) s, LightGeometry L, vec3 p,
                          PN_INOUT(SoftShadCounts) c) {
  int n = s.cols * s.rows;
  // §5.2.1: no prediction for the first point, nor across a jump between consecutive points.
  // Otherwise an empty list is a prediction too: the light entirely visible, as from p_{i-1} in
  // §5.2.1's missed-blocker argument, where only the border is traced.
  bool reset = s.has_prev == 0u || distance(p, s.prev) > s.reset_distance * distance(p, L.center);
  s.prev = p;
  s.has_prev = 1u;
  s.generation += 1u;
  if (s.generation == 0u) {  // wrapped: clear the stamps
    for (int i = 0; i < s.scols * s.srows; ++i) ss_set_stamp(r, i, 0u);
    s.generation = 1u;
  }
  if (reset) {
    s.blockers = 0u;
    c.resets += 1u;
    for (int j = 0; j < n; ++j) {
      ss_set_visible(r, j, 1u);
      ss_set_state(r, j, kSsTodo);
      ss_push(r, s, j);
    }
    return;
  }
  // Project the blocker points; keep those on the light, one per sub-cell (§5.2.2).
  for (int j = 0; j < n; ++j) ss_set_predicted(r, j, 0u);
  uint kept = 0u;
  for (uint i = 0u; i < s.blockers; ++i) {
    vec3 b = ss_blocker(r, i);
    vec2 u;
    if (!ss_project(L, p, b, u)) continue;
    int sub = ss_sub_index(s, u);
    if (ss_stamp(r, sub) == s.generation) continue;
    ss_set_stamp(r, sub, s.generation);
    ss_set_blocker(r, kept, b);
    kept += 1u;
    int sx = sub % s.scols;
    int sy = sub / s.scols;
    ss_set_predicted(r, (sy / s.sub_grid) * s.cols + sx / s.sub_grid, 1u);
  }
  s.blockers = kept;
  c.blocker_points += kept;
  for (int j = 0; j < n; ++j) {
    ss_set_visible(r, j, ss_predicted(r, j) != 0u ? 0u : 1u);
    ss_set_state(r, j, kSsUsePrev);
  }
  // The sub-grid shortcut: a blocker point in the sub-cell of a cell's sample blocks it.
  if (s.shortcut != 0u) {
    for (int j = 0; j < n; ++j) {
      if (ss_stamp(r, ss_sub_index(s, ss_sample(r, j))) == s.generation) {
        ss_set_state(r, j, kSsDone);
        ss_set_visible(r, j, 0u);
        c.shortcut_cells += 1u;
      }
    }
  }
  // cellsTodo: the light's border and the edges of the predicted image (Figure 8).
  for (int cy = 0; cy < s.rows; ++cy) {
    for (int cx = 0; cx < s.cols; ++cx) {
      int j = cy * s.cols + cx;
      if (ss_state(r, j) == kSsDone) continue;
      bool todo = cx == 0 || cy == 0 || cx == s.cols - 1 || cy == s.rows - 1;
      uint mine = ss_predicted(r, j);
      for (int dy = -1; dy <= 1 && !todo; ++dy)
        for (int dx = -1; dx <= 1 && !todo; ++dx) todo = ss_predicted(r, (cy + dy) * s.cols + cx + dx) != mine;
      if (todo) {
        ss_set_state(r, j, kSsTodo);
        ss_push(r, s, j);
      }
    }
  }
}

// Starts shading point p (SoftShad::shade): the cells to trace queued.
PN_INLINE void ss_begin(SoftShadRef r, PN_INOUT(SoftShadState) s, LightGeometry L, vec3 p,
                        PN_INOUT(SoftShadCounts) c) {
  c.points += 1u;
  s.queue_head = 0u;
  s.queue_size = 0u;
  if (s.coherence == 0u) {
    for (int j = 0; j < s.cols * s.rows; ++j) ss_push(r, s, j);
    return;
  }
  ss_predict(r, s, L, p, c);
}

// The next cell to trace, or -1 when the point is done (visible then holds its light).
PN_INLINE int ss_next(SoftShadRef r, PN_INOUT(SoftShadState) s) {
  if (s.queue_head >= s.queue_size) return -1;
  int j = ss_queue(r, s.queue_head);
  s.queue_head += 1u;
  return j;
}

// Cell j's ray answer (SoftShad lines 5-14): blocked, with the blocker point when known. A traced
// ray that disagrees with the prediction floods its 8 neighbours still trusted.
PN_INLINE void ss_answer(SoftShadRef r, PN_INOUT(SoftShadState) s, LightGeometry L, vec3 p, int j, bool blocked,
                         bool has_point, vec3 point, PN_INOUT(SoftShadCounts) c) {
  c.rays += 1u;
  uint vis = blocked ? 0u : 1u;
  if (s.coherence == 0u) {
    ss_set_visible(r, j, vis);
    return;
  }
  if (blocked && has_point) ss_add_blocker(r, s, L, p, point);
  if (vis != ss_visible(r, j)) {
    c.predicted_wrong += 1u;
    ss_set_visible(r, j, vis);
    int cx = j % s.cols;
    int cy = j / s.cols;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        int x = cx + dx;
        int y = cy + dy;
        if (x < 0 || y < 0 || x >= s.cols || y >= s.rows) continue;
        int k = y * s.cols + x;
        if (ss_state(r, k) == kSsUsePrev) {
          ss_set_state(r, k, kSsTodo);
          ss_push(r, s, k);
        }
      }
  }
  ss_set_state(r, j, kSsDone);
}

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::SoftShadState) == 64);
#endif

#endif  // PENUMBRA_SHADOW_COHERENT_RT_SOFT_SHAD_SHARED_H
