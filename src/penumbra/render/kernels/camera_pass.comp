#version 460
// The camera pass on the GPU (Renderer's CameraPass): one thread per camera ray of the window,
// traced to its nearest hit (gpu/bvh_traverse.glsl), and the view sample built as the CPU
// builds it: position by barycentric interpolation, the geometric normal facing the camera, the
// shading normal in its hemisphere, the albedo (textured, black behind a one-sided surface).
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/bvh_traverse.glsl"
#include "penumbra/core/rng_shared.h"
#include "penumbra/core/sampling_shared.h"
#include "penumbra/render/frame_kernels_shared.h"
#include "penumbra/scene/camera_shared.h"
#include "penumbra/shadow/view_samples_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { CameraPassParams p; } pc;
layout(buffer_reference, scalar) writeonly buffer ViewSamplesOut { GpuViewSample v[]; };

void main() {
  uint slot = pn_thread_index();
  uint spp = uint(pc.p.spp);
  uint rays = uint(pc.p.window_width * pc.p.window_height) * spp;
  if (slot >= rays) return;
  scene_bind(pc.p.scene);
  uint sub = slot % spp, px = slot / spp;
  int x = pc.p.x0 + int(px % uint(pc.p.window_width)), y = pc.p.y0 + int(px / uint(pc.p.window_width));
  vec2 at = vec2(float(x) + 0.5f, float(y) + 0.5f);
  if (spp > 1u) {
    // The pixel's stream (CameraPass::run): sample s uses its (2s+1)-th and (2s+2)-th numbers.
    RngState rng = rng_keyed(pc.p.seed, 0x43414dUL, uint64_t(y * pc.p.image_width + x), 0UL);
    rng.counter = uint64_t(2u * sub);
    vec2 u = stratified_cell(int(sub), pc.p.grid_cols, pc.p.inv_cols, pc.p.inv_rows, rng_next_2d(rng));
    at = vec2(float(x) + u.x, float(y) + u.y);
  }
  vec3 dir = camera_ray_direction(pc.p.s, pc.p.t, pc.p.n, pc.p.tan_half, pc.p.aspect, pc.p.width, pc.p.height, at.x, at.y);
  RayHit hit;
  GpuViewSample vs;
  vs.pixel = uint(y * pc.p.image_width + x);
  vs.sub = sub;
  if (!trace_closest(pc.p.eye, dir, pn_inf(), hit)) {
    vs.p = vec3(0.0f);
    vs.ng = vec3(0.0f);
    vs.ns = vec3(0.0f);
    vs.albedo = vec3(0.0f);
    vs.object = kMissObject;
    vs.prim = 0u;
    ViewSamplesOut(pc.p.samples).v[slot] = vs;
    return;
  }
  GpuObject obj = g_objects.v[hit.object];
  GpuMesh m = g_meshes.v[obj.mesh];
  GpuInstance inst = g_instances.v[obj.instance];
  uint i0 = mesh_vertex(m, hit.prim, 0u), i1 = mesh_vertex(m, hit.prim, 1u), i2 = mesh_vertex(m, hit.prim, 2u);
  Vec3s pos = Vec3s(g_scene.positions);
  vec3 p0 = pos.v[i0], p1 = pos.v[i1], p2 = pos.v[i2];
  if (inst.identity == 0u) {
    p0 = instance_point(inst, p0);
    p1 = instance_point(inst, p1);
    p2 = instance_point(inst, p2);
  }
  float w = 1.0f - hit.u - hit.v;
  // Barycentric interpolation is more accurate than org + t dir far from the eye.
  vs.p = p0 * w + p1 * hit.u + p2 * hit.v;
  vec3 ng = normalize(cross(p1 - p0, p2 - p0));
  bool back = dot(ng, dir) > 0.0f;
  vs.ng = back ? -ng : ng;
  if ((m.flags & kMeshNormals) != 0u) {
    Vec3s nrm = Vec3s(g_scene.normals);
    vec3 n0 = nrm.v[i0], n1 = nrm.v[i1], n2 = nrm.v[i2];
    if (inst.identity == 0u) {
      n0 = instance_normal(inst, n0);
      n1 = instance_normal(inst, n1);
      n2 = instance_normal(inst, n2);
    }
    vec3 ns = n0 * w + n1 * hit.u + n2 * hit.v;
    float len = length(ns);
    ns = len > 0.0f ? ns / len : vs.ng;
    vs.ns = dot(ns, vs.ng) < 0.0f ? -ns : ns;
  } else {
    vs.ns = vs.ng;
  }
  if (back && (obj.flags & kObjectTwoSided) == 0u)
    vs.albedo = vec3(0.0f);
  else if (obj.albedo_texture != kNoTexture && (m.flags & kMeshUvs) != 0u)
    vs.albedo = obj.albedo * texture_rgb(obj.albedo_texture, mesh_uv(m, hit.prim, hit.u, hit.v));
  else
    vs.albedo = obj.albedo;
  vs.object = hit.object;
  vs.prim = hit.prim;
  ViewSamplesOut(pc.p.samples).v[slot] = vs;
}
