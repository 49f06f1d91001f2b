// Method `msm`: moment shadow maps (Peters & Klein 2015: four power moments, Hamburger 4MSM
// with moment bias alpha, optionally their optimized 16-bit quantisation) with the blocker
// search of moment soft shadows (Peters, Münstermann, Wetzstein, Klein 2016: the
// blockers' mean depth from the moments over the search region, then the filtered lookup),
// prefiltered by the shared core (filtered_moments.h). docs/methods/msm.md.
#include "penumbra/shadow/filtered_moments/filtered_moments.h"
#include "penumbra/shadow/filtered_moments/models.h"

namespace penumbra::filtered_moments {
namespace {

std::vector<ParamSpec> params() {
  std::vector<ParamSpec> p = core_param_specs(1024, Prefilter::Sat);
  p.push_back({"moment_bias", ParamType::Float, 3e-5,
               "alpha: the moments are mixed with (0.5, 0.5, 0.5, 0.5) by this weight before the Hamburger 4MSM bound "
               "(Peters & Klein 2015; 3e-5 is theirs for 16-bit storage): against singular moments and acne",
               {}, 0, 1});
  p.push_back({"quantize", ParamType::Bool, true,
               "store the moments in the paper's optimized basis rounded to 16 bits per channel (RGBA16 UNORM), "
               "dequantise after filtering; false: float power moments",
               {}});
  p.push_back(bleeding_param());
  return p;
}

const MethodRegistration registration({
    "msm",
    "moment shadow maps (Peters & Klein 2015, Hamburger 4MSM, optimized 16-bit quantisation) with the moment "
    "blocker search of moment soft shadows (Peters et al. 2016), prefiltered",
    params(),
    [](const ParamSet& p) { return make_filtered_moment_method("msm", p); },
    /*samples_light=*/false,
    [](const ParamSet& p, const MemoryQuery& q) { return core_memory(p, q, moment_channels("msm", p)); },
    // Not tile-exact: the depth map is fitted to the rendered view samples (as shadow-map's).
    /*tile_exact=*/false,
    // A textured light counts as its mean colour: the light is its centre, size or outline.
    /*uniform_light=*/true,
});

}  // namespace
}  // namespace penumbra::filtered_moments
