// Caster culling per view (issue 34 part 3): a map costs what its view holds, not the whole
// scene. The triangle list is cut into runs of consecutive triangles of one object (at most
// kRunTriangles each: a mesh's triangles in file order are spatially coherent, so a forest
// exported as one mesh is culled too), each with its world bounds; a view keeps the runs whose
// box is not wholly outside one of its frustum's planes. A run that is kept is rasterized whole,
// so the kept triangles give the very map all triangles give (the rasterizer drops what lies
// outside the view itself): culling changes the cost, never a texel.
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/raster/light_view.h"
#include "penumbra/raster/raster_triangle.h"

namespace penumbra {

// Whether a box lies wholly outside one plane of the view's frustum (near, far and the four
// sides of its window; perspective or orthographic).
bool box_outside_view(const Bounds3f& box, const LightView& view);

class CasterCulling {
 public:
  static constexpr size_t kRunTriangles = 1024;

  // The runs of `triangles` and their bounds.
  void build(RasterTriangleView triangles);
  // `triangles` (the list build() saw) without the runs wholly outside `view`: `triangles`
  // itself when none is, else those kept gathered into `scratch` (same textures table).
  // *culled (if given) = the triangles left out.
  RasterTriangleView visible(RasterTriangleView triangles, const LightView& view, std::vector<RasterTriangle>& scratch,
                             uint64_t* culled = nullptr) const;
  size_t runs() const { return runs_.size(); }

 private:
  struct Run {
    size_t begin, end;
    Bounds3f bounds;
  };
  std::vector<Run> runs_;
  size_t triangles_ = 0;
};

}  // namespace penumbra
