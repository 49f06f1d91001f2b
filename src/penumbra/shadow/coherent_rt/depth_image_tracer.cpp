#include "penumbra/shadow/coherent_rt/depth_image_tracer.h"

#include <algorithm>
#include <cmath>

namespace penumbra::coherent_rt {

void TraceCounters::add(const TraceCounters& o) {
  rays += o.rays;
  blocked += o.blocked;
  maps_walked += o.maps_walked;
  clear_misses += o.clear_misses;
  intervals_exhausted += o.intervals_exhausted;
  connected_hits += o.connected_hits;
  hidden_everywhere += o.hidden_everywhere;
  walk.add(o.walk);
}

shader::CrtTraceOptions TraceOptions::shared() const {
  return {minmax_clipping, connectedness, clear_miss, occlusion_intervals, ranking, hidden_blocks};
}

DepthImageTracer::DepthImageTracer(std::span<const ReferenceImage> images, const TraceOptions& options)
    : images_(images), options_(options) {
  levels_.reserve(images.size());
  for (const ReferenceImage& img : images) levels_.emplace_back(img.pyramid);
}

TraceResult DepthImageTracer::trace(Vec3f p, Vec3f q, bool need_point, TraceScratch& scratch,
                                    TraceCounters* counters) const {
  const shader::CrtImages images{images_.data(), levels_.data(), static_cast<int>(images_.size())};
  const shader::CrtSpanLists lists{{&scratch.intervals, &scratch.next, &scratch.walked}};
  shader::CrtTraceCounts c{};
  TraceResult result;
  shader::crt_trace(images, options_.shared(), p, q, need_point, lists, c, result.blocked, result.has_point,
                    result.point);
  if (counters) {
    counters->rays += c.rays;
    counters->blocked += c.blocked;
    counters->maps_walked += c.maps_walked;
    counters->clear_misses += c.clear_misses;
    counters->intervals_exhausted += c.intervals_exhausted;
    counters->connected_hits += c.connected_hits;
    counters->hidden_everywhere += c.hidden_everywhere;
    counters->walk.nodes += c.nodes;
    counters->walk.texels += c.texels;
  }
  return result;
}

}  // namespace penumbra::coherent_rt
