// Method `vsm`: variance shadow maps (Donnelly & Lauritzen 2006) prefiltered with a
// summed-area table (Lauritzen, GPU Gems 3 ch. 8), with light-bleeding reduction and a
// moment-based blocker search for contact hardening (Yang et al. 2010). The shared core:
// filtered_moments.h; docs/methods/vsm.md.
#include "penumbra/shadow/filtered_moments/filtered_moments.h"
#include "penumbra/shadow/filtered_moments/models.h"

namespace penumbra::filtered_moments {
namespace {

std::vector<ParamSpec> params() {
  std::vector<ParamSpec> p = core_param_specs(1024, Prefilter::Sat);
  p.push_back(bleeding_param());
  p.push_back(min_variance_param());
  return p;
}

const MethodRegistration registration({
    "vsm",
    "variance shadow maps (Donnelly & Lauritzen 2006), summed-area prefiltered, light-bleeding reduction, "
    "contact hardening from a moment blocker search",
    params(),
    [](const ParamSet& p) { return make_filtered_moment_method("vsm", p); },
    /*samples_light=*/false,
    [](const ParamSet& p, const MemoryQuery& q) { return core_memory(p, q, moment_channels("vsm", p)); },
    // Not tile-exact: the depth map is fitted to the rendered view samples (as shadow-map's
    // and pcss's), so a crop's lookups read another map.
    /*tile_exact=*/false,
    // A textured light counts as its mean colour: the light is its centre, size or outline.
    /*uniform_light=*/true,
});

}  // namespace
}  // namespace penumbra::filtered_moments
