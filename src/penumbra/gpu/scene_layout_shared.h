// The scene on the GPU, byte by byte (docs/gpu.md, "Memory layout"): written by GpuScene
// (gpu/gpu_scene.cpp) and read by every kernel through gpu/scene_access.glsl. One header in the
// common subset of C++ and GLSL (core/shader_compat.h), scalar block layout (no padding beyond
// what is written here): the C++ structs below are the GPU's, checked by static_asserts.
//
// Two levels (Aila & Laine 2009 traversal, tinybvh's node layout):
//   - bottom-level BVHs (BLAS): one per mesh that several objects place (SceneObject::
//     shared_mesh: the mesh once, in its own space), one per movable object (refit when it
//     moves), and one "world" BLAS over every other object's triangles in world space;
//   - instances: a BLAS and the transform that places it; the top-level BVH (TLAS) over the
//     instances' world boxes. A scene of one instance (nothing shared, nothing movable)
//     traverses its world BLAS directly (SceneDesc::root_is_blas).
// Every BVH is built by Embree's builder (rtcBuildBVH, SAH, binary, 1-4 triangles a leaf),
// then flattened into the node array; each triangle is referenced by exactly one leaf.
#ifndef PENUMBRA_GPU_SCENE_LAYOUT_SHARED_H
#define PENUMBRA_GPU_SCENE_LAYOUT_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// A BVH node: the boxes of both children (Aila & Laine 2009: a ray tests both before
// descending), 64 bytes.
//   bytes  0-11 lo0   12-15 child0   16-27 hi0   28-31 count0
//   bytes 32-43 lo1   44-47 child1   48-59 hi1   60-63 count1
// count == 0: child is a node index; count > 0: child is the first of `count` leaf items
// (GpuTriangle indices in a BLAS, GpuInstance indices in the TLAS). Indices are absolute
// (into SceneDesc::nodes, ::triangles, ::instances). Node 0 of each BVH is its root; a BVH of
// a single leaf has a root whose child1 is an empty leaf (count1 = 0, child1 = kEmptyChild,
// and a box that no ray enters).
struct GpuBvhNode {
  vec3 lo0;
  uint child0;
  vec3 hi0;
  uint count0;
  vec3 lo1;
  uint child1;
  vec3 hi1;
  uint count1;
};
PN_CONST uint kEmptyChild = 0xffffffffu;

// A triangle as traversal tests it, 48 bytes: its vertices (in its BLAS's space) and where it
// came from.
//   bytes 0-11 v0   12-15 prim   16-27 v1   28-31 object   32-43 v2   44-47 (unused, 0)
// prim: the triangle's index in its object's mesh (Hit::prim, ViewSample::prim). object: the
// index into Scene::objects, or kInstanceObject in a shared mesh's BLAS (the instance says).
struct GpuTriangle {
  vec3 v0;
  uint prim;
  vec3 v1;
  uint object;
  vec3 v2;
  uint pad;
};
PN_CONST uint kInstanceObject = 0xffffffffu;
// The object of a ray that hit nothing (trace/ray_tracer.h Hit::kMiss).
PN_CONST uint kMissObject = 0xffffffffu;

// An instance, 112 bytes: a BLAS placed in the world.
//   bytes  0-47  to_world: rows of the 3x4 affine matrix (object -> world), 3 x (vec3, float)
//   bytes 48-95  to_object: its inverse, likewise
//   bytes 96-99  root: the BLAS's root node   100-103 object: Scene::objects index, or
//                kInstanceObject for the world BLAS (each triangle says)
//   bytes 104-107 identity: 1 when both matrices are the identity (the world BLAS)
//   bytes 108-111 mirrored: 1 when to_world mirrors (det < 0). The world mesh then lists each
//                 triangle's vertices 1 and 2 swapped (SceneObject::shared_mesh), so a hit's
//                 barycentrics in the world mesh are (v, u) of those in the shared one.
struct GpuInstance {
  vec3 to_world_x;
  float to_world_tx;
  vec3 to_world_y;
  float to_world_ty;
  vec3 to_world_z;
  float to_world_tz;
  vec3 to_object_x;
  float to_object_tx;
  vec3 to_object_y;
  float to_object_ty;
  vec3 to_object_z;
  float to_object_tz;
  uint root;
  uint object;
  uint identity;
  uint mirrored;
};

// Per object (Scene::objects order), 64 bytes: its material and where its mesh lives.
//   bytes  0-11 albedo   12-15 opacity (Material::opacity)
//   bytes 16-19 mesh (GpuMesh index)   20-23 flags (kObject* bits)
//   bytes 24-27 albedo_texture   28-31 alpha_texture (GpuTexture indices, kNoTexture: none)
//   bytes 32-35 alpha_cutoff   36-39 instance (the GpuInstance that places it)
//   bytes 40-63 (unused, 0)
struct GpuObject {
  vec3 albedo;
  float opacity;
  uint mesh;
  uint flags;
  uint albedo_texture;
  uint alpha_texture;
  float alpha_cutoff;
  uint instance;
  uint pad0;
  uint pad1;
  uint pad2;
  uint pad3;
  uint pad4;
  uint pad5;
};
PN_CONST uint kNoTexture = 0xffffffffu;
PN_CONST uint kObjectTwoSided = 1u;        // Material::two_sided
PN_CONST uint kObjectClosed = 2u;          // SceneObject::closed
PN_CONST uint kObjectAlphaMask = 4u;       // alpha_texture is a mask (AlphaMode::Mask)
PN_CONST uint kObjectAlphaBlend = 8u;      // alpha_texture is fractional (AlphaMode::Blend)
PN_CONST uint kObjectSemiTransparent = 16u;  // Material::semi_transparent() or per-triangle opacity < 1

// Per mesh, 32 bytes: a range of the vertex arrays (positions, normals, uvs: one entry per
// vertex) and of the triangle arrays (indices: 3 per triangle, relative to first_vertex;
// triangle_opacity: one per triangle).
//   bytes 0-3 first_vertex   4-7 vertex_count   8-11 first_triangle   12-15 triangle_count
//   bytes 16-19 flags (kMesh* bits)   20-31 (unused, 0)
struct GpuMesh {
  uint first_vertex;
  uint vertex_count;
  uint first_triangle;
  uint triangle_count;
  uint flags;
  uint pad0;
  uint pad1;
  uint pad2;
};
PN_CONST uint kMeshNormals = 1u;          // normals are the mesh's (else flat shading)
PN_CONST uint kMeshUvs = 2u;              // uvs are the mesh's
PN_CONST uint kMeshTriangleOpacity = 4u;  // triangle_opacity holds values below 1

// Per texture, 16 bytes: `width` x `height` texels of 4 linear floats (Texture::rgba, row 0 at
// the top) from `first_texel` of the texel array.
struct GpuTexture {
  uint first_texel;
  int width;
  int height;
  uint has_alpha;
};

// Where everything is: one 128-byte block whose device address every kernel that reads the
// scene takes (push constant `scene`).
struct SceneDesc {
  uint64_t nodes;             // GpuBvhNode[]
  uint64_t triangles;         // GpuTriangle[]
  uint64_t instances;         // GpuInstance[]
  uint64_t objects;           // GpuObject[]
  uint64_t meshes;            // GpuMesh[]
  uint64_t positions;         // vec3[] per vertex, in the mesh's space
  uint64_t normals;           // vec3[] per vertex
  uint64_t uvs;               // vec2[] per vertex
  uint64_t indices;           // uint[3] per triangle
  uint64_t triangle_opacity;  // float per triangle
  uint64_t textures;          // GpuTexture[]
  uint64_t texels;            // vec4[]
  uint root;                  // the TLAS's root node, or the only BLAS's (root_is_blas)
  uint root_is_blas;          // 1: one instance with the identity, traversed without the TLAS
  uint has_transparency;      // 1: some caster is semi-transparent or alpha-textured
  uint object_count;
  // uint[object_count + 1]: the first triangle of each object in the scene's numbering (object
  // order, then mesh order: raster_triangle.h gather_raster_triangles'), then the total. The GPU
  // rasterizer maps its input triangle index back to (object, prim) through it.
  uint64_t object_triangles;
  uint triangle_count;        // the total
  uint pad;
};

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::GpuBvhNode) == 64);
static_assert(sizeof(penumbra::shader::GpuTriangle) == 48);
static_assert(sizeof(penumbra::shader::GpuInstance) == 112);
static_assert(sizeof(penumbra::shader::GpuObject) == 64);
static_assert(sizeof(penumbra::shader::GpuMesh) == 32);
static_assert(sizeof(penumbra::shader::GpuTexture) == 16);
static_assert(sizeof(penumbra::shader::SceneDesc) == 128);
#endif

#endif  // PENUMBRA_GPU_SCENE_LAYOUT_SHARED_H
