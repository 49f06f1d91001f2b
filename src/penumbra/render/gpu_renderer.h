// The frame on the GPU (docs/gpu.md, "The frame"): Renderer's pipeline with every per-pixel step
// on the device. The scene is uploaded once (gpu/gpu_scene.h); each render records the camera
// pass, each light's method (prepare when needed, evaluate), the compose with the closed-form
// unshadowed irradiance and the resolve into pixels, submits them once, and reads back only the
// finished image and V. Renderer uses it when RenderSettings::device is a GPU.
#pragma once

#include <memory>
#include <span>
#include <vector>

#include "penumbra/gpu/buffer.h"
#include "penumbra/gpu/commands.h"
#include "penumbra/gpu/gpu_light.h"
#include "penumbra/gpu/gpu_scene.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/gpu_method.h"

namespace penumbra {

class GpuRenderer {
 public:
  // `scene` has its textured lights expanded already (Renderer's constructor does it).
  GpuRenderer(const Scene& scene, const RenderSettings& settings, gpu::Device& device);
  ~GpuRenderer();

  // New lights over the same geometry: the methods of lights that changed start afresh.
  void set_lights(const Scene& scene, const std::vector<bool>& changed, const RenderSettings& settings);
  // Objects moved (Renderer::set_objects): the GPU scene is refit (movable objects) or uploaded
  // again, and each light's method keeps its structures or starts afresh.
  void set_objects(const Scene& scene, std::span<const uint32_t> moved, const RenderSettings& settings);
  bool prepared() const;
  void prepare(const Scene& scene, const RenderSettings& settings);
  RenderResult render(const Scene& scene, const RenderSettings& settings);
  int refits() const { return gpu_scene_->refits(); }
  // The last render's view samples read back, the hits only, in slot order (as the CPU's camera
  // pass lists them): for tests that hold the GPU's camera pass against the CPU's.
  ViewSamples download_view_samples() const;
  const gpu::GpuScene& gpu_scene() const { return *gpu_scene_; }
  gpu::Device& device() { return *device_; }

 private:
  // The per-slot buffers of a window of `slots` camera rays and `pixels` pixels (kept while the
  // size stays).
  void size_frame(uint64_t slots, uint64_t pixels);
  ShadowContext light_context(const Scene& scene, size_t l, const RenderSettings& settings) const;
  GpuFrame frame_for(size_t l);

  gpu::Device* device_;
  std::unique_ptr<gpu::GpuScene> gpu_scene_;
  std::vector<std::unique_ptr<gpu::GpuLightBuffer>> lights_;
  std::vector<std::unique_ptr<GpuShadowMethod>> methods_;
  std::vector<bool> prepared_;
  std::vector<bool> split_;  // light l is a face of a split sphere (AreaLight::split_face)
  std::unique_ptr<gpu::CommandList> commands_;
  gpu::StageTimes times_;  // of the render in progress (flushes included)
  uint64_t slots_ = 0, pixels_ = 0;
  uint32_t frame_slots_ = 0;  // the current window's
  int frame_width_ = 0, frame_height_ = 0, frame_spp_ = 1;
  PixelWindow frame_window_;
  gpu::Buffer samples_, visibility_, irradiance_, visibility_sum_, irradiance_sum_, radiance_, v_weighted_, v_weight_,
      v_plain_, color_out_, visibility_out_;
  gpu::Buffer face_samples_;  // a split sphere's face's view samples (face_samples.comp), when one is drawn
};

// What a render on the GPU holds in device memory beyond the scene (the frame's per-slot
// buffers) for a window of `slots` camera rays and `pixels` pixels.
// With `split_sphere`, also the copy of the view samples a split sphere's face draws.
uint64_t gpu_frame_bytes(uint64_t slots, uint64_t pixels, bool split_sphere = false);

}  // namespace penumbra
