// The reference depth images of coherence-based ray tracing (agrawala2000 §5, §5.1): a few
// shadow maps of the scene (by default from the 4 corners of a rect light), each with the
// floors-and-walls reconstruction of its surfaces, the min/max quadtree the walk descends
// (raster/depth_image_walk.h) and the hierarchical connectedness quadtree (§5.1.1).
//
// Floors and walls (§5.1): texel i holds a floor, a plane parallel to the image plane at
// its sampled depth z_i pushed back by the shadow bias; two adjacent texels are connected
// by a wall when their depths differ by at most the gap bias. Both biases are given in
// texels: multiples of the texel's world size at its depth (LightView::texel_world_size),
// so they follow the map's resolution and perspective; a slope-scaled part of the shadow
// bias (the depth step to the neighbours) keeps surfaces seen at grazing angles from
// shadowing themselves. All depths the walk compares are
// window depths (affine along an epipolar segment; raster.md conventions).
//
// The pyramid's texel range spans the texel's floor and the walls to its connected
// neighbours, so a ray crossing a wall at a texel's edge overlaps the texel's range there
// and reaches the exact test.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "penumbra/raster/light_view.h"
#include "penumbra/raster/minmax_pyramid.h"
#include "penumbra/raster/raster_triangle.h"
#include "penumbra/shadow/shadow_region.h"

namespace penumbra {

struct Scene;
struct AreaLight;

namespace coherent_rt {

// Neighbour bits of ReferenceImage::links: bit k set when the texel is connected to
// neighbour (x + kNeighbourDx[k], y + kNeighbourDy[k]).
inline constexpr int kNeighbourDx[8] = {1, -1, 0, 0, 1, -1, 1, -1};
inline constexpr int kNeighbourDy[8] = {0, 0, 1, -1, 1, 1, -1, -1};
// The bit of the neighbour at offset (dx, dy) in {-1, 0, 1}^2 \ {(0, 0)}.
inline int neighbour_bit(int dx, int dy) {
  static constexpr int8_t table[3][3] = {{7, 3, 6}, {1, -1, 0}, {5, 2, 4}};  // [dy + 1][dx + 1]
  return table[dy + 1][dx + 1];
}

struct ReferenceImageOptions {
  int resolution = 2048;     // texels along the longer side of each view
  float gap_bias = 4.0f;     // texels: adjacent depths within gap_bias * texel size are connected
  float shadow_bias = 1.5f;  // texels: floors of closed objects pushed back by shadow_bias * texel size
  float open_shadow_bias = 0.5f;  // texels: floors of open surfaces (SceneObject::closed false)
  // plus slope_bias times the largest depth step to a connected edge neighbour
  float slope_bias = 0.25f;
};

// One reference view.
struct ReferenceImage {
  LightView view;
  int width = 0, height = 0;
  std::vector<float> floor;    // window depth of the biased floor; +inf where empty
  std::vector<uint8_t> links;  // connected neighbours (bits as above)
  MinMaxPyramid pyramid;       // over the floors and walls (window depth)
  // Connectedness quadtree (§5.1.1): connected[l][node] = 1 when every texel under the node
  // holds a surface and every pair of edge-adjacent texels under it is connected. Level 0
  // (a texel is connected to itself) is floor != +inf.
  std::vector<std::vector<uint8_t>> connected;

  bool covered(int x, int y) const { return floor[static_cast<size_t>(y) * width + x] < kInfinity; }
  float floor_at(int x, int y) const { return floor[static_cast<size_t>(y) * width + x]; }
  uint8_t links_at(int x, int y) const { return links[static_cast<size_t>(y) * width + x]; }
  bool node_connected(int level, int x, int y) const {
    return connected[level][static_cast<size_t>(y) * pyramid.width(level) + x] != 0;
  }
  size_t memory_bytes() const;
  // What an image of w x h texels holds (memory_bytes before it exists), and what building
  // one holds besides (its depth map and the texel ranges; the rasterizer's scratch on top).
  static uint64_t bytes(int w, int h);
  static uint64_t build_scratch_bytes(int w, int h);
};

// The view points on the light: "corners" (the 4 corners of a rect light, or 4 points on a
// disk's rim along its axes), "center", or "corners+center"; and how many that makes.
std::vector<Vec3f> view_points(const AreaLight& light, const std::string& views);
int view_point_count(const std::string& views);

// A view from `eye` on the light, looking along the light's normal, containing `region`
// (fit_shadow_region: everything that can cast or receive a shadow from `light`) widened
// for the eye's offset from the light's centre, `resolution` texels along its longer side.
// Throws if the region is empty. Where it is (no caster can shadow a receiver: a lone ground
// under the light, a light facing away from the scene) the method builds no image and every ray
// is unblocked: crt_trace with no map blocks nothing.
LightView reference_view(const ShadowRegion& region, const AreaLight& light, Vec3f eye, int resolution);
// The same for the scene's region.
LightView reference_view(const Scene& scene, const AreaLight& light, Vec3f eye, int resolution);

struct BuildTimes {
  double raster_ms = 0, floors_ms = 0, pyramid_ms = 0;
};

// Rasterizes `tris` into `view` and builds floors, walls, the pyramid and the connectedness
// quadtree. object_closed: per scene object (RasterTriangle::object), 1 when it is closed
// (SceneObject::closed; objects_closed below); shorter or empty: open.
ReferenceImage build_reference_image(RasterTriangleView tris, const LightView& view,
                                     const ReferenceImageOptions& options, std::span<const uint8_t> object_closed,
                                     BuildTimes* times = nullptr);
// SceneObject::closed of every object of `scene`, as build_reference_image takes it.
std::vector<uint8_t> objects_closed(const Scene& scene);

}  // namespace coherent_rt
}  // namespace penumbra
