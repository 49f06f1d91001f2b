// `single-sample` on the GPU, byte by byte (single_sample_gpu.cpp; docs/methods/single-sample.md,
// "On the GPU"): the search's set-up block, its counters and kernels/single_sample_search.comp's
// parameters. The occluder BVH's nodes, triangles and planes and the spheres are
// single_sample_shared.h's SsNode, SsTriangle, SsPlane and SsSphere arrays. Common subset of C++
// and GLSL (core/shader_compat.h), scalar block layout.
#ifndef PENUMBRA_SHADOW_SINGLE_SAMPLE_SINGLE_SAMPLE_KERNELS_SHARED_H
#define PENUMBRA_SHADOW_SINGLE_SAMPLE_SINGLE_SAMPLE_KERNELS_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/shadow/single_sample/single_sample_shared.h"

PN_SHARED_BEGIN

// The most BVH levels the search's stack holds (the host checks the BVH against it).
PN_CONST int kSsStack = 64;

// What the search needs of the light and the occluders, 80 bytes: bytes 0-11 the light's centre
// (every shadow ray ends there), 12-15 D (the light's diameter), 16-63 the light frame's axes s, t,
// n (the BVH's frame: x_local = (dot(x - centre, s), dot(x - centre, t), dot(x - centre, n))) with
// plane_eps (two points this close to one plane lie in it), combine (0 min, 1 multiply, 2 add) and
// sphere_count after s, t and n, 64-67 node_count (0: no occluder triangle), 68-79 (0).
struct SsSetup {
  vec3 light_pos;
  float diameter;
  vec3 frame_s;
  float plane_eps;
  vec3 frame_t;
  uint combine;
  vec3 frame_n;
  uint sphere_count;
  uint node_count;
  uint pad0;
  uint pad1;
  uint pad2;
};

// What the search counts, 40 bytes (the CPU's statistics): bytes 0-7 BVH nodes visited, 8-15
// triangles tested, 16-23 clipped triangle tests, 24-27 rays (view samples that hit something),
// 28-31 rays the inner objects blocked, 32-35 rays searched, 36-39 (0).
struct SsCounters {
  uint64_t nodes;
  uint64_t tests;
  uint64_t clipped;
  uint rays;
  uint blocked;
  uint searched;
  uint pad;
};

// single_sample_search.comp: one thread per view-sample slot.
struct SingleSampleParams {
  uint64_t scene;       // SceneDesc: the inner objects' shadow rays
  uint64_t samples;     // GpuViewSample[slots]
  uint64_t visibility;  // float per slot
  uint64_t setup;       // SsSetup
  uint64_t nodes;       // SsNode[node_count]
  uint64_t triangles;   // SsTriangle[]
  uint64_t planes;      // SsPlane[] (per triangle)
  uint64_t spheres;     // SsSphere[sphere_count]
  uint64_t counters;    // SsCounters
  uint slots;
  uint pad;
};

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::SsSetup) == 80);
static_assert(sizeof(penumbra::shader::SsCounters) == 40);
static_assert(sizeof(penumbra::shader::SingleSampleParams) <= 128);
#endif

#endif  // PENUMBRA_SHADOW_SINGLE_SAMPLE_SINGLE_SAMPLE_KERNELS_SHARED_H
