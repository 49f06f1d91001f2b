// Ray queries against the bound scene (gpu/scene_access.glsl): a stack-based traversal of the
// two-level BVH (Aila & Laine 2009, "Understanding the Efficiency of Ray Traversal on GPUs":
// both children's boxes in the parent, the nearer child first for closest hits), with the
// CPU ray tracer's rules (trace/ray_tracer.cpp):
//   trace_closest        the nearest hit a camera ray stops at (alpha masks let it through);
//   trace_closest_after  the same beyond a distance tmin (the next surface along a ray, as the
//                        CPU's closest-hit queries with tnear: ssv-rt counts surfaces so);
//   trace_transmittance  the fraction of light along a shadow segment: 0 at an opaque hit,
//                        (1 - opacity) per semi-transparent surface crossed, once per surface
//                        where a ray crosses the edge two triangles share.
// Triangles are tested with Moller-Trumbore (u, v: the barycentrics of vertices 1 and 2, as
// Embree reports them); t in (0, tmax].
#ifndef PENUMBRA_GPU_BVH_TRAVERSE_GLSL
#define PENUMBRA_GPU_BVH_TRAVERSE_GLSL

#include "penumbra/gpu/scene_access.glsl"

// Two BVH levels of at most kMaxBvhDepth (gpu/bvh_builder.h) levels each push at most one entry
// a level, plus an instance's entry and exit marks.
#define PN_TRAVERSAL_STACK 96
const uint kEnterInstance = 0x80000000u;  // | instance index
const uint kExitInstance = 0xffffffffu;

struct RayHit {
  float t;
  uint object;
  uint prim;
  float u;  // barycentrics in the triangle's own mesh (a shared mesh's, for an instance)
  float v;
  bool mirrored;  // the instance mirrors: the world mesh's barycentrics are (v, u)
};

// 1/d without infinities (so box tests never compute 0 * inf).
vec3 safe_inverse(vec3 d) {
  const float eps = 1e-20f;
  return vec3(1.0f / (abs(d.x) > eps ? d.x : (d.x >= 0.0f ? eps : -eps)),
              1.0f / (abs(d.y) > eps ? d.y : (d.y >= 0.0f ? eps : -eps)),
              1.0f / (abs(d.z) > eps ? d.z : (d.z >= 0.0f ? eps : -eps)));
}

// The entry distance of the ray into the box, or +inf if it misses it within (tmin, tmax]
// (tmin 0: every query but trace_closest_after's, which skips the boxes it has passed).
float box_entry(vec3 lo, vec3 hi, vec3 o, vec3 inv_d, float tmin, float tmax) {
  vec3 t0 = (lo - o) * inv_d, t1 = (hi - o) * inv_d;
  vec3 tn = min(t0, t1), tf = max(t0, t1);
  float enter = max(max(tn.x, tn.y), max(tn.z, tmin));
  float leave = min(min(tf.x, tf.y), min(tf.z, tmax));
  return enter <= leave ? enter : pn_inf();
}

// Moller-Trumbore in Embree's formulation (its MoellerTrumboreIntersector1: e1 = v0 - v1,
// e2 = v2 - v0, Ng = e2 x e1, the edge tests on the undivided values), so the GPU decides edge and
// grazing cases as the CPU's Embree does: true and (t, u, v) where the ray meets the triangle with
// t in (0, tmax].
bool intersect_triangle(GpuTriangle tri, vec3 o, vec3 d, float tmax, out float t, out float u, out float v) {
  vec3 e1 = tri.v0 - tri.v1, e2 = tri.v2 - tri.v0;
  vec3 ng = cross(e2, e1);
  vec3 c = tri.v0 - o;
  vec3 r = cross(c, d);
  float den = dot(ng, d);
  float abs_den = abs(den);
  bool flip = (floatBitsToUint(den) >> 31) != 0u;  // Embree XORs the sign of den in
  float uu = dot(r, e2), vv = dot(r, e1);
  if (flip) {
    uu = -uu;
    vv = -vv;
  }
  t = 0.0f;
  u = 0.0f;
  v = 0.0f;
  if (den == 0.0f || uu < 0.0f || vv < 0.0f || uu + vv > abs_den) return false;
  float tt = dot(ng, c);
  if (flip) tt = -tt;
  if (!(tt > 0.0f && tt <= abs_den * tmax)) return false;
  float inv = 1.0f / abs_den;
  t = tt * inv;
  u = uu * inv;
  v = vv * inv;
  return true;
}

// An instance's transform of a point and of a direction.
vec3 to_object_point(GpuInstance inst, vec3 p) {
  return vec3(dot(inst.to_object_x, p) + inst.to_object_tx, dot(inst.to_object_y, p) + inst.to_object_ty,
              dot(inst.to_object_z, p) + inst.to_object_tz);
}
vec3 to_object_vector(GpuInstance inst, vec3 d) {
  return vec3(dot(inst.to_object_x, d), dot(inst.to_object_y, d), dot(inst.to_object_z, d));
}

// Below this a shadow ray counts as blocked (ray_tracer.cpp kOpaqueCutoff).
const float kOpaqueCutoff = 1e-4f;

// The traversal both queries share (closest: keep the nearest hit a camera ray stops at;
// otherwise: multiply the transmittance and stop when nothing is left). Both callers pass a
// constant `closest`, so each gets its own specialised copy once inlined.
void traverse(vec3 org, vec3 dir, float tmin, float tmax, bool closest, inout RayHit hit, inout float transmit) {
  uint stack[PN_TRAVERSAL_STACK];
  int sp = 0;
  vec3 o = org, d = dir, inv_d = safe_inverse(dir);
  uint inst_object = kInstanceObject;
  bool inst_mirrored = false;
  bool in_blas = g_scene.root_is_blas != 0u;
  bool done = false;
  bool opaque_scene = g_scene.has_transparency == 0u;
  // The last few surfaces a shadow ray crossed (ray_tracer.cpp RecentHits): a ray through an
  // edge two triangles of one surface share meets both; it is attenuated once.
  float recent_t[4];
  uint recent_object[4];
  int recent_count = 0, recent_next = 0;
  stack[sp++] = g_scene.root;
  while (sp > 0 && !done) {
    uint e = stack[--sp];
    if (e == kExitInstance) {  // back to the world's ray
      o = org;
      d = dir;
      inv_d = safe_inverse(dir);
      in_blas = false;
      inst_object = kInstanceObject;
      inst_mirrored = false;
      continue;
    }
    if ((e & kEnterInstance) != 0u) {  // into an instance's BLAS, in its space
      GpuInstance inst = g_instances.v[e & ~kEnterInstance];
      if (inst.identity == 0u) {
        o = to_object_point(inst, org);
        d = to_object_vector(inst, dir);
        inv_d = safe_inverse(d);
      }
      inst_object = inst.object;
      inst_mirrored = inst.mirrored != 0u;
      in_blas = true;
      stack[sp++] = kExitInstance;
      stack[sp++] = inst.root;
      continue;
    }
    GpuBvhNode n = g_nodes.v[e];
    float h0 = n.child0 == kEmptyChild ? pn_inf() : box_entry(n.lo0, n.hi0, o, inv_d, tmin, tmax);
    float h1 = n.child1 == kEmptyChild ? pn_inf() : box_entry(n.lo1, n.hi1, o, inv_d, tmin, tmax);
    for (int k = 0; k < 2 && !done; ++k) {
      // The farther child goes onto the stack first, so the nearer is popped first.
      bool second = (h1 < h0) == (k == 0);
      float h = second ? h1 : h0;
      if (isinf(h)) continue;
      uint child = second ? n.child1 : n.child0;
      uint count = second ? n.count1 : n.count0;
      if (count == 0u) {
        stack[sp++] = child;
        continue;
      }
      if (!in_blas) {  // a TLAS leaf: its instances
        for (uint i = 0u; i < count; ++i) stack[sp++] = kEnterInstance | (child + i);
        continue;
      }
      for (uint i = 0u; i < count && !done; ++i) {
        GpuTriangle tri = g_triangles.v[child + i];
        float t, u, v;
        if (!intersect_triangle(tri, o, d, tmax, t, u, v)) continue;
        uint object = tri.object != kInstanceObject ? tri.object : inst_object;
        if (closest) {
          if (!(t > tmin)) continue;  // before the query's start (trace_closest_after)
          if (!surface_seen(object, tri.prim, u, v)) continue;  // an alpha mask's hole
          tmax = t;
          hit.t = t;
          hit.object = object;
          hit.prim = tri.prim;
          hit.u = u;
          hit.v = v;
          hit.mirrored = inst_mirrored;
          continue;
        }
        if (opaque_scene) {
          transmit = 0.0f;
          done = true;
          continue;
        }
        float a = surface_opacity(object, tri.prim, u, v);
        if (!(a > 0.0f)) continue;  // a hole of an alpha mask: nothing there
        bool seen = false;
        float eps = 1e-5f * max(1.0f, t);
        for (int r = 0; r < recent_count; ++r)
          seen = seen || (recent_object[r] == object && abs(recent_t[r] - t) <= eps);
        if (seen) continue;  // the same surface through a shared edge
        recent_t[recent_next] = t;
        recent_object[recent_next] = object;
        recent_next = (recent_next + 1) % 4;
        recent_count = min(recent_count + 1, 4);
        transmit *= 1.0f - a;
        if (!(transmit > kOpaqueCutoff)) {
          transmit = 0.0f;
          done = true;
        }
      }
    }
  }
}

RayHit no_hit(float tmax) {
  RayHit h;
  h.t = tmax;
  h.object = kMissObject;
  h.prim = 0u;
  h.u = 0.0f;
  h.v = 0.0f;
  h.mirrored = false;
  return h;
}

// The nearest hit along org + t dir, t in (0, tmax], that a camera ray stops at.
bool trace_closest(vec3 org, vec3 dir, float tmax, out RayHit hit) {
  hit = no_hit(tmax);
  float unused = 1.0f;
  traverse(org, dir, 0.0f, tmax, true, hit, unused);
  return hit.object != kMissObject;
}

// The nearest such hit with t in (tmin, tmax].
bool trace_closest_after(vec3 org, vec3 dir, float tmin, float tmax, out RayHit hit) {
  hit = no_hit(tmax);
  float unused = 1.0f;
  traverse(org, dir, tmin, tmax, true, hit, unused);
  return hit.object != kMissObject;
}

// The fraction of light along org + t dir, t in (0, tmax] (see the header comment).
float trace_transmittance(vec3 org, vec3 dir, float tmax) {
  RayHit unused = no_hit(tmax);
  float transmit = 1.0f;
  traverse(org, dir, 0.0f, tmax, false, unused, transmit);
  return transmit;
}

#endif
