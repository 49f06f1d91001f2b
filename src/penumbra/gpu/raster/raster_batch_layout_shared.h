// The GPU rasterizer's batch mode, byte by byte (gpu/raster/gpu_batch_rasterizer.h): many views'
// depth maps of one scene in one pass, e.g. one per light sample (`multi-view-sm`, `lam`). Common
// subset of C++ and GLSL (core/shader_compat.h), scalar block layout. Each view's map is the one
// mode's map (raster_layout_shared.h) texel for texel: the same stages, the same functions
// (gpu/raster/raster_stages.glsl), only with a view index carried along:
//   raster_batch_setup    one thread per (input triangle, view), the views of a triangle side by
//                         side (thread = triangle x views + view): raster_polygon, the fan, one
//                         GpuRasterBatchTriangle each and one work item per 16 x 16-texel tile of
//                         its view; optionally culling the triangles of closed objects that face
//                         away from every point of a polygon (an area light's outline), and the
//                         objects a view's flags skip (per-view caster culling);
//   raster_fill_args      (the one mode's kernel) the indirect dispatch of the fill;
//   raster_batch_fill     one thread per work item: raster_scan_tile (raster_scan.glsl) into its view's keys;
//   raster_batch_resolve  (optional) one thread per texel of all views: the key into the z and
//                         opacity planes (what shadow_map_shared.h's lookups read).
// The keys of view i are texels [first_texel, first_texel + width x height) of one uint64 buffer
// (raster_depth_key; ~0 where empty), row-major: a method may read depths straight from them
// (raster_key_depth). Both growing buffers count past their capacity (GpuRasterState, the one
// mode's counters); the host grows them and renders the batch again.
#ifndef PENUMBRA_GPU_RASTER_RASTER_BATCH_LAYOUT_SHARED_H
#define PENUMBRA_GPU_RASTER_RASTER_BATCH_LAYOUT_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/gpu/raster/raster_layout_shared.h"

PN_SHARED_BEGIN

// One view of a batch, 168 bytes: bytes 0-159 its RasterView (raster/raster_shared.h), 160-167
// first_texel: where its texels start in the batch's planes.
struct GpuRasterBatchView {
  RasterView view;
  uint64_t first_texel;
};

// A set-up triangle of a batch, 96 bytes: bytes 0-87 the one mode's GpuRasterTriangle (its
// RasterSetup, object, prim), 88-91 view (index into the batch's views), 92-95 (0).
struct GpuRasterBatchTriangle {
  GpuRasterTriangle t;
  uint view;
  uint pad;
};

// raster_batch_setup.comp's push constants. Work items are the one mode's GpuRasterItem (the
// set-up triangle, its tile); counters its GpuRasterState.
struct RasterBatchSetupParams {
  uint64_t scene;      // SceneDesc
  uint64_t views;      // GpuRasterBatchView[view_count]
  uint64_t state;      // GpuRasterState
  uint64_t triangles;  // GpuRasterBatchTriangle[triangle_capacity]
  uint64_t items;      // GpuRasterItem[item_capacity]
  // Back-face culling against a polygon (0: none): float per scene object, +1 for a closed mesh
  // wound outward, -1 inward, 0 to keep all its triangles; and the polygon's outline_count
  // points (vec3 each). A triangle of an oriented object is skipped when every point lies behind
  // its outward plane: from no point of the polygon can it be the nearest surface.
  uint64_t orientation;
  uint64_t outline;
  // Per-view caster culling (0: none): a uint per (view, object), view-major (object_count a
  // view), the kRasterObject* flags raster_polygon takes for that view (ObjectCulling::
  // flags_for_views: kRasterObjectSkip for the objects wholly outside the view's frustum).
  uint64_t view_object_flags;
  uint triangle_count;  // input triangles (SceneDesc::triangle_count)
  uint view_count;
  uint triangle_capacity;
  uint item_capacity;
  uint culling;      // as RasterSetupParams
  uint opaque_only;  // as RasterSetupParams
  uint outline_count;
  uint object_count;  // the stride of view_object_flags
};

// raster_batch_fill.comp's push constants (raster_fill_args reads the one mode's RasterFillParams).
struct RasterBatchFillParams {
  uint64_t scene;
  uint64_t views;
  uint64_t state;
  uint64_t triangles;
  uint64_t items;
  uint64_t keys;  // uint64 per texel of every view
  uint item_capacity;
  uint pad;
};

// raster_batch_resolve.comp's push constants.
struct RasterBatchResolveParams {
  uint64_t scene;
  uint64_t views;
  uint64_t keys;
  uint64_t z;        // float per texel of every view: linear depth, +inf where empty
  uint64_t opacity;  // float per texel: 0 where empty
  uint64_t texels;   // of all views
  uint view_count;
  uint pad;
};

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::GpuRasterBatchView) == 168);
static_assert(sizeof(penumbra::shader::GpuRasterBatchTriangle) == 96);
static_assert(sizeof(penumbra::shader::RasterBatchSetupParams) <= 128);
static_assert(sizeof(penumbra::shader::RasterBatchFillParams) <= 128);
static_assert(sizeof(penumbra::shader::RasterBatchResolveParams) <= 128);
#endif

#endif  // PENUMBRA_GPU_RASTER_RASTER_BATCH_LAYOUT_SHARED_H
