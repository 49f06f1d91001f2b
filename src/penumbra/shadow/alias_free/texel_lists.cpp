#include "penumbra/shadow/alias_free/texel_lists.h"

#include <algorithm>
#include <cmath>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"

namespace penumbra::afsm {

TexelLists build_texel_lists(const LightView& view, std::span<const Vec3f> points, std::span<const uint32_t> ids) {
  if (points.size() != ids.size()) throw Error("build_texel_lists: {} points, {} ids", points.size(), ids.size());
  TexelLists lists;
  lists.width = view.width();
  lists.height = view.height();
  const size_t texels = static_cast<size_t>(lists.width) * lists.height;
  // Pass 1: each point's texel (or none), in parallel.
  constexpr uint32_t kNone = ~0u;
  std::vector<uint32_t> texel_of(points.size());
  parallel_for(points.size(), 4096, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const Vec3f t = view.to_texel(points[i]);
      const bool in = t.z >= view.near() && t.x >= 0 && t.y >= 0 && t.x < lists.width && t.y < lists.height;
      texel_of[i] = in ? static_cast<uint32_t>(lists.texel(static_cast<int>(t.x), static_cast<int>(t.y))) : kNone;
    }
  });
  // Pass 2: counts, exclusive prefix sum.
  lists.first.assign(texels + 1, 0);
  for (uint32_t t : texel_of)
    if (t != kNone) lists.first[t + 1]++;
    else lists.uncovered++;
  for (size_t i = 0; i < texels; ++i) lists.first[i + 1] += lists.first[i];
  // Pass 3: scatter, in input order within a texel (deterministic).
  const size_t slots = lists.first[texels];
  lists.positions.resize(slots);
  lists.sample.resize(slots);
  std::vector<uint32_t> cursor(lists.first.begin(), lists.first.end() - 1);
  for (size_t i = 0; i < points.size(); ++i) {
    if (texel_of[i] == kNone) continue;
    const uint32_t slot = cursor[texel_of[i]]++;
    lists.positions[slot] = points[i];
    lists.sample[slot] = ids[i];
  }
  return lists;
}

size_t TexelLists::memory_bytes() const {
  return first.size() * sizeof(uint32_t) + positions.size() * sizeof(Vec3f) + sample.size() * sizeof(uint32_t) +
         summed_.size() * sizeof(uint32_t);
}

TexelLists::Occupancy TexelLists::occupancy() const {
  Occupancy o;
  const size_t texels = first.empty() ? 0 : first.size() - 1;
  for (size_t i = 0; i < texels; ++i) {
    const size_t len = first[i + 1] - first[i];
    if (len == 0) continue;
    o.occupied++;
    o.longest = std::max(o.longest, len);
  }
  o.average = o.occupied ? static_cast<double>(slots()) / o.occupied : 0.0;
  return o;
}

void TexelLists::build_summed_area() {
  const size_t w1 = static_cast<size_t>(width) + 1;
  summed_.assign(w1 * (height + 1), 0);
  for (int y = 0; y < height; ++y) {
    uint32_t row = 0;
    for (int x = 0; x < width; ++x) {
      row += end(x, y) - begin(x, y);
      summed_[(y + 1) * w1 + x + 1] = summed_[y * w1 + x + 1] + row;
    }
  }
}

uint64_t TexelLists::count_in(int x0, int y0, int x1, int y1) const {
  x0 = std::clamp(x0, 0, width);
  x1 = std::clamp(x1, 0, width);
  y0 = std::clamp(y0, 0, height);
  y1 = std::clamp(y1, 0, height);
  if (x0 >= x1 || y0 >= y1) return 0;
  const size_t w1 = static_cast<size_t>(width) + 1;
  return static_cast<uint64_t>(summed_[y1 * w1 + x1]) - summed_[y0 * w1 + x1] - summed_[y1 * w1 + x0] +
         summed_[y0 * w1 + x0];
}

DepthSlabs split_by_depth(const TexelLists& lists, std::span<const float> depth, int slabs) {
  const size_t slots = lists.slots();
  if (depth.size() != slots) throw Error("split_by_depth: {} depths for {} slots", depth.size(), slots);
  DepthSlabs out;
  out.width = lists.width, out.height = lists.height;
  out.texels = lists.first.empty() ? 0 : lists.first.size() - 1;
  // Slab boundaries at depth quantiles (equal slot counts); equal depths stay in one slab.
  std::vector<float> sorted(depth.begin(), depth.end());
  std::sort(sorted.begin(), sorted.end());
  std::vector<float> upper;  // slab k holds depths <= upper[k] (and > upper[k - 1])
  slabs = std::clamp(slabs, 1, 255);
  for (int k = 1; k <= slabs && !sorted.empty(); ++k) {
    const float u = sorted[std::min(slots - 1, (slots * k + slabs - 1) / slabs - 1)];
    if (upper.empty() || u > upper.back()) upper.push_back(u);
  }
  if (upper.empty()) upper.push_back(0);
  upper.back() = kInfinity;
  out.count = static_cast<int>(upper.size());
  std::vector<uint8_t> slab(slots);
  out.far.assign(out.count, 0.0f);
  for (size_t i = 0; i < slots; ++i) {
    slab[i] = static_cast<uint8_t>(std::lower_bound(upper.begin(), upper.end(), depth[i]) - upper.begin());
    out.far[slab[i]] = std::max(out.far[slab[i]], depth[i]);
  }
  for (float& f : out.far) f = f * (1 + 1e-4f) + 1e-6f;
  // Count per (slab, texel), exclusive prefix sum in slab-major order, then scatter in list
  // order (each texel's list is walked in order, so a (slab, texel) keeps its list order).
  out.bounds.assign(out.count * out.texels + 1, 0);
  for (size_t t = 0; t < out.texels; ++t)
    for (uint32_t i = lists.first[t]; i < lists.first[t + 1]; ++i) out.bounds[slab[i] * out.texels + t + 1]++;
  for (size_t i = 1; i < out.bounds.size(); ++i) out.bounds[i] += out.bounds[i - 1];
  out.positions.resize(slots);
  out.sample.resize(slots);
  out.list_slot.resize(slots);
  for (size_t t = 0; t < out.texels; ++t) {
    uint32_t cursor[256];  // per slab met in this texel
    for (uint32_t i = lists.first[t]; i < lists.first[t + 1]; ++i) cursor[slab[i]] = out.bounds[slab[i] * out.texels + t];
    for (uint32_t i = lists.first[t]; i < lists.first[t + 1]; ++i) {
      const uint32_t to = cursor[slab[i]]++;
      out.positions[to] = lists.positions[i];
      out.sample[to] = lists.sample[i];
      out.list_slot[to] = i;
    }
  }
  return out;
}

size_t DepthSlabs::memory_bytes() const {
  return bounds.size() * sizeof(uint32_t) + positions.size() * sizeof(Vec3f) +
         (sample.size() + list_slot.size() + summed_.size()) * sizeof(uint32_t);
}

uint64_t DepthSlabs::bytes(int slabs, int width, int height, uint64_t slots, bool summed) {
  const uint64_t k = static_cast<uint64_t>(slabs), w = static_cast<uint64_t>(width), h = static_cast<uint64_t>(height);
  const uint64_t tables = (k * w * h + 1) * sizeof(uint32_t) + (summed ? k * (w + 1) * (h + 1) * sizeof(uint32_t) : 0);
  const uint64_t per_slot = sizeof(Vec3f) + 2 * sizeof(uint32_t) + sizeof(float) + sizeof(uint8_t);
  return tables + slots * per_slot;
}

void DepthSlabs::build_summed_areas() {
  const size_t w1 = static_cast<size_t>(width) + 1, plane = w1 * (height + 1);
  summed_.assign(count * plane, 0);
  for (int k = 0; k < count; ++k) {
    uint32_t* s = summed_.data() + k * plane;
    for (int y = 0; y < height; ++y) {
      uint32_t row = 0;
      for (int x = 0; x < width; ++x) {
        const size_t t = static_cast<size_t>(y) * width + x;
        row += end(k, t) - begin(k, t);
        s[(y + 1) * w1 + x + 1] = s[y * w1 + x + 1] + row;
      }
    }
  }
}

uint64_t DepthSlabs::count_in(int k, int x0, int y0, int x1, int y1) const {
  x0 = std::clamp(x0, 0, width);
  x1 = std::clamp(x1, 0, width);
  y0 = std::clamp(y0, 0, height);
  y1 = std::clamp(y1, 0, height);
  if (x0 >= x1 || y0 >= y1) return 0;
  const size_t w1 = static_cast<size_t>(width) + 1;
  const uint32_t* s = summed_.data() + k * w1 * (height + 1);
  return static_cast<uint64_t>(s[y1 * w1 + x1]) - s[y0 * w1 + x1] - s[y1 * w1 + x0] + s[y0 * w1 + x0];
}

}  // namespace penumbra::afsm
