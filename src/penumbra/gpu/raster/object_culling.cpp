#include "penumbra/gpu/raster/object_culling.h"

#include <algorithm>

#include "penumbra/gpu/raster/raster_layout_shared.h"
#include "penumbra/raster/caster_culling.h"

namespace penumbra::gpu {

void ObjectCulling::prepare(Device& device, const Scene& scene) {
  bounds_.clear();
  triangles_.clear();
  for (const SceneObject& o : scene.objects) {
    bounds_.push_back(o.mesh.bounds());
    triangles_.push_back(o.mesh.triangle_count());
  }
  flags_.assign(bounds_.size(), 0u);
  ensure_buffer(device, buffer_, flags_.size() * sizeof(uint32_t), "the casters' culling flags");
}

uint64_t ObjectCulling::flags_for(const LightView& view, uint64_t* culled) {
  uint64_t left_out = 0;
  for (size_t i = 0; i < bounds_.size(); ++i) {
    flags_[i] = box_outside_view(bounds_[i], view) ? shader::kRasterObjectSkip : 0u;
    if (flags_[i] != 0u) left_out += triangles_[i];
  }
  if (culled) *culled = left_out;
  if (left_out == 0) return 0;
  buffer_.upload(std::span<const uint32_t>(flags_));
  return buffer_.address();
}

bool ObjectCulling::flags_for_views(std::span<const LightView> views, RasterViewCulling* out, uint64_t* culled) const {
  const size_t objects = bounds_.size();
  out->objects = static_cast<uint32_t>(objects);
  out->flags.assign(views.size() * objects, 0u);
  uint64_t left_out = 0;
  for (size_t v = 0; v < views.size(); ++v)
    for (size_t i = 0; i < objects; ++i)
      if (box_outside_view(bounds_[i], views[v])) {
        out->flags[v * objects + i] = shader::kRasterObjectSkip;
        left_out += triangles_[i];
      }
  if (culled) *culled = left_out;
  if (left_out == 0) out->flags.clear();
  return left_out > 0;
}

}  // namespace penumbra::gpu
