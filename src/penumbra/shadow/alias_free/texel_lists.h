// The alias-free shadow map's lists (sintorn2008 §3.1): each view sample is projected into
// the light's image and listed at the texel it falls in. Built as on the GPU, without
// dynamic allocation: a count per texel, an exclusive prefix sum (each texel's first slot),
// then a scatter of the samples into flat arrays. A slot's position and the view sample it
// came from are stored apart from the per-slot shadow state (a bit or a mask, owned by the
// method), as the paper keeps positions and shadow bits in separate arrays.
#pragma once

#include <bit>
#include <cstdint>
#include <span>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/raster/light_view.h"

namespace penumbra::afsm {

struct TexelLists {
  int width = 0, height = 0;
  std::vector<uint32_t> first;      // width * height + 1: texel i's slots are [first[i], first[i+1])
  std::vector<Vec3f> positions;     // per slot
  std::vector<uint32_t> sample;     // per slot: the index given with the point
  size_t uncovered = 0;             // points outside the view (not listed)

  size_t slots() const { return positions.size(); }
  size_t texel(int x, int y) const { return static_cast<size_t>(y) * width + x; }
  uint32_t begin(int x, int y) const { return first[texel(x, y)]; }
  uint32_t end(int x, int y) const { return first[texel(x, y) + 1]; }
  size_t memory_bytes() const;

  // Fig. 9's inlay: texels with a non-empty list, their average and the longest list.
  struct Occupancy {
    size_t occupied = 0;
    double average = 0;
    size_t longest = 0;
  };
  Occupancy occupancy() const;
  // Number of slots in the texel rectangle [x0, x1) x [y0, y1) (clamped to the image), in
  // constant time from a summed-area table (built on first use by build_summed_area()).
  void build_summed_area();
  uint64_t count_in(int x0, int y0, int x1, int y1) const;

 private:
  std::vector<uint32_t> summed_;  // (width + 1) x (height + 1)
};

// The lists cut into slabs of depth from the light (CPU adaptation of sintorn2008 §4.3
// "Parametrization", which fits one far plane to the farthest view sample to keep the
// influence regions small): a caster's influence region on slab k's own far plane holds
// every sample of slab k it can shadow, and is smaller than the region on the farthest
// plane; casters wholly behind a slab's samples cannot shadow them at all. Each texel's
// slots are ordered by slab (input order inside a slab); slab k of texel t is
// [begin(k, t), end(k, t)).
struct DepthSlabs {
  int count = 0;
  int width = 0, height = 0;
  size_t texels = 0;
  std::vector<float> far;         // per slab: its farthest sample's depth, padded
  std::vector<uint32_t> bounds;   // (count + 1) x texels, slab-major
  uint32_t begin(int k, size_t texel) const { return bounds[k * texels + texel]; }
  uint32_t end(int k, size_t texel) const { return bounds[(k + 1) * texels + texel]; }
  // Bit x of occupied(k, y)[x / 64]: texel (x, y) lists a sample of slab k. A rasterized span
  // visits only those (§4.3: texels with empty lists do no work).
  int row_words = 0;
  std::vector<uint64_t> occupancy;  // count x height x row_words
  const uint64_t* occupied(int k, int y) const {
    return occupancy.data() + (static_cast<size_t>(k) * height + y) * row_words;
  }
  // Slots of slab k in the texel rectangle [x0, x1) x [y0, y1) (clamped), from summed-area
  // tables (build_summed_areas()).
  void build_summed_areas();
  uint64_t count_in(int k, int x0, int y0, int x1, int y1) const;

 private:
  std::vector<uint32_t> summed_;  // count x (width + 1) x (height + 1)
};

// Splits `lists` into up to `slabs` slabs holding about equal numbers of slots (`depth`: each
// slot's linear depth from the light), reordering each texel's slots by slab.
DepthSlabs split_by_depth(TexelLists* lists, std::span<const float> depth, int slabs);

// Calls fn(x) for every set bit x in [x0, x1) of a row bitset.
template <class Fn>
inline void for_each_set(const uint64_t* row, int x0, int x1, Fn&& fn) {
  for (int w = x0 >> 6, w_end = (x1 + 63) >> 6; w < w_end; ++w) {
    uint64_t bits = row[w];
    if (w == x0 >> 6) bits &= ~0ull << (x0 & 63);
    if (w == (x1 - 1) >> 6 && (x1 & 63)) bits &= ~0ull >> (64 - (x1 & 63));
    for (; bits; bits &= bits - 1) fn(w * 64 + std::countr_zero(bits));
  }
}

// Lists `points` (ids[i] names points[i]) at the texels of `view` they project into; points
// behind the near plane or outside the image are counted in `uncovered`.
TexelLists build_texel_lists(const LightView& view, std::span<const Vec3f> points, std::span<const uint32_t> ids);

}  // namespace penumbra::afsm
