#include "penumbra/render/sequence_renderer.h"

#include "penumbra/core/error.h"
#include "penumbra/core/timer.h"
#include "penumbra/scene/animation.h"

namespace penumbra {

SequenceRenderer::SequenceRenderer(Scene scene, RenderSettings settings)
    : current_(std::move(scene)), settings_(std::move(settings)) {
  if (!current_.animation) throw Error("{}: the scene has no \"animation\" block", current_.source.string());
  // The objects the tracks move get refittable BVHs in a two-level Embree scene.
  settings_.movable_objects = current_.animation->movable_objects();
}

SequenceRenderer::~SequenceRenderer() = default;

SequenceRenderer::Frame SequenceRenderer::render(int frame) {
  const Animation& animation = *current_.animation;
  if (frame < 0 || frame >= animation.frames)
    throw Error("{}: frame {} is outside the animation's frames 0..{}", current_.source.string(), frame,
                animation.frames - 1);
  Frame out;
  if (!renderer_) {
    animation.place_objects(frame, current_);
    animation.set_camera_and_lights(frame, current_);
    renderer_ = std::make_unique<Renderer>(current_, settings_);
    out.new_renderer = true;
  } else {
    // Moved objects: the Embree scene is refit and each method keeps what stays valid
    // (Renderer::set_objects); a camera or light change keeps the geometry, and with it
    // whatever each method keeps for the lights that did not change.
    const std::vector<uint32_t> moved = animation.moved_objects(last_frame_, frame);
    if (!moved.empty()) animation.place_objects(frame, current_);
    animation.set_camera_and_lights(frame, current_);
    if (!moved.empty()) {
      Timer timer;
      const int refits = renderer_->refits();
      renderer_->set_objects(current_.objects, moved);
      out.moved_objects = static_cast<int>(moved.size());
      out.refit = renderer_->refits() > refits;
      out.geometry_update_ms = timer.elapsed_ms();
    }
    renderer_->set_camera(current_.camera);
    renderer_->set_lights(current_.lights);
  }
  last_frame_ = frame;
  out.result = renderer_->render();
  return out;
}

}  // namespace penumbra
