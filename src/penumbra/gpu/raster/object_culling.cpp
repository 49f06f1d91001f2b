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

uint64_t ObjectCulling::flags_into(const LightView& view, uint32_t* flags) const {
  uint64_t left_out = 0;
  for (size_t i = 0; i < bounds_.size(); ++i) {
    flags[i] = box_outside_view(bounds_[i], view) ? shader::kRasterObjectSkip : 0u;
    if (flags[i] != 0u) left_out += triangles_[i];
  }
  return left_out;
}

uint64_t ObjectCulling::flags_for(const LightView& view, uint64_t* culled) {
  const uint64_t left_out = flags_into(view, flags_.data());
  if (culled) *culled = left_out;
  if (left_out == 0) return 0;
  buffer_.upload(std::span<const uint32_t>(flags_));
  return buffer_.address();
}

bool ObjectCulling::flags_for_views(std::span<const LightView> views, RasterViewCulling* out, uint64_t* culled) const {
  const size_t objects = bounds_.size();
  out->objects = static_cast<uint32_t>(objects);
  out->flags.resize(views.size() * objects);
  uint64_t left_out = 0;
  for (size_t v = 0; v < views.size(); ++v) left_out += flags_into(views[v], out->flags.data() + v * objects);
  if (culled) *culled = left_out;
  if (left_out == 0) out->flags.clear();
  return left_out > 0;
}

}  // namespace penumbra::gpu
