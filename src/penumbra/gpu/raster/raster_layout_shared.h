// The GPU rasterizer's buffers and kernel parameters, byte by byte (gpu/raster/gpu_rasterizer.h;
// docs/raster.md, "The GPU rasterizer"). Common subset of C++ and GLSL (core/shader_compat.h),
// scalar block layout: the C++ structs are the GPU's, checked by the static_asserts below.
//
// A depth map is rendered in four kernels:
//   raster_setup      one thread per input triangle (SceneDesc::object_triangles numbers them in
//                     object order, then mesh order: gather_raster_triangles' order): transform to
//                     homogeneous texel space, cull, clip (near, far, guard band), fan, set up
//                     each fan triangle (raster/raster_shared.h) into GpuRasterTriangle[], and
//                     append one work item per 16 x 16-texel tile its texel box touches;
//   raster_fill_args  one thread: the indirect dispatch of raster_fill from the item count;
//   raster_fill       one thread per work item: the texel centres of its tile that its triangle
//                     covers, alpha looked up per fragment, atomicMin of (ordered z bits << 32 |
//                     input index) into the texel's key: the nearest surface, ties to the first
//                     triangle in input order, whatever order the GPU runs fragments in;
//   raster_resolve    one thread per texel: the key into the DepthMap planes (z, window depth,
//                     opacity, triangle) and the map's smallest z.
// Work items split big triangles (a ground plane under the whole map) into tiles, so no thread
// scans more than 256 texels. Both growing buffers count what they were asked to hold even past
// their capacity; the host reads the counts and renders again with larger buffers (never drops
// work).
#ifndef PENUMBRA_GPU_RASTER_RASTER_LAYOUT_SHARED_H
#define PENUMBRA_GPU_RASTER_RASTER_LAYOUT_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/raster/raster_shared.h"

PN_SHARED_BEGIN

// The edge of a work item's square tile, in texels.
PN_CONST int kRasterTileShift = 4;
PN_CONST int kRasterTile = 16;

// A set-up triangle, 88 bytes: bytes 0-79 the RasterSetup (raster/raster_shared.h; its `source`
// is the input triangle's index), 80-83 object (Scene::objects index), 84-87 prim (triangle of
// that object's mesh).
struct GpuRasterTriangle {
  RasterSetup s;
  uint object;
  uint prim;
};

// A work item, 8 bytes: a set-up triangle and one tile it touches (tile column in bits 0-15,
// tile row in bits 16-31).
struct GpuRasterItem {
  uint triangle;
  uint tile;
};

// The rasterizer's counters, 40 bytes:
//   bytes 0-3 setup_count: set-up triangles the input produced (written while below capacity)
//   bytes 4-7 z_min_bits: raster_order_bits of the smallest z in the map (0xffffffff: empty)
//   bytes 8-15 item_count: work items the written triangles produced (likewise)
//   bytes 16-27 fill_groups: the VkDispatchIndirectCommand of raster_fill (x, y, z groups)
//   bytes 28-31 (unused, 0)   32-39 fragments: covered texel centres visited (before the depth test)
struct GpuRasterState {
  uint setup_count;
  uint z_min_bits;
  uint64_t item_count;
  uint fill_groups_x;
  uint fill_groups_y;
  uint fill_groups_z;
  uint pad;
  uint64_t fragments;
};

// The depth map on the device: one plane per quantity, width x height texels each, row 0 at the
// top (raster/depth_map.h DepthMap, the same planes): keys (uint64: raster_depth_key, ~0 where
// empty), z (linear depth, +inf where empty), depth (window depth, +inf where empty), opacity
// (0 where empty), triangle (input index, kNoTriangle = 0xffffffff where empty). 24 bytes a texel.

// Per-object flags a mode may give the set-up (RasterSetupParams::object_flags, a uint per scene
// object): leave the object out; keep only its triangles facing the view's eye (as culling 1).
PN_CONST uint kRasterObjectSkip = 1u;
PN_CONST uint kRasterObjectFrontOnly = 2u;

// raster_setup.comp's push constants.
struct RasterSetupParams {
  uint64_t scene;      // SceneDesc
  uint64_t view;       // RasterView (raster/raster_shared.h)
  uint64_t state;      // GpuRasterState
  uint64_t triangles;  // GpuRasterTriangle[triangle_capacity]
  uint64_t items;      // GpuRasterItem[item_capacity]
  uint triangle_count;  // input triangles (SceneDesc::triangle_count)
  uint triangle_capacity;
  uint item_capacity;
  uint culling;      // 0 none, 1 keep triangles facing the light, 2 keep those facing away
  uint opaque_only;  // 1: skip semi-transparent triangles (RasterFilter::opaque_only)
  uint pad;
  uint64_t object_flags;  // uint per scene object (kRasterObject*), or 0: none
};

// raster_fill_args.comp's and raster_fill.comp's push constants.
struct RasterFillParams {
  uint64_t scene;
  uint64_t view;
  uint64_t state;
  uint64_t triangles;
  uint64_t items;
  uint64_t keys;  // uint64 per texel
  uint triangle_capacity;
  uint item_capacity;
};

// raster_resolve.comp's push constants.
struct RasterResolveParams {
  uint64_t scene;
  uint64_t view;
  uint64_t state;
  uint64_t keys;
  uint64_t z;
  uint64_t depth;
  uint64_t opacity;
  uint64_t triangle;
};

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::GpuRasterTriangle) == 88);
static_assert(sizeof(penumbra::shader::GpuRasterItem) == 8);
static_assert(sizeof(penumbra::shader::GpuRasterState) == 40);
static_assert(sizeof(penumbra::shader::RasterSetupParams) <= 128);
static_assert(sizeof(penumbra::shader::RasterFillParams) <= 128);
static_assert(sizeof(penumbra::shader::RasterResolveParams) <= 128);
#endif

#endif  // PENUMBRA_GPU_RASTER_RASTER_LAYOUT_SHARED_H
