#include "penumbra/render/sequence_renderer.h"

#include "penumbra/core/error.h"
#include "penumbra/scene/animation.h"

namespace penumbra {

SequenceRenderer::SequenceRenderer(Scene scene, RenderSettings settings)
    : current_(std::move(scene)), settings_(std::move(settings)) {
  if (!current_.animation) throw Error("{}: the scene has no \"animation\" block", current_.source.string());
}

SequenceRenderer::~SequenceRenderer() = default;

SequenceRenderer::Frame SequenceRenderer::render(int frame) {
  const Animation& animation = *current_.animation;
  if (frame < 0 || frame >= animation.frames)
    throw Error("{}: frame {} is outside the animation's frames 0..{}", current_.source.string(), frame,
                animation.frames - 1);
  // Moved objects need a new renderer (its Embree scene and the methods' maps hold the old
  // geometry); a camera or light change alone keeps it, and with it whatever each method keeps.
  Frame out;
  out.new_renderer = !renderer_ || animation.objects_differ(last_frame_, frame);
  if (out.new_renderer) animation.place_objects(frame, current_);
  animation.set_camera_and_lights(frame, current_);
  if (out.new_renderer) {
    renderer_.reset();  // its memory first
    renderer_ = std::make_unique<Renderer>(current_, settings_);
    ++renderers_;
  } else {
    renderer_->set_camera(current_.camera);
    renderer_->set_lights(current_.lights);
  }
  last_frame_ = frame;
  out.result = renderer_->render();
  return out;
}

}  // namespace penumbra
