// The alias-free shadow map's lists (sintorn2008 §3.1): each view sample is projected into
// the light's image and listed at the texel it falls in. Built as on the GPU, without
// dynamic allocation: a count per texel, an exclusive prefix sum (each texel's first slot),
// then a scatter of the samples into flat arrays. A slot's position and the view sample it
// came from are stored apart from the per-slot shadow state (a bit or a mask, owned by the
// method), as the paper keeps positions and shadow bits in separate arrays.
#pragma once

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
  // For memory estimates: the lists of `slots` points over `texels` texels, and what
  // build_texel_lists holds besides while building them (each point's texel, a cursor per
  // texel).
  static uint64_t bytes(uint64_t texels, uint64_t slots) {
    return (texels + 1) * sizeof(uint32_t) + slots * (sizeof(Vec3f) + sizeof(uint32_t)) +
           (slots + texels) * sizeof(uint32_t);
  }
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
// plane; casters wholly behind a slab's samples cannot shadow them at all. The slots are
// copied in slab-major, then texel (row-major), then list order, so that the samples of
// slab k in a row span of texels [x0, x1) are one range of slots:
// [begin(k, texel(x0, y)), end(k, texel(x1 - 1, y))).
struct DepthSlabs {
  int count = 0;
  int width = 0, height = 0;
  size_t texels = 0;
  std::vector<float> far;            // per slab: its farthest sample's depth, padded
  std::vector<uint32_t> bounds;      // count x texels + 1: slab k, texel t starts at bounds[k * texels + t]
  std::vector<Vec3f> positions;      // per slot (slab order)
  std::vector<uint32_t> sample;      // per slot: the list's id (TexelLists::sample)
  std::vector<uint32_t> list_slot;   // per slot: its slot in the TexelLists
  size_t slots() const { return positions.size(); }
  uint32_t begin(int k, size_t texel) const { return bounds[k * texels + texel]; }
  uint32_t end(int k, size_t texel) const { return bounds[k * texels + texel + 1]; }
  // Slots of slab k in the texel rectangle [x0, x1) x [y0, y1) (clamped), from summed-area
  // tables (build_summed_areas()).
  void build_summed_areas();
  uint64_t count_in(int k, int x0, int y0, int x1, int y1) const;
  size_t memory_bytes() const;
  // For memory estimates: up to `slabs` slabs of `slots` slots over a width x height image
  // (with the summed-area tables when `summed`), and what split_by_depth holds besides while
  // splitting (the sorted depths, each slot's slab).
  static uint64_t bytes(int slabs, int width, int height, uint64_t slots, bool summed);

 private:
  std::vector<uint32_t> summed_;  // count x (width + 1) x (height + 1)
};

// Splits the lists into up to `slabs` slabs holding about equal numbers of slots (`depth`:
// each list slot's linear depth from the light).
DepthSlabs split_by_depth(const TexelLists& lists, std::span<const float> depth, int slabs);

// Lists `points` (ids[i] names points[i]) at the texels of `view` they project into; points
// behind the near plane or outside the image are counted in `uncovered`.
TexelLists build_texel_lists(const LightView& view, std::span<const Vec3f> points, std::span<const uint32_t> ids);

}  // namespace penumbra::afsm
