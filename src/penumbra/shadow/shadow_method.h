// The interface every shadow algorithm implements (DESIGN.md): prepare light-space
// structures for one light, then evaluate visibility V (and irradiance E where the method
// computes eq. 1 itself) for the view samples. One instance serves one light; it is kept
// while the light and the geometry do not change, so a camera change calls evaluate()
// alone (agrawala2000 §4: the LDI is precomputed once per light).
#pragma once

#include <cstdint>
#include <functional>
#include <iosfwd>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
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

  // Some objects moved since prepare() (RenderSettings::movable_objects, Renderer::set_objects:
  // new vertex positions for the same triangles; ctx's scene and tracer already show them).
  // True if what prepare() built stays valid for the moved geometry, so the next render calls
  // evaluate() alone; false (the default, right for every method whose light-space structures
  // hold the geometry: maps, LDIs, lists) and the renderer creates the method afresh and
  // prepares it again. Called only on a prepared method.
  virtual bool keeps_prepared_after_moving(std::span<const uint32_t> moved_objects, const ShadowContext& ctx) {
    return false;
  }

  // Light-space data kept on disk between runs (RenderSettings::map_cache, `--map-cache DIR`;
  // issue 18 part 4, xie2007's memory/disk trade-off, agrawala2000's reuse). A method whose
  // prepare() depends only on the scene's geometry and materials, the light, its parameters,
  // the seed, the light index and ShadowContext::light_samples (not on the camera or the view
  // samples) may return true here; the render layer (render/map_cache.h) keys an entry by a
  // digest of exactly those inputs and of the program, writes save_prepared() after a
  // prepare() and calls load_prepared() instead of prepare() when an entry exists.
  virtual bool stores_prepared() const { return false; }
  // Writes what prepare() built, in the method's own binary layout. Only after prepare().
  virtual void save_prepared(std::ostream& out) const {}
  // Reads what save_prepared() wrote, as if prepare(ctx) had run: false (and the method
  // unchanged) where the bytes are not a whole entry, so the caller prepares afresh.
  virtual bool load_prepared(std::istream& in, const ShadowContext& ctx) { return false; }

  MethodStats& stats() { return stats_; }
  const MethodStats& stats() const { return stats_; }

 protected:
  MethodStats stats_;
};

// What a render asks a method's memory estimate about (MethodInfo::estimate_memory).
struct MemoryQuery {
  uint64_t view_samples = 0;  // an upper bound: every camera ray hits
  int light_samples = 256;    // --spp
  uint64_t triangles = 0;     // in the whole scene
  int threads = 1;            // worker threads that may each hold scratch buffers
  bool semi_transparent = false;  // some object stops only part of the light (SceneObject::semi_transparent)
  // The light the instance serves (its shape decides some sizes); null: the largest of any.
  const AreaLight* light = nullptr;
};

// Bytes one method instance holds for one light (its maps, lists, per-sample buffers and
// the largest transient scratch), and the setting that drives them: what an error tells the
// user to lower ("resolution", "--spp", ...).
struct MemoryEstimate {
  uint64_t bytes = 0;
  std::string setting;
};

// MemoryEstimate::setting for the parts no method parameter drives (the render's error then
// names them as they are, without "-p METHOD."; for the view samples it names the camera's
// settings, as for the view samples' own memory).
inline constexpr const char* kLightSamplesSetting = "--spp";
inline constexpr const char* kViewSamplesSetting = "--resolution or --pixel-samples";
inline constexpr const char* kTrianglesSetting = "the scene's triangle count";

// Adds up the parts of a method's estimate, each with the setting that drives it, and names
// the setting whose parts add up to the most: what lowering helps most.
class MemoryTally {
 public:
  void add(uint64_t bytes, std::string_view setting);
  uint64_t bytes() const;
  MemoryEstimate estimate() const;

 private:
  std::vector<std::pair<std::string, uint64_t>> parts_;  // per setting, in the order first added
};

struct MethodInfo {
  std::string name;         // as used by -m, scene files and reports
  std::string description;  // one line
  std::vector<ParamSpec> params;
  std::function<std::unique_ptr<ShadowMethod>(const ParamSet&)> create;
  // Whether the method samples the light (so --spp, ShadowContext::light_samples, applies).
  bool samples_light = false;
  // The method's memory at these parameters, before anything is allocated: the Renderer
  // refuses a render whose total exceeds the budget (issue 17, docs/reliability.md). Empty
  // for methods whose memory is negligible next to the view samples (hard: a stack of rays).
  std::function<MemoryEstimate(const ParamSet&, const MemoryQuery&)> estimate_memory;
  // Whether a crop of the image (RenderSettings::crop: a tile of a frame split among machines)
  // gives the whole frame's pixels there bit for bit, whatever the window: each view sample's
  // result depends on that sample alone (its random numbers keyed by its camera ray,
  // sample_key). False for a method whose result for a sample depends on which other samples
  // are rendered: one that fits its light view to the view samples, or one that predicts a
  // pixel from its neighbours'. The registration says why.
  bool tile_exact = true;
  // Whether the method models the light as uniform (its centre, its size, its outline) rather
  // than by points on it: a textured light (AreaLight::texture) then counts as its mean colour,
  // and a render says so in one line. False for every method that takes points on the light
  // (AreaLight::sample_area, LightPointSampler), which follow the texture (issue 20 part 3).
  bool uniform_light = false;
  // Whether the method samples a sphere light through the one disk facing frame.n (its light
  // views, its maps): the renderer then draws a sphere that the scene reaches behind as one
  // light per face of the cube around it (split_sphere_lights, scene/light.h), each serving
  // only its view samples. False for a method that takes each point's own silhouette disk
  // (AreaLight::sample_area_toward) or the light's centre alone: the split would change nothing.
  bool sphere_through_disk = true;
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

// A method's parameters from (in order) its defaults, the scene's "methods" table and
// `overrides` ("key=value" strings; also "method.key=value" where the prefix must match
// `name`, for compare runs). Throws naming the key on a bad one.
ParamSet resolve_method_params(const std::string& name, const Scene& scene, const std::vector<std::string>& overrides);

// Creates a method with the parameters of resolve_method_params.
std::unique_ptr<ShadowMethod> create_method(const std::string& name, const Scene& scene,
                                            const std::vector<std::string>& overrides,
                                            ParamSet* resolved = nullptr);

}  // namespace penumbra
