// Method `occlusion-textures` (eisemann2006): plausible soft shadows from pre-filtered
// occlusion textures. The work is in occlusion_textures.h/.cpp and prefilter.h/.cpp; this
// file is the ShadowMethod wrapper and the parameter table.
#include <algorithm>

#include "penumbra/core/progress.h"
#include "penumbra/shadow/occlusion_textures/occlusion_textures.h"
#include "penumbra/shadow/shadow_method.h"

namespace penumbra {
namespace {


class OcclusionTexturesMethod final : public ShadowMethod {
 public:
  explicit OcclusionTexturesMethod(const ParamSet& p) : options_(occlusion::options_from(p)), textures_(options_) {}

  void prepare(const ShadowContext& ctx) override {
    stats_.prepare_count++;
    textures_.build(*ctx.scene, *ctx.light, &stats_);
    stats_.extra["slices"] = options_.slices;
    stats_.extra["resolution"] = options_.resolution;
    stats_.extra["prefilter"] = occlusion::to_string(options_.prefilter);
  }

  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override {
    textures_.shade(*ctx.scene, vs, out.visibility, &stats_, ctx.tracer);
    if (ctx.progress) ctx.progress->add(vs.size());
  }

 private:
  occlusion::Options options_;
  occlusion::OcclusionTextures textures_;
};

// One light's instance: the slices' coverage masks and the prefilter's tables (mipmaps about
// 4/3 R^2 bytes a slice, N-buffers R^2 a level, summed-area tables 4 or 8 bytes an entry);
// the casters' triangles and the rasterizer's scratch. Shading holds one tile's points per
// thread (small next to the textures).
MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q) {
  const occlusion::Options o = occlusion::options_from(p);
  MemoryTally tally;
  tally.add(occlusion::OcclusionTextures::texture_bytes(o, q.triangles), "resolution");
  // The larger rasterization: the own slice's nearest depths' pass at own_slice_scale x resolution.
  const int side = std::max(o.resolution, occlusion::own_slice_side(o, q.triangles));
  tally.add(raster_triangles_bytes(q.triangles) + Rasterizer::scratch_bytes(q.triangles, side, side), kTrianglesSetting);
  return tally.estimate();
}

const MethodRegistration registration({
    "occlusion-textures",
    "eisemann2006: the scene sliced parallel to the light into pre-filtered occlusion textures, "
    "combined by probability (rect lights; disks as their bounding square)",
    {
        {"slices", ParamType::Int, 16, "number of slices (occlusion textures) between the casters' nearest and farthest depth", {}, 1, 32},
        {"resolution", ParamType::Int, 512, "occlusion texture side in texels (a power of two)", {}, 16, 4096},
        {"prefilter", ParamType::String, "nbuffer",
         "box filtering of the textures (§3.2): 'mipmap' (trilinear, anisotropic), 'nbuffer' (N-buffers) or 'sat' "
         "(summed-area tables, exact)",
         {"mipmap", "nbuffer", "sat"}},
        {"sat_precision", ParamType::String, "uint32", "summed-area table entries: 'uint32' (exact counts) or 'double'",
         {"uint32", "double"}},
        {"combine", ParamType::String, "product",
         "how slices combine: 'product' (eq. 5, V = prod(1 - I_k)), 'sum' (1 - sum I_k) or 'max' (1 - max I_k)",
         {"product", "sum", "max"}},
        {"thin_fix", ParamType::Bool, false,
         "also fill each slice's coverage into the next slice farther away (thin occluders, §3.4): closes light leaks through thin "
         "surfaces cut by a slice plane, and darkens every other shadow (each occluder counts twice in eq. 5)",
         {}},
        {"fade", ParamType::Float, 1.0,
         "the slice just above a point fades in linearly over this many slice thicknesses (self-shadowing, §3.4; 0 = no fade)",
         {}, 0, 16},
        {"open_fade", ParamType::Float, 0.25,
         "fade for points on open surfaces (leaves, cards, planes: objects that are not closed): in a canopy a leaf's "
         "occluders are its neighbours a slice above, which a whole thickness's fade-in leaves out (penumbra's addition)",
         {}, 0, 16},
        {"cop_distance", ParamType::Float, 0.0,
         "distance d of the centre of projection behind the light (world units); 0 = the largest d whose frustum contains "
         "the casters",
         {}, 0, 1e6},
        {"cull_planar", ParamType::Bool, true,
         "leave out planar objects that cannot shadow anything (the light and every other object on one side: ground planes)", {}},
        {"cull_back_faces", ParamType::Bool, true,
         "closed objects: slice only the faces toward the centre of projection (where rays enter the solid), so that a solid "
         "occludes once in eq. 5 instead of twice, and half its triangles are rasterized",
         {}},
        {"horizon", ParamType::Bool, true,
         "closed receivers: multiply V by the part of the light above the receiver's tangent plane (the rest is hidden by the "
         "object itself, which the slices cannot show: a solid's faces away from the light read as lit; penumbra's "
         "addition, as vsm's); false: the slices alone, as the paper",
         {}},
        {"own_slice", ParamType::Bool, true,
         "open receivers (leaves, cards): also test the slice holding the point, which the paper leaves out (§3.4), by its "
         "nearest depths per texel, kept by the slicing pass: a shadow map per slice, tested against the receiver's plane "
         "(penumbra's addition: a canopy's leaves are shadowed by leaves centimetres above, in their own slice)",
         {}},
        {"own_slice_scale", ParamType::Int, 0,
         "the own slice's nearest depths at this many times `resolution` texels a side (1, 2 or 4; above 1 a pass of "
         "their own): a shadow map's test needs finer texels than the textures' filtered coverage; 0 = fitted: 2 where "
         "the casters' triangles outnumber the texels (a canopy), else 1",
         {}, 0, 4},
        {"tiles", ParamType::Int, 0,
         "light-space tiles a side (a power of two): each tile of the textures is sliced over the depth range of its own "
         "casters instead of the whole scene's, so that a wide scene's slices follow its casters (a tree crown in `slices` "
         "slices, not a forest); 0 = fitted (the largest penumbra spans at most 4 tiles a side); 1 = one range, as the paper",
         {}, 0, 64},
        {"near_field", ParamType::Float, 2.0,
         "where an occluder's penumbra at the point would be narrower than near_field texels of the textures, one "
         "ray toward the light's centre answers instead of the slices, whose coverage cannot place an occluder that "
         "near (a leaf centimetres above another; penumbra's addition, as vsm's); 0 = the slices alone, as the paper",
         {}, 0, 64},
    },
    [](const ParamSet& p) { return std::make_unique<OcclusionTexturesMethod>(p); },
    /*samples_light=*/false,
    memory,
    /*tile_exact=*/true,
    // A textured light counts as its mean colour: the light is its centre, size or outline.
    /*uniform_light=*/true,
});

}  // namespace
}  // namespace penumbra
