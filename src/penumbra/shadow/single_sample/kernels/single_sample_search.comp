#version 460
// `single-sample` on the GPU (parker1998; single_sample.cpp): one thread per view sample. The hard
// shadow ray to the light's centre through the real geometry (the inner objects, §2: the GpuScene's
// BVH, as `hard` traces it): blocked, V = 0. Otherwise the outer objects: the analytic spheres
// (appendix), then the search in cone space over the occluder BVH built on the host by the CPU's
// code (occluders.h: the contour candidates in a frame centred on the light), nearest child first,
// pruning every node whose lower bound of (perp / t)^2 cannot lower the ray's s, each triangle
// found nearer lowering the limit. single_sample_shared.h holds the per-node and per-triangle math,
// the CPU's. The CPU searches packets of 8 rays seeded with their neighbours' nearest triangles;
// with `min` the result is the minimum over the same triangles either way.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/bvh_traverse.glsl"
#include "penumbra/scene/light_shared.h"
#include "penumbra/shadow/single_sample/single_sample_kernels_shared.h"
#include "penumbra/shadow/view_samples_shared.h"
#include "penumbra/trace/ray_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { SingleSampleParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };
layout(buffer_reference, scalar) readonly buffer SetupRef { SsSetup s; };
layout(buffer_reference, scalar) readonly buffer Nodes { SsNode v[]; };
layout(buffer_reference, scalar) readonly buffer Triangles { SsTriangle v[]; };
layout(buffer_reference, scalar) readonly buffer Planes { SsPlane v[]; };
layout(buffer_reference, scalar) readonly buffer Spheres { SsSphere v[]; };
layout(buffer_reference, scalar) buffer CountersRef { SsCounters c; };

SsSetup g_setup;
// The ray in the light frame (single_sample.cpp RayFrame) and its cone: k2 = (D / |l - o|)^2.
vec3 g_o, g_v, g_e1, g_e2, g_av, g_ae1, g_ae2, g_p;
float g_near, g_far, g_k2;
uint g_object, g_prim;
// The search's state (single_sample.cpp Lane): with `min`, limit2 = (k tau)^2 holds s; with the
// other rules s accumulates and limit2 = k2 (only tau < 1 matters).
float g_limit2, g_s;
bool g_min;
uint g_visited, g_tested, g_clips;

vec3 to_light_space(vec3 x) {
  vec3 d = x - g_setup.light_pos;
  return vec3(dot(d, g_setup.frame_s), dot(d, g_setup.frame_t), dot(d, g_setup.frame_n));
}

void combine(float si) {
  if (g_setup.combine == 0u) g_s = min(g_s, si);              // the paper's choice
  else if (g_setup.combine == 1u) g_s *= si;                   // s = s1 s2
  else g_s = max(0.0f, g_s - (1.0f - si));                     // s = 1 - ((1 - s1) + (1 - s2))
}

// The receiver's own triangle, and triangles in its plane (the rest of a ground plane or a leaf),
// are no occluders of it.
bool excluded(SsTriangle t, SsPlane plane) {
  return t.object == g_object && (t.prim == g_prim || abs(dot(plane.n, g_p) - plane.d) < g_setup.plane_eps);
}

// A triangle at squared cone distance d2 < limit2 (single_sample.cpp accept). False when the ray
// is fully blocked (s = 0).
bool accept(SsTriangle t, SsPlane plane, float d2) {
  if (excluded(t, plane)) return true;
  if (g_min) {
    if (t.opacity >= 1.0f) {
      g_limit2 = d2;
      return d2 > 0.0f;
    }
    float si = ss_occluder_transmission(t.opacity, d2, g_k2);
    float tau = ss_inverse_falloff(si);
    g_limit2 = min(g_limit2, g_k2 * (tau * tau));
    return true;
  }
  combine(ss_occluder_transmission(t.opacity, d2, g_k2));
  return g_s > 0.0f;
}

float box_bound2(SsNode n) {
  return ss_box_bound2(n.lo, n.hi, g_o, g_v, g_e1, g_e2, g_av, g_ae1, g_ae2, g_near, g_far);
}

// The descent (single_sample.cpp search_single): nearest child first.
void search() {
  Nodes nodes = Nodes(pc.p.nodes);
  Triangles tris = Triangles(pc.p.triangles);
  Planes planes = Planes(pc.p.planes);
  float bounds[kSsStack];
  uint stack[kSsStack];
  int sp = 0;
  bounds[0] = box_bound2(nodes.v[0]);
  stack[0] = 0u;
  sp = 1;
  while (sp > 0) {
    --sp;
    float bound = bounds[sp];
    uint index = stack[sp];
    if (bound >= g_limit2) continue;
    ++g_visited;
    SsNode n = nodes.v[index];
    if (n.count != 0u) {
      for (uint i = n.first; i < n.first + n.count; ++i) {
        ++g_tested;
        SsTriangle t = tris.v[i];
        SsPlane plane = planes.v[i];
        if (!ss_triangle_in_range(g_o, g_v, g_near, g_far, t.v0, t.v1, t.v2)) {
          // Straddles the ray's origin plane: clip it, unless it is the receiver's own triangle
          // or coplanar with it (the ground under a ground receiver), or the ray leaves its plane
          // too steeply.
          if (excluded(t, plane) || ss_leaves_plane(g_o, g_v, plane, g_limit2)) continue;
          ++g_clips;
        }
        float d2 = ss_triangle_cone_distance2(g_o, g_v, g_e1, g_e2, g_near, g_far, t.v0, t.v1, t.v2);
        if (d2 >= g_limit2) continue;
        if (!accept(t, plane, d2)) return;
      }
      continue;
    }
    float b0 = box_bound2(nodes.v[n.first]), b1 = box_bound2(nodes.v[n.first + 1u]);
    // Nearest child last on the stack, so it is searched first.
    uint near_child = b0 < b1 ? n.first : n.first + 1u, far_child = b0 < b1 ? n.first + 1u : n.first;
    float near_bound = min(b0, b1), far_bound = b0 < b1 ? b1 : b0;
    if (far_bound < g_limit2) {
      bounds[sp] = far_bound;
      stack[sp++] = far_child;
    }
    if (near_bound < g_limit2) {
      bounds[sp] = near_bound;
      stack[sp++] = near_child;
    }
  }
}

// V of one view sample (single_sample.cpp evaluate, begin_lane, search_single, Lane::result).
float single_sample_visibility(GpuViewSample s, out bool blocked, out bool searched) {
  blocked = false;
  searched = false;
  vec3 l = g_setup.light_pos;
  // The inner objects: the hard shadow ray (hard.cpp's).
  vec3 org, dir;
  float tfar;
  shadow_segment(s.p, s.ng, l, org, dir, tfar);
  if (trace_transmittance(org, dir, tfar) == 0.0f) {
    blocked = true;
    return 0.0f;
  }
  g_min = g_setup.combine == 0u;
  g_s = 1.0f;
  float light_dist = length(l - org);
  if (!(light_dist > 0.0f)) return 1.0f;
  g_o = to_light_space(org);
  g_v = vec3(dot(dir, g_setup.frame_s), dot(dir, g_setup.frame_t), dot(dir, g_setup.frame_n));
  vec3 axis;
  frame_from_z(g_v, g_e1, g_e2, axis);
  g_av = abs(g_v);
  g_ae1 = abs(g_e1);
  g_ae2 = abs(g_e2);
  g_near = 1e-6f * light_dist;
  g_far = light_dist;
  g_p = to_light_space(s.p);
  g_object = s.object;
  g_prim = s.prim;
  float k = g_setup.diameter / light_dist;  // b(t) = k t
  g_k2 = k * k;
  if (!(g_k2 > 0.0f)) return 1.0f;  // D = 0: a point light, the hard shadow alone
  Spheres spheres = Spheres(pc.p.spheres);
  for (uint i = 0u; i < g_setup.sphere_count; ++i) {
    SsSphere sp = spheres.v[i];
    float si = ss_sphere_transmission(org, dir, light_dist, sp.center, sp.radius, g_setup.diameter);
    combine(1.0f - sp.opacity * (1.0f - si));
  }
  float tau = ss_inverse_falloff(g_s);
  g_limit2 = g_min && g_s < 1.0f ? g_k2 * (tau * tau) : g_k2;
  if (g_s > 0.0f && g_setup.node_count > 0u) {
    searched = true;
    search();
  }
  return g_min ? ss_falloff(sqrt(g_limit2 / g_k2)) : g_s;
}

void main() {
  uint i = pn_thread_index();
  g_visited = 0u;
  g_tested = 0u;
  g_clips = 0u;
  uint rays = 0u, blocked = 0u, searched = 0u;
  if (i < pc.p.slots) {
    GpuViewSample s = ViewSamplesIn(pc.p.samples).v[i];
    if (s.object != kMissObject) {
      scene_bind(pc.p.scene);
      g_setup = SetupRef(pc.p.setup).s;
      bool b, f;
      Floats(pc.p.visibility).v[i] = single_sample_visibility(s, b, f);
      rays = 1u;
      blocked = b ? 1u : 0u;
      searched = f ? 1u : 0u;
    }
  }
  uint nodes = subgroupAdd(g_visited), tests = subgroupAdd(g_tested), clipped = subgroupAdd(g_clips);
  rays = subgroupAdd(rays);
  blocked = subgroupAdd(blocked);
  searched = subgroupAdd(searched);
  if (subgroupElect() && rays > 0u) {
    CountersRef c = CountersRef(pc.p.counters);
    atomicAdd(c.c.nodes, uint64_t(nodes));
    atomicAdd(c.c.tests, uint64_t(tests));
    atomicAdd(c.c.clipped, uint64_t(clipped));
    atomicAdd(c.c.rays, rays);
    atomicAdd(c.c.blocked, blocked);
    atomicAdd(c.c.searched, searched);
  }
}
