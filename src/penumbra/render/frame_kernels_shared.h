// The parameters (push constants) of the frame's own kernels on the GPU (render/kernels/): the
// camera pass, the compose and the resolve (render/gpu_renderer.cpp records them). Buffers are
// device addresses. Common subset of C++ and GLSL; each struct fits the 128 bytes every device
// allows.
#ifndef PENUMBRA_RENDER_FRAME_KERNELS_SHARED_H
#define PENUMBRA_RENDER_FRAME_KERNELS_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// camera_pass.comp: one thread per camera ray of the window, writing its GpuViewSample slot.
struct CameraPassParams {
  uint64_t scene;    // SceneDesc
  uint64_t samples;  // GpuViewSample[window_width * window_height * spp]
  vec3 eye;
  float tan_half;
  vec3 s;  // the camera's frame: right
  float aspect;
  vec3 t;  // up
  float width;  // the whole image's, in pixels
  vec3 n;  // backward
  float height;
  int x0;  // the window
  int y0;
  int window_width;
  int window_height;
  int image_width;
  int spp;  // camera rays per pixel; above 1 jittered in a StratifiedGrid(spp)
  int grid_cols;
  float inv_cols;
  float inv_rows;
  uint pad;
  uint64_t seed;
};

// compose.comp: one light's V (or E) into the per-slot sums (Renderer::render's compose).
struct ComposeParams {
  uint64_t samples;      // GpuViewSample[]
  uint64_t light;        // GpuLight
  uint64_t unit_circle;  // float[512] (scene/light.h unit_circle_table)
  uint64_t visibility;   // float per slot, the method's V
  uint64_t irradiance;   // vec3 per slot, the method's E (has_irradiance)
  uint64_t radiance;     // vec3 per slot, summed over lights
  uint64_t v_weighted;   // float per slot: sum of luminance(E0) V
  uint64_t v_weight;     // float per slot: sum of luminance(E0)
  uint64_t v_plain;      // float per slot: sum of V
  uint slots;
  uint has_irradiance;
};

// face_samples.comp: the view samples one face of a split sphere light serves
// (scene/light.h split_sphere_lights), copied, every other slot marked a miss; the face's method
// and compose read the copy, so they draw the served samples alone (Renderer::render's split).
//   0-7 samples  8-15 served  16-27 center  28-31 face  32-43 s  44-47 slots  48-59 t  60-63 cube
//   64-75 n
struct FaceSamplesParams {
  uint64_t samples;  // GpuViewSample[slots], the camera pass's
  uint64_t served;   // GpuViewSample[slots], written
  vec3 center;       // the sphere's
  uint face;         // AreaLight::split_face
  vec3 s;            // AreaLight::split_frame
  uint slots;
  vec3 t;
  uint cube;  // AreaLight::split_cube
  vec3 n;
  uint pad;
};

// frame_sum.comp: progressive frames (RenderSettings::frames): add a frame's V and E into sums
// (mode 0), or turn the sums into their means (mode 1).
struct FrameSumParams {
  uint64_t visibility;
  uint64_t irradiance;  // 0: the method gives V only
  uint64_t visibility_sum;
  uint64_t irradiance_sum;
  uint slots;
  uint mode;
  float inv_frames;
  uint pad;
};

// resolve.comp: one thread per pixel of the window: the mean over its camera rays, misses
// counting as background (black, fully lit).
struct ResolveParams {
  uint64_t samples;
  uint64_t radiance;
  uint64_t v_weighted;
  uint64_t v_weight;
  uint64_t v_plain;
  uint64_t color;       // vec3 per pixel of the window
  uint64_t visibility;  // float per pixel of the window
  int window_width;
  int window_height;
  int spp;
  float lights;  // whole lights (whole_light_count): a split sphere's faces count once together
};

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::CameraPassParams) == 128);
static_assert(sizeof(penumbra::shader::ComposeParams) <= 128);
static_assert(sizeof(penumbra::shader::FaceSamplesParams) == 80);
static_assert(sizeof(penumbra::shader::ResolveParams) <= 128);
#endif

#endif  // PENUMBRA_RENDER_FRAME_KERNELS_SHARED_H
