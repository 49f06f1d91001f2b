#version 460
// ssv-rt on the GPU (soft_shadow_volumes_gpu.cpp; Laine et al. 2005 §3.2-3.3): one work group of
// 64 threads per view sample. Per group of light samples (those in front of the receiver's
// plane, then, on an open receiver, those behind it: soft_shadow_volumes.cpp), from that group's
// ray origin o:
//   thread 0 counts the surfaces the reference ray to the group's first sample crosses (§3.3)
//   and walks the edge hierarchy with the pyramid from o over the light samples (§3.1), handing
//   the edges of the leaves it reaches to the group in batches of 64;
//   each thread sets up one edge of the batch in double (ssv_edge_crossing, §3.2), then every
//   thread updates the depth complexities of its own light samples (j = lane, lane + 64, ...)
//   in shared memory for every edge of the batch.
// A sample with depth complexity 0 is visible; where the scene has casters that stop part of the
// light (alpha masks, opacity < 1, which have no edges), its transmittance is that of its shadow
// segment through the scene (the CPU version tests those casters per sample on the host).
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/bvh_traverse.glsl"
#include "penumbra/shadow/soft_shadow_volumes/ssv_shared.h"
#include "penumbra/shadow/view_samples_shared.h"
#include "penumbra/trace/ray_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { SsvParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };
layout(buffer_reference, scalar) readonly buffer SsvNodes { SsvNode v[]; };
layout(buffer_reference, scalar) readonly buffer SsvEdges { SsvEdge v[]; };

shared int s_depth[kSsvMaxSamples];  // per light sample: D relative to the reference
shared uint s_group[kSsvMaxSamples];  // per light sample: 0 in front of the receiver, 1 behind
shared vec3 s_offset[kSsvMaxSamples];  // per light sample of the group: l - o
shared SsvCrossing s_tests[64];        // the batch's edges that change something, set up
shared uint s_batch[64];               // the batch's edge indices
shared uint s_batch_count;
shared uint s_kept;  // of them, those in s_tests
shared bool s_walk_done;
shared uint s_first[2];  // each group's first light sample (its reference), n if empty
shared int s_reference;  // the reference sample's absolute depth complexity
shared uint s_stack[kSsvStack];
shared uint s_sp;

// The reference ray's count (soft_shadow_volumes.cpp surfaces_crossed): the surfaces the segment
// from o to q crosses, one closest-hit query per surface, each starting past the last hit; a hit
// a few ulps past the last one on a triangle of the same object that shares a vertex with it and
// faces the ray the same way is the same crossing (a ray through a shared edge or vertex).
// Casters that stop part of the light are not counted.
bool counted(uint object, uint prim) {
  GpuObject ob = g_objects.v[object];
  return !object_alpha_textured(ob) && surface_opacity(object, prim, 0.0f, 0.0f) >= 1.0f;
}
vec3 vertex_position(GpuMesh m, uint prim, uint k) { return Vec3s(g_scene.positions).v[mesh_vertex(m, prim, k)]; }
bool share_a_vertex(GpuMesh m, uint a, uint b) {
  bool any = false;
  for (uint i = 0u; i < 3u; ++i)
    for (uint j = 0u; j < 3u; ++j) any = any || vertex_position(m, a, i) == vertex_position(m, b, j);
  return any;
}
// Whether the triangle faces against the ray (its geometric normal . dir < 0), in its mesh's space.
bool faces_against(uint object, uint prim, bool mirrored, vec3 dir) {
  GpuObject ob = g_objects.v[object];
  GpuMesh m = g_meshes.v[ob.mesh];
  vec3 p0 = vertex_position(m, prim, 0u), p1 = vertex_position(m, prim, 1u), p2 = vertex_position(m, prim, 2u);
  vec3 d = dir;
  if (ob.instance != kInstanceObject) {
    GpuInstance inst = g_instances.v[ob.instance];
    if (inst.identity == 0u) d = to_object_vector(inst, dir);
  }
  bool against = dot(cross(p1 - p0, p2 - p0), d) < 0.0f;
  return mirrored ? !against : against;
}
int surfaces_crossed(vec3 o, vec3 q, inout uint hits) {
  vec3 d = q - o;
  float dist = length(d);
  if (!(dist > 0.0f)) return 0;
  vec3 dir = d / dist;
  float tfar = dist * (1.0f - 1e-5f);
  float tnear = 0.0f;
  int count = 0;
  bool any = false;
  RayHit last = no_hit(tfar);
  bool last_against = false;
  for (int guard = 0; guard < 4096; ++guard) {
    RayHit hit;
    if (!trace_closest_after(o, dir, tnear, tfar, hit)) break;
    ++hits;
    if (counted(hit.object, hit.prim)) {
      bool against = faces_against(hit.object, hit.prim, hit.mirrored, dir);
      bool same_crossing = any && hit.object == last.object && hit.t - last.t <= 1e-6f * max(1.0f, hit.t) &&
                           against == last_against &&
                           share_a_vertex(g_meshes.v[g_objects.v[hit.object].mesh], hit.prim, last.prim);
      if (!same_crossing) ++count;
      last = hit;
      last_against = against;
      any = true;
    }
    tnear = hit.t;
    if (!(uintBitsToFloat(floatBitsToUint(tnear) + 1u) < tfar)) break;
  }
  return count;
}

// Whether the box lies wholly on the negative side of the plane n . x + d (its most positive corner).
bool outside(vec3 lo, vec3 hi, vec4 plane) {
  vec3 c = vec3(plane.x >= 0.0f ? hi.x : lo.x, plane.y >= 0.0f ? hi.y : lo.y, plane.z >= 0.0f ? hi.z : lo.z);
  return plane.x * c.x + plane.y * c.y + plane.z * c.z + plane.w < 0.0f;
}

void main() {
  uint lane = gl_LocalInvocationIndex;
  uint slot = pn_thread_index() / 64u;
  bool in_range = slot < pc.p.slots;
  GpuViewSample s;
  if (in_range) s = ViewSamplesIn(pc.p.samples).v[slot];
  // Points behind the light's plane see none of it (as afsm and rays to the samples).
  bool lit = in_range && s.object != kMissObject && dot(s.p - pc.p.light_center, pc.p.light_n) > 0.0f;
  if (!lit) {
    if (in_range && s.object != kMissObject && lane == 0u) Floats(pc.p.visibility).v[slot] = 0.0f;
    return;  // the whole group: no barrier below is reached
  }
  scene_bind(pc.p.scene);
  Vec3s light = Vec3s(pc.p.light);
  Uints counters = Uints(pc.p.counters);
  SsvNodes nodes = SsvNodes(pc.p.nodes);
  SsvEdges edges = SsvEdges(pc.p.edges);
  uint n = pc.p.n;
  // This dispatch's light samples (gpu::LoopLimitSplit splits them where the driver cuts long
  // loops); the groups and their reference samples are of all n.
  uint first = pc.p.first_sample, end = min(n, pc.p.first_sample + pc.p.sample_count);
  // The light samples' groups (ray_shared.h leaves_front: each shadow ray leaves the receiver on
  // its sample's side).
  vec3 n_unit = offset_normal(s.ng);
  if (lane == 0u) {
    s_first[0] = n;
    s_first[1] = n;
  }
  barrier();
  for (uint j = lane; j < n; j += 64u) {
    uint g = leaves_front(n_unit, light.v[kSsvLightCorners + j] - s.p) ? 0u : 1u;
    s_group[j] = g;
    atomicMin(s_first[g], j);
  }
  barrier();
  bool closed = Uints(pc.p.closed).v[s.object] != 0u;
  uint hits = 0u, tests = 0u, updates = 0u;
  float visible = 0.0f;
  for (uint g = 0u; g < (closed ? 1u : 2u); ++g) {
    if (s_first[g] >= n) continue;  // uniform: shared, read after a barrier
    vec3 o = offset_ray_origin_shared(s.p, s.ng, g == 0u ? s.ng : -s.ng);
    vec3 r = light.v[kSsvLightCorners + s_first[g]] - o;
    for (uint j = first + lane; j < end; j += 64u) {
      s_depth[j] = 0;
      s_offset[j] = light.v[kSsvLightCorners + j] - o;
    }
    if (lane == 0u) {
      // §3.3: the reference sample's absolute depth complexity, from one ray.
      s_reference = surfaces_crossed(o, light.v[kSsvLightCorners + s_first[g]], hits);
      s_sp = 0u;
      if (pc.p.node_count > 0u) s_stack[s_sp++] = 0u;
      s_walk_done = false;
    }
    // The pyramid from o over the samples' rectangle: four planes through o and the light's
    // plane (edges beyond the light change nothing). Thread 0 walks with it.
    vec4 planes[5];
    vec3 rect_centre = light.v[4];
    for (int k = 0; k < 4; ++k) {
      vec3 nn = cross(light.v[k] - o, light.v[(k + 1) % 4] - o);
      if (dot(nn, rect_centre - o) < 0.0f) nn = -nn;
      planes[k] = vec4(nn, -dot(nn, o));
    }
    planes[4] = vec4(pc.p.light_n, -dot(pc.p.light_n, pc.p.light_center));
    float o_size = max(abs(o.x), max(abs(o.y), abs(o.z)));
    barrier();
    for (;;) {
      if (lane == 0u) {
        // §3.1: the leaves whose edges the pyramid may hold, up to a batch of 64 edges.
        uint count = 0u;
        while (s_sp > 0u) {
          uint k = s_stack[s_sp - 1u];
          SsvNode node = nodes.v[k];
          if (node.count > 0u && count + node.count > 64u) break;  // the next batch takes it
          --s_sp;
          // Written out: a loop here would count 5 iterations a node against lavapipe's loop limit.
          bool cut = outside(node.lo, node.hi, planes[0]) || outside(node.lo, node.hi, planes[1]) ||
                     outside(node.lo, node.hi, planes[2]) || outside(node.lo, node.hi, planes[3]) ||
                     outside(node.lo, node.hi, planes[4]);
          if (cut || (node.cullable != 0u && ssv_sees_all_alike(node.axis, node.spread, node.h_lo, node.h_hi,
                                                                  node.centre, node.half_diagonal, o)))
            continue;
          if (node.count == 0u) {
            if (s_sp + 2u > kSsvStack) {
              atomicOr(counters.v[kSsvStackFull], 1u);
              continue;
            }
            s_stack[s_sp++] = node.first;
            s_stack[s_sp++] = node.first + 1u;
            continue;
          }
          for (uint i = 0u; i < node.count; ++i) s_batch[count++] = node.first + i;
        }
        s_batch_count = count;
        s_kept = 0u;
        s_walk_done = count == 0u;
        tests += count;
      }
      barrier();
      if (s_walk_done) break;
      uint batch = s_batch_count;
      // §3.2: each thread sets up one edge (an edge surely no silhouette from o changes nothing);
      // those that change something are kept side by side (in any order: the updates add up).
      if (lane < batch) {
        SsvEdge e = edges.v[s_batch[lane]];
        SsvCrossing c;
        bool quick_no = e.triangles == 2u && ssv_surely_not_silhouette(e.n0, e.d0, e.scale0, e.n1, e.d1, e.scale1,
                                                                       o, o_size);
        if (!quick_no && ssv_edge_crossing(e.a, e.b, e.w0, e.w1, e.triangles, o, r, c))
          s_tests[atomicAdd(s_kept, 1u)] = c;
      }
      barrier();
      uint kept = s_kept;
      updates += kept;
      for (uint t = 0u; t < kept; ++t) {
        SsvCrossing c = s_tests[t];
        for (uint j = first + lane; j < end; j += 64u)
          if (s_group[j] == g && ssv_sample_crosses(c, s_offset[j])) s_depth[j] += c.delta;
      }
      barrier();
    }
    // A sample is visible iff its depth complexity is 0 (§3.3); its transmittance through the
    // casters that stop part of the light.
    int reference = s_reference;
    for (uint j = first + lane; j < end; j += 64u) {
      if (s_group[j] != g || s_depth[j] + reference != 0) continue;
      float v = 1.0f;
      if (g_scene.has_transparency != 0u) {
        vec3 org, dir;
        float tfar;
        shadow_segment(s.p, s.ng, light.v[kSsvLightCorners + j], org, dir, tfar);
        v = trace_transmittance(org, dir, tfar);
      }
      visible += v;
    }
    if (lane == 0u && first == 0u) atomicAdd(counters.v[kSsvGroups], 1u);
    barrier();
  }
  // V: the threads' sums over the group (subgroup sizes vary: shared memory, reusing s_offset's
  // first 64 entries' x).
  s_offset[lane].x = visible;
  barrier();
  if (lane == 0u) {
    float sum = 0.0f;
    for (uint k = 0u; k < 64u; ++k) sum += s_offset[k].x;
    // The first dispatch of the light samples writes V, the others add their share.
    Floats out_v = Floats(pc.p.visibility);
    out_v.v[slot] = (first == 0u ? 0.0f : out_v.v[slot]) + sum / float(n);
    if (first == 0u) {  // the walk's counts, once
      atomicAdd(counters.v[kSsvEdgeTests], tests);
      atomicAdd(counters.v[kSsvEdgeUpdates], updates);
      atomicAdd(counters.v[kSsvCrossings], hits);
    }
  }
  if (pn_loop_limit_hit(pc.p.canary)) atomicOr(counters.v[kSsvLoopCut], 1u);
}
