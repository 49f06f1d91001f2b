// The cheap part of afsm's (listed sample, caster) test (sintorn2008 §4.2), over the samples
// of a rasterized span at once: one caster against many samples, in SIMD lanes (Highway,
// dispatched at run time to the best of SSE4 / AVX2 / AVX-512). It decides what most pairs
// end with — the sample behind a closed caster, or seeing it edge-on, or one of the three
// planes through the sample and an edge leaving every light sample outside — and hands the
// rest on with the three edge planes as lines on the light. Every value is computed with
// the same float operations in the same order as the scalar test (no fused multiply-adds),
// so the survivors, their lines, and hence the images are the scalar code's, bit for bit.
#pragma once

#include <cstddef>
#include <cstdint>

#include "penumbra/shadow/alias_free/sample_masks.h"

namespace penumbra::afsm {

// The light as the lines need it: centre, the frame vectors scaled by the extent radius,
// and the squared radius of the samples' disk (PlaneMaskLut::side_of_disk).
struct PairLight {
  float c[3], ls[3], lt[3];
  float max_distance2;
  SampleGrid::Geometry grid;  // the samples' grid (SampleGrid::triangle_cells in SIMD)
  int max_grid_cells;         // above: the caller builds the masks plane by plane
  const SampleGrid* samples;  // its cells, for the small ranges tested here
};

// One caster, set up once (triangle setup once per caster and span).
struct PairCaster {
  float v[3][3];     // vertices
  float d[3][3];     // edges v[(i + 1) % 3] - v[i]
  float normal[3];   // cross(v1 - v0, v2 - v0)
  float flat_scale;  // kFlat^2 |normal|^2 (the edge-on threshold before |p - v0|^2)
  bool closed;
};

// The samples of the lists in structure-of-arrays form, padded to a whole vector at the end.
struct PairSamples {
  const float *x, *y, *z;
  const uint32_t* settled;  // non-zero: skip
  const float *rot_c, *rot_s;  // per-sample rotation (cos, sin) of the lines, or null
};

struct PairSurvivor {
  uint32_t slot;
  float side;     // dot(normal, p - v0): which way the caster faces the sample
  Line edges[3];  // the planes through p and each edge, as lines on the light
  // on_grid: the three lines bound a small triangle (as SampleGrid::triangle_cells decides,
  // computed in float with a bound on its rounding) and every sample on their positive sides
  // lies in cells [x0, x1] x [y0, y1] of the grid; otherwise the caller decides.
  bool on_grid;
  int32_t x0, y0, x1, y1;
};

// Survivors of slots [begin, end) written to out (room for end - begin); returns how many.
// Pairs whose three lines bound a triangle with no sample inside are not survivors: beside
// every sample, or (a range of at most 2 rows of 4 samples) none of its cells' samples
// inside all three lines.
// tested: the number of slots not settled.
size_t filter_pairs(const PairLight& light, const PairCaster& caster, const PairSamples& samples, uint32_t begin,
                    uint32_t end, PairSurvivor* out, size_t* tested);

// The grid positions k (SampleGrid's order) in cells r whose samples are on the positive side
// of all three lines by `above` (the same float operations), written to out (room for every
// sample of the grid); returns how many. The grid's arrays are padded (SampleGrid).
size_t inside_cells(const SampleGrid& grid, const SampleGrid::Range& r, const Line edges[3], uint32_t* out);

// Lanes of the widest vector the dispatched target has (padding of PairSamples' arrays).
inline constexpr size_t kPairPadding = 64;

}  // namespace penumbra::afsm
