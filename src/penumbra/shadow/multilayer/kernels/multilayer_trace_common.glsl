// The declarations mlsm_trace and mtsm_trace start with (multilayer_kernels_shared.h).
#ifndef PENUMBRA_SHADOW_MULTILAYER_KERNELS_MULTILAYER_TRACE_COMMON_GLSL
#define PENUMBRA_SHADOW_MULTILAYER_KERNELS_MULTILAYER_TRACE_COMMON_GLSL

#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/bvh_traverse.glsl"
#include "penumbra/gpu/scene_access.glsl"
#include "penumbra/gpu/light_access.glsl"
#include "penumbra/core/rng_shared.h"
#include "penumbra/core/sampling_shared.h"
#include "penumbra/shadow/multilayer/multilayer_kernels_shared.h"
#include "penumbra/shadow/view_samples_shared.h"
#include "penumbra/trace/ray_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { MlTraceParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };
layout(buffer_reference, scalar) readonly buffer TraceBlockRef { MlTraceBlock b; };
layout(buffer_reference, scalar) buffer CountersRef { MlGpuCounters c; };
layout(buffer_reference, scalar) readonly buffer TraceFrameRef { MlTraceFrame f; };

#endif
