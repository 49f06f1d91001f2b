// The occluders parker1998's single-sample search visits for one light (single_sample.cpp's
// prepare, shared with its GPU version single_sample_gpu.cpp): the light's diameter D, a frame
// centred on the light, the candidate triangles (every triangle, or with `contour` those along each
// opaque mesh's contour seen from the light centre, outer_objects.h) in a TriangleBvh in that
// frame with their planes, the analytic spheres, and per mesh the topology the `neighbours` option
// reads. docs/methods/single-sample.md.
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/scene/scene.h"
#include "penumbra/shadow/params.h"
#include "penumbra/shadow/single_sample/outer_objects.h"
#include "penumbra/shadow/single_sample/single_sample_shared.h"
#include "penumbra/trace/bvh.h"

namespace penumbra::single_sample {

using Plane = shader::SsPlane;  // unit normal n, dot(n, x) = d on the plane

// The parameters that decide the occluder set (single-sample's table).
struct OccluderSettings {
  bool equal_area = true;     // diameter=equal-area
  float diameter_scale = 1;   // diameter_scale
  bool contour_only = true;   // candidates=contour
  float band = 0;             // band
  bool ring = false;          // neighbours
  int leaf_size = 4;          // leaf_size
};
OccluderSettings occluder_settings(const ParamSet& p);

struct AnalyticSphere {
  SphereShape shape;
  uint32_t object;
  float opacity;
};

// Per scene object, with `neighbours`: its welded topology and its triangles' planes (light
// frame), also in the order of the vertex fans.
struct ObjectData {
  MeshTopology topology;
  std::vector<Plane> planes;      // per triangle, light frame
  std::vector<Plane> fan_planes;  // planes[topology.vertex_tris[i]]
  bool ring = false;   // receivers on it test the triangles around their own
};

struct Occluders {
  float diameter = 1;  // D: b(t) = D t / |l - o|
  // The search's frame: centred on the light, z toward the scene. Every shadow ray ends at its
  // origin and runs roughly along -z, and the contour triangles lie edge-on to the light, so
  // boxes aligned with this frame are thin across the rays.
  Frame light_frame;
  Vec3f light_pos;
  float scene_scale = 1;  // the scene's reach: the largest distance of its bounds' corners from the light
  float plane_eps = 1e-4f;  // two points closer than this to one plane lie in it
  TriangleBvh bvh;  // the candidates, light frame
  std::vector<Plane> planes;  // per BVH triangle: its plane
  std::vector<ObjectData> objects;
  std::vector<AnalyticSphere> spheres;
  size_t all_triangles = 0;  // of the scene's meshes

  Vec3f to_light_space(Vec3f x) const { return light_frame.to_local(x - light_pos); }
};

Occluders build_occluders(const Scene& scene, const AreaLight& light, const OccluderSettings& settings);

// The unit normal and offset of t's plane (zero and +inf for a triangle without area).
Plane triangle_plane(const BvhTriangle& t);

}  // namespace penumbra::single_sample
