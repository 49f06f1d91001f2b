// The frames of an animated scene (docs/scene-format.md, "Animation") rendered one after
// another by one Renderer, keeping what stays valid between frames (issue 18, part 3): the
// Embree scene (refit where objects moved: RayTracer's two-level build with the animated
// objects refittable), and the light-space structures of every light that did not change
// while only the camera moves (Renderer::set_camera, set_lights) or, where objects moved, of
// the methods that keep them (ShadowMethod::keeps_prepared_after_moving). Every frame equals
// a fresh render of scene_at_frame(scene, frame), bit for bit while no object moves; after a
// move up to the order Embree reports equally near hits in. `penumbra render --frame-range`,
// `compare --frame-range` and `penumbra bench --suite walk` use it.
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
    bool new_renderer = false;  // this frame built the Renderer (the first frame rendered)
    int moved_objects = 0;      // objects placed differently than in the frame before
    bool refit = false;         // they were refit in the Embree scene (not rebuilt)
    double geometry_update_ms = 0;  // moving them: the Embree refit and the methods told
  };
  // Frame `frame` of the animation; frames may come in any order.
  Frame render(int frame);
  // The scene as the last frame rendered it.
  const Scene& scene() const { return current_; }

 private:
  Scene current_;
  RenderSettings settings_;
  std::unique_ptr<Renderer> renderer_;
  int last_frame_ = -1;
};

}  // namespace penumbra
