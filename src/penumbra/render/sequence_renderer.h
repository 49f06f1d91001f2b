// The frames of an animated scene (docs/scene-format.md, "Animation") rendered one after
// another, keeping what stays valid between frames (issue 18, part 3): while no object moves,
// one Renderer serves every frame (its Embree scene, and the light-space structures of every
// light that did not change: Renderer::set_camera, set_lights); a frame where an object moved
// gets a new Renderer. `penumbra render --frame-range` and `penumbra bench --suite walk` use it.
#pragma once

#include <memory>

#include "penumbra/render/renderer.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

class SequenceRenderer {
 public:
  // `scene` has an animation (throws otherwise); its camera's resolution and samples per pixel
  // (as overridden by the caller) are kept for every frame.
  SequenceRenderer(Scene scene, RenderSettings settings);
  ~SequenceRenderer();

  struct Frame {
    RenderResult result;
    bool new_renderer = false;  // this frame built a Renderer (the first, or objects moved)
  };
  // Frame `frame` of the animation; frames may come in any order (each equals a render of
  // scene_at_frame(scene, frame) alone, bit for bit).
  Frame render(int frame);
  // The scene as the last frame rendered it.
  const Scene& scene() const { return current_; }
  int renderers_built() const { return renderers_; }

 private:
  Scene current_;
  RenderSettings settings_;
  std::unique_ptr<Renderer> renderer_;
  int last_frame_ = -1;
  int renderers_ = 0;
};

}  // namespace penumbra
