// Reading the scene on the GPU (gpu/scene_layout_shared.h): a kernel binds the SceneDesc at the
// address it was given (scene_bind), then asks for objects, meshes, texture lookups and the
// opacity a surface stops light with, with the CPU's rules (scene/texture.h SurfaceAlpha,
// trace/ray_tracer.cpp's filters).
#ifndef PENUMBRA_GPU_SCENE_ACCESS_GLSL
#define PENUMBRA_GPU_SCENE_ACCESS_GLSL

#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/scene_layout_shared.h"
#include "penumbra/scene/texture_shared.h"

layout(buffer_reference, scalar) readonly buffer SceneDescRef { SceneDesc d; };
layout(buffer_reference, scalar) readonly buffer BvhNodes { GpuBvhNode v[]; };
layout(buffer_reference, scalar) readonly buffer BvhTriangles { GpuTriangle v[]; };
layout(buffer_reference, scalar) readonly buffer Instances { GpuInstance v[]; };
layout(buffer_reference, scalar) readonly buffer Objects { GpuObject v[]; };
layout(buffer_reference, scalar) readonly buffer Meshes { GpuMesh v[]; };
layout(buffer_reference, scalar) readonly buffer Textures { GpuTexture v[]; };

// The bound scene and its arrays.
SceneDesc g_scene;
BvhNodes g_nodes;
BvhTriangles g_triangles;
Instances g_instances;
Objects g_objects;
Meshes g_meshes;

void scene_bind(uint64_t desc) {
  g_scene = SceneDescRef(desc).d;
  g_nodes = BvhNodes(g_scene.nodes);
  g_triangles = BvhTriangles(g_scene.triangles);
  g_instances = Instances(g_scene.instances);
  g_objects = Objects(g_scene.objects);
  g_meshes = Meshes(g_scene.meshes);
}

// An instance's object -> world transform of a point, and the inverse transpose for normals.
vec3 instance_point(GpuInstance inst, vec3 q) {
  return vec3(dot(inst.to_world_x, q) + inst.to_world_tx, dot(inst.to_world_y, q) + inst.to_world_ty,
              dot(inst.to_world_z, q) + inst.to_world_tz);
}
vec3 instance_normal(GpuInstance inst, vec3 m) {
  return inst.to_object_x * m.x + inst.to_object_y * m.y + inst.to_object_z * m.z;
}

// Vertex k (0..2) of triangle prim of mesh m: its index into the vertex arrays.
uint mesh_vertex(GpuMesh m, uint prim, uint k) {
  return m.first_vertex + Uints(g_scene.indices).v[3u * (m.first_triangle + prim) + k];
}

// Texture coordinates at barycentrics (b1, b2) of triangle prim (TriangleMesh::uv_at).
vec2 mesh_uv(GpuMesh m, uint prim, float b1, float b2) {
  Vec2s uvs = Vec2s(g_scene.uvs);
  vec2 a = uvs.v[mesh_vertex(m, prim, 0u)], b = uvs.v[mesh_vertex(m, prim, 1u)], c = uvs.v[mesh_vertex(m, prim, 2u)];
  float b0 = 1.0f - b1 - b2;
  return vec2(b0 * a.x + b1 * b.x + b2 * c.x, b0 * a.y + b1 * b.y + b2 * c.y);
}

// Bilinear lookups (Texture::rgb, Texture::alpha).
vec4 texture_texel(GpuTexture t, uint i) { return Vec4s(g_scene.texels).v[t.first_texel + i]; }
vec3 texture_rgb(uint index, vec2 uv) {
  GpuTexture t = Textures(g_scene.textures).v[index];
  TexelFootprint f = texel_footprint(uv, t.width, t.height);
  vec3 c = vec3(0.0f);
  c += texture_texel(t, f.i0).xyz * f.w0;
  c += texture_texel(t, f.i1).xyz * f.w1;
  c += texture_texel(t, f.i2).xyz * f.w2;
  c += texture_texel(t, f.i3).xyz * f.w3;
  return c;
}
float texture_alpha(uint index, vec2 uv) {
  GpuTexture t = Textures(g_scene.textures).v[index];
  TexelFootprint f = texel_footprint(uv, t.width, t.height);
  int c = t.has_alpha != 0u ? 3 : 0;
  float a = 0.0f;
  a += texture_texel(t, f.i0)[c] * f.w0;
  a += texture_texel(t, f.i1)[c] * f.w1;
  a += texture_texel(t, f.i2)[c] * f.w2;
  a += texture_texel(t, f.i3)[c] * f.w3;
  return a;
}

bool object_alpha_textured(GpuObject o) { return (o.flags & (kObjectAlphaMask | kObjectAlphaBlend)) != 0u; }

// SurfaceAlpha::opacity: a mask's 1 or 0, a blend texture's alpha.
float alpha_opacity(GpuObject o, vec2 uv) {
  float a = texture_alpha(o.alpha_texture, uv);
  if ((o.flags & kObjectAlphaMask) != 0u) return a >= o.alpha_cutoff ? 1.0f : 0.0f;
  return clamp(a, 0.0f, 1.0f);
}

// The opacity a shadow ray meets at barycentrics (b1, b2) of triangle prim of `object`
// (ray_tracer.cpp TransparencyData::opacity_at): material x triangle x alpha texture.
float surface_opacity(uint object, uint prim, float b1, float b2) {
  GpuObject o = g_objects.v[object];
  GpuMesh m = g_meshes.v[o.mesh];
  float a = o.opacity;
  if ((m.flags & kMeshTriangleOpacity) != 0u) a *= Floats(g_scene.triangle_opacity).v[m.first_triangle + prim];
  if (object_alpha_textured(o) && a > 0.0f) a *= alpha_opacity(o, mesh_uv(m, prim, b1, b2));
  return a;
}

// Whether a camera ray stops there (SurfaceAlpha::seen): a mask's holes and a blend surface
// below its cutoff let it through.
bool surface_seen(uint object, uint prim, float b1, float b2) {
  GpuObject o = g_objects.v[object];
  if (!object_alpha_textured(o)) return true;
  GpuMesh m = g_meshes.v[o.mesh];
  return texture_alpha(o.alpha_texture, mesh_uv(m, prim, b1, b2)) >= o.alpha_cutoff;
}

#endif
