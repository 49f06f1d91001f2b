// Method `evsm`: exponential variance shadow maps (Lauritzen & McCool 2008): the VSM of
// exponentially warped depths, two components (positive warp) or four (positive and
// negative), with the bleeding reduction and the blocker search of the shared core
// (filtered_moments.h). Prefiltered like vsm with a double summed-area table, which holds
// the warped moments up to c+ of about 15 (bunny: MAE 0.036 at 10 and 15; at 20 a dotted line
// of dark pixels on the far ground; 0.049 at 30, 0.069 at 40: the table's differences of huge
// sums lose the small ones); larger exponents need prefilter=mipmap (no differences; about
// 5x slower here). docs/methods/vsm.md.
#include "penumbra/shadow/filtered_moments/filtered_moments.h"
#include "penumbra/shadow/filtered_moments/models.h"

namespace penumbra::filtered_moments {
namespace {

std::vector<ParamSpec> params() {
  std::vector<ParamSpec> p = core_param_specs(1024, Prefilter::Sat);
  p.push_back({"components", ParamType::Int, 4,
               "2: positive warp only, (e^(c+ x), e^(2 c+ x)); 4: positive and negative warps, V = the smaller bound",
               {}, 2, 4});
  // 42: e^(2 * 42) still fits a float (the mip chain's texels), with a margin for the means.
  p.push_back({"positive_exponent", ParamType::Float, 10.0,
               "c+ of the positive warp e^(c+ x), x = 2 z - 1 in [-1, 1]: larger, less bleeding; from about 20 on the "
               "summed-area table's differences lose the warped moments (use prefilter=mipmap)",
               {}, 0.1, 42});
  p.push_back({"negative_exponent", ParamType::Float, 5.0, "c- of the negative warp -e^(-c- x) (components=4)", {},
               0.1, 42});
  p.push_back(bleeding_param());
  p.push_back(min_variance_param());
  return p;
}

const MethodRegistration registration({
    "evsm",
    "exponential variance shadow maps (Lauritzen & McCool 2008), 2 or 4 components, prefiltered, light-bleeding "
    "reduction, contact hardening from a moment blocker search",
    params(),
    [](const ParamSet& p) { return make_filtered_moment_method("evsm", p); },
    /*samples_light=*/false,
    [](const ParamSet& p, const MemoryQuery& q) { return core_memory(p, q, moment_channels("evsm", p)); },
    // Not tile-exact: the depth map is fitted to the rendered view samples (as shadow-map's).
    /*tile_exact=*/false,
    // A textured light counts as its mean colour: the light is its centre, size or outline.
    /*uniform_light=*/true,
});

}  // namespace
}  // namespace penumbra::filtered_moments
