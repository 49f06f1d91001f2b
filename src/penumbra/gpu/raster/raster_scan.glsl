// The fragments of one work item of the GPU rasterizer (a set-up triangle and one 16 x 16-texel
// tile: gpu/raster/raster_layout_shared.h), for every mode that scans them (the depth map's
// raster_fill, the batch's raster_batch_fill, the layered map's raster_layer_peel, the fragment lists' raster_fragment_count and
// raster_fragment_scatter): every texel centre of the tile the triangle covers (exact int64 edge
// functions, stepped by addition; top-left rule) is a fragment at the depth plane's linear depth,
// summed as the CPU's scan sums it; an alpha-textured triangle is looked up where the ray through
// the centre meets it, and a mask's holes drop the fragment.
//
// The including kernel defines, before including this file, what a fragment does:
//   void raster_visit(uint texel, float z, uint source, float opacity)
// texel: y * width + x; source: the input triangle; opacity: the fragment's (material x triangle
// x alpha texture, as the CPU's FragmentAlpha gives it) when the kernel asks for it, else 1
// unless textured.
#ifndef PENUMBRA_GPU_RASTER_RASTER_SCAN_GLSL
#define PENUMBRA_GPU_RASTER_RASTER_SCAN_GLSL

#include "penumbra/gpu/raster/raster_access.glsl"

// Visits the fragments of tile `tile` (column in bits 0-15, row in bits 16-31) of set-up triangle
// t (of scene triangle object/prim; the scene bound); returns how many.
uint raster_scan_tile(RasterView view, RasterSetup t, uint object, uint prim, uint tile, bool want_opacity) {
  int tx = int(tile & 0xffffu) << kRasterTileShift, ty = int(tile >> 16) << kRasterTileShift;
  int x0 = max(t.x0, tx), x1 = min(t.x1, tx + kRasterTile);
  int y0 = max(t.y0, ty), y1 = min(t.y1, ty + kRasterTile);
  bool textured = raster_textured(object);
  float flat_opacity = want_opacity && !textured ? raster_opacity(object, prim) : 1.0f;
  bool perspective = view.perspective != 0u;
  uint fragments = 0u;
  RasterEdges row = raster_edges_at(t, x0, y0);
  for (int y = y0; y < y1; ++y, row = raster_step_y(t, row)) {
    RasterEdges e = row;
    for (int x = x0; x < x1; ++x, e = raster_step_x(t, e)) {
      if (!raster_inside(e)) continue;
      // The CPU's span starts at the later of its 64-texel tile's first column and the box's.
      int span_x0 = max(t.x0, (x / kRasterCpuTile) * kRasterCpuTile);
      float z = raster_linear_depth(raster_plane_value(t, x, y, span_x0), view.near, view.far, perspective);
      float opacity = flat_opacity;
      if (textured) {
        opacity = raster_fragment_opacity(view, object, prim, x, y);
        if (!(opacity > 0.0f)) continue;
      }
      ++fragments;
      raster_visit(uint(y) * uint(view.width) + uint(x), z, t.source, opacity);
    }
  }
  return fragments;
}

// Visits the fragments of work item `i` (items and triangles: the one-map rasterizer's buffers;
// the scene bound); returns how many.
uint raster_scan_item(RasterView view, uint64_t items_address, uint64_t triangles_address, uint i, bool want_opacity) {
  GpuRasterItem item = RasterItems(items_address).v[i];
  GpuRasterTriangle tri = RasterTriangles(triangles_address).v[item.triangle];
  return raster_scan_tile(view, tri.s, tri.object, tri.prim, item.tile, want_opacity);
}

#endif
