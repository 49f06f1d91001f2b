#include "penumbra/gpu/gpu_scene.h"

#include <algorithm>
#include <map>

#include "penumbra/core/error.h"
#include "penumbra/core/timer.h"

namespace penumbra::gpu {
namespace {

using shader::GpuInstance;
using shader::GpuMesh;
using shader::GpuObject;
using shader::GpuTexture;
using shader::GpuTriangle;

GpuInstance identity_instance(uint32_t root, uint32_t object) {
  GpuInstance in{};
  in.to_world_x = in.to_object_x = Vec3f(1, 0, 0);
  in.to_world_y = in.to_object_y = Vec3f(0, 1, 0);
  in.to_world_z = in.to_object_z = Vec3f(0, 0, 1);
  in.root = root;
  in.object = object;
  in.identity = 1;
  return in;
}

Bounds3f triangle_box(const GpuTriangle& t) {
  Bounds3f b;
  b.extend(t.v0);
  b.extend(t.v1);
  b.extend(t.v2);
  return b;
}

// The box of a BVH's root (both children).
Bounds3f root_box(const shader::GpuBvhNode& n) {
  Bounds3f b;
  if (n.child0 != shader::kEmptyChild) b.extend(Bounds3f{n.lo0, n.hi0});
  if (n.child1 != shader::kEmptyChild) b.extend(Bounds3f{n.lo1, n.hi1});
  return b;
}

// Moves relative child indices to absolute ones (a node child by node_offset, a leaf's first
// item by item_offset).
void offset_node(shader::GpuBvhNode& n, uint32_t node_offset, uint32_t item_offset) {
  auto fix = [&](uint32_t& child, uint32_t count) {
    if (child == shader::kEmptyChild) return;
    child += count > 0 ? item_offset : node_offset;
  };
  fix(n.child0, n.count0);
  fix(n.child1, n.count1);
}

uint32_t object_flags(const SceneObject& o) {
  const Material& m = o.material;
  uint32_t f = 0;
  if (m.two_sided) f |= shader::kObjectTwoSided;
  if (o.closed) f |= shader::kObjectClosed;
  if (m.alpha.active()) f |= m.alpha.mode == AlphaMode::Mask ? shader::kObjectAlphaMask : shader::kObjectAlphaBlend;
  if (o.semi_transparent()) f |= shader::kObjectSemiTransparent;
  return f;
}

}  // namespace

GpuScene::GpuScene(Device& device, const Scene& scene, std::span<const uint32_t> movable) : device_(&device) {
  movable_.assign(scene.objects.size(), false);
  for (uint32_t o : movable) {
    if (o >= scene.objects.size()) throw Error("GpuScene: movable object {} of {}", o, scene.objects.size());
    movable_[o] = true;
  }
  build(scene);
}

std::vector<GpuTriangle> GpuScene::blas_triangles(const Scene& scene, const Blas& b) const {
  std::vector<GpuTriangle> tris;
  auto add = [&](const TriangleMesh& m, uint32_t object) {
    const size_t n = m.triangle_count();
    for (size_t t = 0; t < n; ++t) {
      GpuTriangle g{};
      g.v0 = m.vertex(t, 0);
      g.v1 = m.vertex(t, 1);
      g.v2 = m.vertex(t, 2);
      g.prim = static_cast<uint32_t>(t);
      g.object = object;
      tris.push_back(g);
    }
  };
  if (b.shared) {
    add(*b.shared, shader::kInstanceObject);  // each instance names its object
    return tris;
  }
  for (uint32_t o : b.objects) add(scene.objects[o].mesh, o);
  return tris;
}

shader::GpuInstance GpuScene::placed_instance(const SceneObject& object, uint32_t o) const {
  const Mat4& m = object.placement;
  const Mat4 inv = m.inverse();
  GpuInstance in{};
  in.to_world_x = {m.m[0][0], m.m[0][1], m.m[0][2]}, in.to_world_tx = m.m[0][3];
  in.to_world_y = {m.m[1][0], m.m[1][1], m.m[1][2]}, in.to_world_ty = m.m[1][3];
  in.to_world_z = {m.m[2][0], m.m[2][1], m.m[2][2]}, in.to_world_tz = m.m[2][3];
  in.to_object_x = {inv.m[0][0], inv.m[0][1], inv.m[0][2]}, in.to_object_tx = inv.m[0][3];
  in.to_object_y = {inv.m[1][0], inv.m[1][1], inv.m[1][2]}, in.to_object_ty = inv.m[1][3];
  in.to_object_z = {inv.m[2][0], inv.m[2][1], inv.m[2][2]}, in.to_object_tz = inv.m[2][3];
  const Vec3f a = in.to_world_x, b = in.to_world_y, c = in.to_world_z;
  in.mirrored = dot(a, cross(b, c)) < 0 ? 1u : 0u;
  in.object = o;
  in.identity = 0;
  return in;
}

void GpuScene::build(const Scene& scene) {
  Timer timer;
  const size_t objects = scene.objects.size();
  // Which BLAS holds each object: a shared mesh's (one BLAS per mesh, an instance per object
  // placing it), a movable object's own, else the one world BLAS.
  blas_.clear();
  Blas world;
  std::map<const TriangleMesh*, uint32_t> shared_blas;
  for (uint32_t o = 0; o < objects; ++o) {
    const SceneObject& obj = scene.objects[o];
    if (obj.shared_mesh) continue;
    if (!movable_[o]) world.objects.push_back(o);
  }
  if (!world.objects.empty() || objects == 0) blas_.push_back(std::move(world));
  for (uint32_t o = 0; o < objects; ++o) {
    const SceneObject& obj = scene.objects[o];
    if (obj.shared_mesh) {
      auto [it, added] = shared_blas.emplace(obj.shared_mesh.get(), static_cast<uint32_t>(blas_.size()));
      if (added) {
        Blas b;
        b.shared = obj.shared_mesh.get();
        blas_.push_back(std::move(b));
      }
      blas_[it->second].objects.push_back(o);
    } else if (movable_[o]) {
      blas_.push_back(Blas{{o}});
    }
  }

  // Meshes: an object's own in world space (its vertices as the CPU holds them), a shared mesh
  // once in its own space.
  std::vector<GpuMesh> meshes;
  std::vector<Vec3f> positions, normals;
  std::vector<Vec2f> uvs;
  std::vector<uint32_t> indices;
  std::vector<float> tri_opacity;
  std::vector<GpuObject> gpu_objects;
  std::vector<GpuTexture> textures;
  std::vector<float> texels;
  std::map<const Texture*, uint32_t> texture_index;
  std::map<const TriangleMesh*, uint32_t> shared_mesh_index;
  auto add_texture = [&](const std::shared_ptr<const Texture>& t) -> uint32_t {
    if (!t) return shader::kNoTexture;
    auto it = texture_index.find(t.get());
    if (it != texture_index.end()) return it->second;
    GpuTexture g{static_cast<uint32_t>(texels.size() / 4), t->width(), t->height(), t->has_alpha() ? 1u : 0u};
    texels.insert(texels.end(), t->rgba().begin(), t->rgba().end());
    textures.push_back(g);
    return texture_index[t.get()] = static_cast<uint32_t>(textures.size() - 1);
  };
  auto add_mesh = [&](const TriangleMesh& m) {
    GpuMesh gm{};
    gm.first_vertex = static_cast<uint32_t>(positions.size());
    gm.vertex_count = static_cast<uint32_t>(m.positions.size());
    gm.first_triangle = static_cast<uint32_t>(indices.size() / 3);
    gm.triangle_count = static_cast<uint32_t>(m.triangle_count());
    positions.insert(positions.end(), m.positions.begin(), m.positions.end());
    if (m.normals.size() == m.positions.size()) {
      gm.flags |= shader::kMeshNormals;
      normals.insert(normals.end(), m.normals.begin(), m.normals.end());
    } else {
      normals.resize(positions.size(), Vec3f(0.0f));
    }
    if (m.uvs.size() == m.positions.size()) {
      gm.flags |= shader::kMeshUvs;
      uvs.insert(uvs.end(), m.uvs.begin(), m.uvs.end());
    } else {
      uvs.resize(positions.size(), Vec2f(0, 0));
    }
    indices.insert(indices.end(), m.indices.begin(), m.indices.end());
    if (m.triangle_opacity.size() == m.triangle_count()) {
      gm.flags |= shader::kMeshTriangleOpacity;
      tri_opacity.insert(tri_opacity.end(), m.triangle_opacity.begin(), m.triangle_opacity.end());
    } else {
      tri_opacity.resize(indices.size() / 3, 1.0f);
    }
    meshes.push_back(gm);
    return static_cast<uint32_t>(meshes.size() - 1);
  };
  has_transparency_ = false;
  object_mesh_.assign(objects, 0);
  for (uint32_t o = 0; o < objects; ++o) {
    const SceneObject& obj = scene.objects[o];
    uint32_t mesh = 0;
    if (obj.shared_mesh) {
      auto it = shared_mesh_index.find(obj.shared_mesh.get());
      mesh = it != shared_mesh_index.end() ? it->second : (shared_mesh_index[obj.shared_mesh.get()] = add_mesh(*obj.shared_mesh));
    } else {
      mesh = add_mesh(obj.mesh);
    }
    object_mesh_[o] = mesh;
    GpuObject g{};
    g.albedo = obj.material.albedo;
    g.opacity = obj.material.opacity;
    g.mesh = mesh;
    g.flags = object_flags(obj);
    g.albedo_texture = add_texture(obj.material.albedo_texture);
    g.alpha_texture = obj.material.alpha.active() ? add_texture(obj.material.alpha.texture) : shader::kNoTexture;
    g.alpha_cutoff = obj.material.alpha.cutoff;
    gpu_objects.push_back(g);
    if (g.flags & (shader::kObjectSemiTransparent | shader::kObjectAlphaMask | shader::kObjectAlphaBlend))
      has_transparency_ = true;
  }

  // The BLASes, their instances and the TLAS.
  for (Blas& b : blas_) {
    const std::vector<GpuTriangle> tris = blas_triangles(scene, b);
    std::vector<Bounds3f> boxes(tris.size());
    for (size_t i = 0; i < tris.size(); ++i) boxes[i] = triangle_box(tris[i]);
    b.bvh = build_bvh(boxes, 4);
  }
  object_instance_.assign(objects, 0);
  instances_.clear();
  instance_blas_.clear();
  for (uint32_t i = 0; i < blas_.size(); ++i) {
    if (blas_[i].shared) {
      for (uint32_t o : blas_[i].objects) {
        object_instance_[o] = static_cast<uint32_t>(instances_.size());
        instances_.push_back(placed_instance(scene.objects[o], o));
        instance_blas_.push_back(i);
      }
      continue;
    }
    // World-space BLASes name each triangle's object themselves.
    for (uint32_t o : blas_[i].objects) object_instance_[o] = static_cast<uint32_t>(instances_.size());
    instances_.push_back(identity_instance(0, shader::kInstanceObject));
    instance_blas_.push_back(i);
  }
  for (uint32_t o = 0; o < objects; ++o) gpu_objects[o].instance = object_instance_[o];

  // Upload the meshes, objects and textures; then the BVHs.
  Device& d = *device_;
  positions_ = make_buffer<Vec3f>(d, positions, "the scene's vertex positions");
  normals_ = make_buffer<Vec3f>(d, normals, "the scene's vertex normals");
  uvs_ = make_buffer<Vec2f>(d, uvs, "the scene's texture coordinates");
  indices_ = make_buffer<uint32_t>(d, indices, "the scene's triangle indices");
  triangle_opacity_ = make_buffer<float>(d, tri_opacity, "the scene's triangle opacities");
  meshes_ = make_buffer<GpuMesh>(d, meshes, "the scene's mesh table");
  mesh_records_ = std::move(meshes);
  objects_ = make_buffer<GpuObject>(d, gpu_objects, "the scene's objects");
  textures_ = make_buffer<GpuTexture>(d, textures, "the scene's texture table");
  texels_ = make_buffer<float>(d, texels, "the scene's textures");
  // Each object's first triangle in the scene's numbering (the rasterizer's input order).
  std::vector<uint32_t> object_triangles(objects + 1, 0);
  for (uint32_t o = 0; o < objects; ++o)
    object_triangles[o + 1] = object_triangles[o] + static_cast<uint32_t>(scene.objects[o].mesh.triangle_count());
  object_triangles_ = make_buffer<uint32_t>(d, object_triangles, "the scene's triangle numbering");
  desc_data_.object_triangles = object_triangles_.address();
  desc_data_.triangle_count = object_triangles[objects];
  desc_data_.object_count = static_cast<uint32_t>(objects);
  desc_data_.has_transparency = has_transparency_ ? 1u : 0u;
  upload_bvhs();
  build_tlas(scene);
  build_ms_ = timer.elapsed_ms();
}

void GpuScene::upload_bvhs() {
  uint32_t node_offset = 0, triangle_offset = 0;
  for (Blas& b : blas_) {
    b.node_offset = node_offset;
    b.triangle_offset = triangle_offset;
    node_offset += static_cast<uint32_t>(b.bvh.nodes.size());
    triangle_offset += static_cast<uint32_t>(b.bvh.order.size());
  }
  // Room for the TLAS after the BLASes: one node per instance at most.
  const size_t tlas_nodes = std::max<size_t>(1, instances_.size());
  nodes_ = Buffer(*device_, (node_offset + tlas_nodes) * sizeof(shader::GpuBvhNode), "the scene's BVH nodes");
  triangles_ = Buffer(*device_, std::max<uint64_t>(1, triangle_offset) * sizeof(GpuTriangle), "the scene's BVH triangles");
  desc_data_.nodes = nodes_.address();
  desc_data_.triangles = triangles_.address();
}

void GpuScene::build_tlas(const Scene& scene) {
  // Each BLAS's nodes (offset) and triangles (in leaf order) into their ranges.
  for (size_t i = 0; i < blas_.size(); ++i) {
    Blas& b = blas_[i];
    std::vector<shader::GpuBvhNode> nodes = b.bvh.nodes;
    for (auto& n : nodes) offset_node(n, b.node_offset, b.triangle_offset);
    nodes_.upload<shader::GpuBvhNode>(nodes, b.node_offset * sizeof(shader::GpuBvhNode));
    const std::vector<GpuTriangle> tris = blas_triangles(scene, b);
    std::vector<GpuTriangle> ordered(b.bvh.order.size());
    for (size_t k = 0; k < ordered.size(); ++k) ordered[k] = tris[b.bvh.order[k]];
    triangles_.upload<GpuTriangle>(ordered, b.triangle_offset * sizeof(GpuTriangle));
  }
  // The TLAS over the instances' world boxes, one instance a leaf (its box is the instance's).
  std::vector<Bounds3f> boxes(instances_.size());
  for (size_t i = 0; i < instances_.size(); ++i) {
    GpuInstance& in = instances_[i];
    const Blas& b = blas_[instance_blas_[i]];
    in.root = b.node_offset;
    const Bounds3f local = root_box(b.bvh.nodes[0]);
    if (in.identity || local.empty()) {
      boxes[i] = local;
      continue;
    }
    for (int c = 0; c < 8; ++c) {
      const Vec3f q = local.corner(c);
      boxes[i].extend({dot(in.to_world_x, q) + in.to_world_tx, dot(in.to_world_y, q) + in.to_world_ty,
                       dot(in.to_world_z, q) + in.to_world_tz});
    }
  }
  tlas_ = build_bvh(boxes, 1);
  const uint32_t tlas_offset = blas_.empty() ? 0 : blas_.back().node_offset + static_cast<uint32_t>(blas_.back().bvh.nodes.size());
  std::vector<shader::GpuBvhNode> tnodes = tlas_.nodes;
  for (auto& n : tnodes) {
    // Leaf items are instances: the leaf's one item is tlas_.order[child].
    if (n.count0 > 0) n.child0 = tlas_.order[n.child0];
    if (n.count1 > 0) n.child1 = tlas_.order[n.child1];
    offset_node(n, tlas_offset, 0);
  }
  nodes_.upload<shader::GpuBvhNode>(tnodes, tlas_offset * sizeof(shader::GpuBvhNode));
  instances_buf_ = make_buffer<GpuInstance>(*device_, instances_, "the scene's instances");
  desc_data_.instances = instances_buf_.address();
  const bool single = instances_.size() == 1 && instances_[0].identity;
  desc_data_.root_is_blas = single ? 1u : 0u;
  desc_data_.root = single ? instances_[0].root : tlas_offset;
  desc_data_.objects = objects_.address();
  desc_data_.meshes = meshes_.address();
  desc_data_.positions = positions_.address();
  desc_data_.normals = normals_.address();
  desc_data_.uvs = uvs_.address();
  desc_data_.indices = indices_.address();
  desc_data_.triangle_opacity = triangle_opacity_.address();
  desc_data_.textures = textures_.address();
  desc_data_.texels = texels_.address();
  if (desc_.empty()) desc_ = Buffer(*device_, sizeof(shader::SceneDesc), "the scene's descriptor");
  desc_.upload(&desc_data_, sizeof(desc_data_));
}

void GpuScene::update_objects(const Scene& scene, std::span<const uint32_t> objects) {
  if (objects.empty()) return;
  if (scene.objects.size() != movable_.size()) {
    build(scene);
    return;
  }
  Timer timer;
  for (uint32_t o : objects) {
    if (o >= movable_.size()) throw Error("GpuScene::update_objects: no object {}", o);
    const SceneObject& obj = scene.objects[o];
    GpuInstance& in = instances_[object_instance_[o]];
    Blas& b = blas_[instance_blas_[object_instance_[o]]];
    if (b.shared) {
      // A placement of a shared mesh: only its instance moves (the same mesh, or start over).
      if (obj.shared_mesh.get() != b.shared) {
        build(scene);
        return;
      }
      in = placed_instance(obj, o);
      continue;
    }
    const TriangleMesh& m = obj.mesh;
    const GpuMesh& mesh = mesh_records_[object_mesh_[o]];
    // Only an object with a BLAS of its own can be refit; the same triangles, or start over.
    if (!movable_[o] || obj.shared_mesh || m.triangle_count() != b.bvh.order.size() ||
        mesh.vertex_count != m.positions.size()) {
      build(scene);
      return;
    }
    // The object's vertices (the camera pass reads them) and its BLAS refit.
    positions_.upload<Vec3f>(m.positions, mesh.first_vertex * sizeof(Vec3f));
    if (mesh.flags & shader::kMeshNormals) normals_.upload<Vec3f>(m.normals, mesh.first_vertex * sizeof(Vec3f));
    const std::vector<GpuTriangle> tris = blas_triangles(scene, b);
    std::vector<Bounds3f> boxes(tris.size());
    for (size_t i = 0; i < tris.size(); ++i) boxes[i] = triangle_box(tris[i]);
    refit_bvh(b.bvh, boxes);
  }
  build_tlas(scene);
  ++refits_;
  build_ms_ = timer.elapsed_ms();
}

uint64_t GpuScene::device_bytes() const {
  uint64_t total = 0;
  for (const Buffer* b : {&nodes_, &triangles_, &instances_buf_, &objects_, &meshes_, &positions_, &normals_, &uvs_,
                          &indices_, &triangle_opacity_, &textures_, &texels_, &object_triangles_, &desc_})
    total += b->bytes();
  return total;
}

uint64_t GpuScene::estimate_bytes(const Scene& scene) {
  uint64_t triangles = 0, vertices = 0, texels = 0;
  std::map<const Texture*, uint64_t> textures;
  std::map<const TriangleMesh*, bool> shared;
  for (const SceneObject& o : scene.objects) {
    const TriangleMesh* m = o.shared_mesh ? o.shared_mesh.get() : &o.mesh;
    if (o.shared_mesh && !shared.emplace(m, true).second) continue;  // a shared mesh once
    triangles += m->triangle_count();
    vertices += m->positions.size();
  }
  for (const SceneObject& o : scene.objects)
    for (const auto& t : {o.material.albedo_texture, o.material.alpha.texture})
      if (t) textures[t.get()] = static_cast<uint64_t>(t->width()) * t->height();
  for (const auto& [t, n] : textures) texels += n;
  const uint64_t objects = scene.objects.size();
  return triangles * (sizeof(shader::GpuBvhNode) + sizeof(GpuTriangle) + 3 * sizeof(uint32_t) + sizeof(float)) +
         vertices * (2 * sizeof(Vec3f) + sizeof(Vec2f)) + objects * (sizeof(GpuObject) + sizeof(GpuMesh) + sizeof(GpuInstance) +
                                                                      2 * sizeof(shader::GpuBvhNode)) +
         texels * 16 + (objects + 1) * sizeof(uint32_t) + sizeof(shader::SceneDesc);
}

}  // namespace penumbra::gpu
