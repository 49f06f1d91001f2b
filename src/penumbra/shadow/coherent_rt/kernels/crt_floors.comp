#version 460
// `coherent-rt` on the GPU, a reference image's floors (agrawala2000 §5.1; reference_images_shared.h
// crt_floor_of): one thread per texel, its biased floor in window depth (+inf where empty), by
// whether the texel's triangle belongs to a closed object (the rasterizer's input numbering,
// mapped back to its object as the rasterizer does: raster_source).
#include "penumbra/shadow/coherent_rt/kernels/crt_build.glsl"

void main() {
  uint i = pn_thread_index();
  if (i >= uint(pc.p.width) * uint(pc.p.height)) return;
  CrtTexelsRef t = build_texels();
  int x = int(i % uint(pc.p.width)), y = int(i / uint(pc.p.width));
  if (!crt_covered(t, int(i))) {
    Floats(pc.p.floors).v[i] = pn_inf();
    return;
  }
  scene_bind(pc.p.scene);
  uint object, prim;
  raster_source(Uints(pc.p.triangle).v[i], object, prim);
  bool closed = (g_objects.v[object].flags & kObjectClosed) != 0u;
  Floats(pc.p.floors).v[i] = crt_floor_of(t, RasterViewRef(pc.p.view).v, pc.p.options, x, y, closed);
}
