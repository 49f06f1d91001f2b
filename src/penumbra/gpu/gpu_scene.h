// A Scene uploaded to a GPU (docs/gpu.md): meshes, materials, textures and the two-level BVH in
// the layout of gpu/scene_layout_shared.h, read by kernels through gpu/scene_access.glsl and
// traversed by gpu/bvh_traverse.glsl. Uploaded once per scene; objects that move are refit.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "penumbra/gpu/buffer.h"
#include "penumbra/gpu/bvh_builder.h"
#include "penumbra/gpu/device.h"
#include "penumbra/scene/scene.h"

namespace penumbra::gpu {

class GpuScene {
 public:
  // Builds the BVHs (Embree's builder) and uploads everything. `movable` objects (an animated
  // scene's object tracks) get a BLAS each, so moving them is a refit.
  GpuScene(Device& device, const Scene& scene, std::span<const uint32_t> movable = {});

  // The device address of the SceneDesc block (what kernels take as `scene`).
  uint64_t address() const { return desc_.address(); }
  Device& device() const { return *device_; }

  // New vertex positions for `objects` (the same triangles, as an animated transform gives);
  // `scene` is the scene from now on. Movable objects' BLASes are refit and re-uploaded and the
  // TLAS rebuilt; any other object makes the whole scene upload again.
  void update_objects(const Scene& scene, std::span<const uint32_t> objects);

  uint64_t device_bytes() const;  // what the buffers hold
  // What a GpuScene of `scene` will hold on the device, before it exists (the up-front memory
  // check): BVH nodes at one per triangle (the most a binary BVH with a leaf per item needs)
  // and every per-vertex and per-triangle array.
  static uint64_t estimate_bytes(const Scene& scene);

  double build_ms() const { return build_ms_; }
  int refits() const { return refits_; }
  int blas_count() const { return static_cast<int>(blas_.size()); }
  size_t instance_count() const { return instances_.size(); }
  // Triangles of all objects (SceneDesc::triangle_count): the GPU rasterizer's input.
  uint64_t triangle_count() const { return desc_data_.triangle_count; }
  bool has_transparency() const { return has_transparency_; }

 private:
  // A bottom-level BVH: which objects' triangles it holds, in which space.
  struct Blas {
    // World space: these objects' triangles, in object order, then mesh order. Shared: the
    // objects that place `shared` (one instance each).
    std::vector<uint32_t> objects;
    const TriangleMesh* shared = nullptr;  // a shared mesh, in its own space (SceneObject::shared_mesh)
    FlatBvh bvh;
    uint32_t node_offset = 0, triangle_offset = 0;  // where its nodes and triangles start
  };
  void build(const Scene& scene);
  void upload_bvhs();
  void build_tlas(const Scene& scene);
  // The instance record of object o placing a shared mesh (its placement and inverse).
  shader::GpuInstance placed_instance(const SceneObject& object, uint32_t o) const;
  std::vector<shader::GpuTriangle> blas_triangles(const Scene& scene, const Blas& b) const;

  Device* device_;
  std::vector<bool> movable_;
  std::vector<Blas> blas_;
  std::vector<shader::GpuInstance> instances_;  // per world-space BLAS, and per object placing a shared mesh
  std::vector<uint32_t> instance_blas_;         // per instance: its BLAS
  std::vector<uint32_t> object_instance_;       // per object: its instance
  std::vector<shader::GpuMesh> mesh_records_;   // what meshes_ holds
  std::vector<uint32_t> object_mesh_;           // per object: its GpuMesh
  FlatBvh tlas_;
  bool has_transparency_ = false;
  double build_ms_ = 0;
  int refits_ = 0;
  // Device buffers (SceneDesc's arrays).
  Buffer nodes_, triangles_, instances_buf_, objects_, meshes_, positions_, normals_, uvs_, indices_,
      triangle_opacity_, textures_, texels_, object_triangles_, desc_;
  shader::SceneDesc desc_data_{};
};

}  // namespace penumbra::gpu
