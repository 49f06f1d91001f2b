// The interface every shadow algorithm implements (DESIGN.md): prepare light-space
// structures for one light, then evaluate visibility V (and irradiance E where the method
// computes eq. 1 itself) for the view samples. One instance serves one light; it is kept
// while the light and the geometry do not change, so a camera change calls evaluate()
// alone (agrawala2000 §4: the LDI is precomputed once per light).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "penumbra/scene/scene.h"
#include "penumbra/shadow/params.h"
#include "penumbra/shadow/stats.h"
#include "penumbra/shadow/view_samples.h"

namespace penumbra {

class RayTracer;
class Progress;

// What a method may read while it works on one light.
struct ShadowContext {
  const Scene* scene = nullptr;
  const AreaLight* light = nullptr;
  int light_index = 0;
  const RayTracer* tracer = nullptr;  // the Embree scene of the same geometry
  uint64_t seed = 0;
  // Light samples per shading point (--spp) for methods that sample the light.
  int light_samples = 256;
  int frame = 0;  // progressive accumulation: frame index (new samples per frame)
  // Optional: methods advance it by the number of view samples they finished.
  Progress* progress = nullptr;
};

struct ShadowOutput {
  std::span<float> visibility;  // V per view sample, in [0,1]
  std::span<Vec3f> irradiance;  // E per view sample; only if computes_irradiance()
};

class ShadowMethod {
 public:
  virtual ~ShadowMethod() = default;
  // Builds the light-space structures for ctx.light. Called once per light and again only
  // when the light or the geometry changes.
  virtual void prepare(const ShadowContext& ctx) = 0;
  // Fills out.visibility (and out.irradiance if computes_irradiance()) for every sample.
  virtual void evaluate(const ShadowContext& ctx, const ViewSamples& samples, ShadowOutput& out) = 0;
  // True if evaluate() computes E (eq. 1) itself; otherwise compose multiplies V with the
  // closed-form unshadowed irradiance.
  virtual bool computes_irradiance() const { return false; }
  MethodStats& stats() { return stats_; }
  const MethodStats& stats() const { return stats_; }

 protected:
  MethodStats stats_;
};

struct MethodInfo {
  std::string name;         // as used by -m, scene files and reports
  std::string description;  // one line
  std::vector<ParamSpec> params;
  std::function<std::unique_ptr<ShadowMethod>(const ParamSet&)> create;
  // Whether the method samples the light (so --spp, ShadowContext::light_samples, applies).
  bool samples_light = false;
};

// The registry of shadow methods by name. Methods register from their own source file:
//   static const MethodRegistration reg({"hard", "...", {...params...}, create});
class MethodRegistry {
 public:
  static void add(MethodInfo info);
  static const MethodInfo& get(const std::string& name);  // throws listing known names
  static const MethodInfo* find(const std::string& name);
  static std::vector<const MethodInfo*> all();  // sorted by name
};

struct MethodRegistration {
  explicit MethodRegistration(MethodInfo info) { MethodRegistry::add(std::move(info)); }
};

// Creates a method with parameters from (in order) its defaults, the scene's "methods"
// table and `overrides` ("key=value" strings; also "method.key=value" where the prefix
// must match `name`, for compare runs).
std::unique_ptr<ShadowMethod> create_method(const std::string& name, const Scene& scene,
                                            const std::vector<std::string>& overrides,
                                            ParamSet* resolved = nullptr);

}  // namespace penumbra
