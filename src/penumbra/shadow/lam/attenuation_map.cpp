#include "penumbra/shadow/lam/attenuation_map.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>

#include "penumbra/core/binary_io.h"
#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/timer.h"
#include "penumbra/raster/rasterizer.h"
#include "penumbra/scene/scene.h"
#include "penumbra/shadow/lam/lam_kernels_shared.h"

namespace penumbra::lam {


LightView reference_view(const LightAxes& a, const ShadowRegion& region, int resolution) {
  if (region.empty) throw Error("lam: reference_view of an empty shadow region");
  if (resolution < 4 || resolution > 16384) throw Error("lam: resolution {} must be in [4, 16384]", resolution);
  // Square texels; one texel of margin on each side.
  float wu = region.u1 - region.u0, wv = region.v1 - region.v0;
  float delta = std::max(wu, wv) / static_cast<float>(resolution - 2);
  int w = std::clamp(static_cast<int>(std::ceil(wu / delta)) + 2, 4, resolution);
  int h = std::clamp(static_cast<int>(std::ceil(wv / delta)) + 2, 4, resolution);
  float cu = 0.5f * (region.u0 + region.u1), cv = 0.5f * (region.v0 + region.v1);
  float u0 = cu - 0.5f * w * delta, u1 = cu + 0.5f * w * delta;
  float v0 = cv - 0.5f * h * delta, v1 = cv + 0.5f * h * delta;
  // A margin around the region's depths against rounding: 1e-3 of the depth, but no more than
  // 1e-3 of the depth range (plus float rounding at that depth), and a range of at least 2^-16 of
  // the depth (a flat region). Relative to the depth alone (and at least 1% of it), a light far
  // from the scene (a sun 10^6 away over a scene 8 deep) got a range of 10^4, and every light
  // sample's view widened by its parallax over that range (64 views of 7,921 x 2,101 texels for
  // a 512-texel map: 13 s and 3.3 GB).
  const float range_margin = 1e-3f * (region.far - region.near) + 1e-6f * region.far;
  const float near = region.near - std::min(region.near * 1e-3f, range_margin);
  const float far = std::max(region.far + std::min(region.far * 1e-3f, range_margin), near * (1 + 0x1p-16f));
  // The window lives on the near plane.
  return LightView::frustum(a.eye, a.forward, a.up, u0 * near, u1 * near, v0 * near, v1 * near, near, far, w, h);
}

LightView sample_view(const LightAxes& a, const LightView& ref, Vec3f sample, int* offset_x, int* offset_y) {
  const float near = ref.near(), far = ref.far();
  const float delta = (ref.window_right() - ref.window_left()) / (near * ref.width());
  const float u0 = ref.window_left() / near, v1 = ref.window_top() / near;
  Vec3f d = sample - a.eye;
  float dx = dot(d, a.right), dy = dot(d, a.up);
  // A point at depth z and reference coordinate u appears at u - dx / z from the sample.
  float sx0 = std::min(-dx / near, -dx / far), sx1 = std::max(-dx / near, -dx / far);
  float sy0 = std::min(-dy / near, -dy / far), sy1 = std::max(-dy / near, -dy / far);
  int ox0 = static_cast<int>(std::floor(sx0 / delta)) - 1, ox1 = static_cast<int>(std::ceil(sx1 / delta)) + 1;
  int oy0 = static_cast<int>(std::floor(sy0 / delta)) - 1, oy1 = static_cast<int>(std::ceil(sy1 / delta)) + 1;
  int w = std::min(16384, ref.width() + ox1 - ox0), h = std::min(16384, ref.height() + oy1 - oy0);
  // Reference texel x = sample texel x + ox0 + dx / (z delta); rows grow downward and the
  // sample view's top edge lies oy1 texels above the reference's, so reference texel
  // y = sample texel y - oy1 - dy / (z delta).
  float su0 = u0 + ox0 * delta, sv1 = v1 + oy1 * delta;
  float su1 = su0 + w * delta, sv0 = sv1 - h * delta;
  *offset_x = ox0;
  *offset_y = -oy1;
  return LightView::frustum(sample, a.forward, a.up, su0 * near, su1 * near, sv0 * near, sv1 * near, near, far, w, h);
}

// ---------------------------------------------------------------------------------------
// Lookup.

LookupClass AttenuationMap::classify(int x, int y, float z, float* attenuation) const {
  size_t i = static_cast<size_t>(y) * width_ + x;
  float r = shader::lam_lookup(reinterpret_cast<const float*>(layers_.data()), offsets_[i], offsets_[i + 1], z,
                               depth_tolerance(epsilon_, z));
  if (r >= 0) {
    *attenuation = r;
    return LookupClass::Match;
  }
  return r == shader::kLamOccluded ? LookupClass::Occluded : LookupClass::Undefined;
}

void AttenuationMap::update_shared() {
  shader::LamMapView& m = shared_;
  m = {};
  m.row0 = {proj_[0][0], proj_[0][1], proj_[0][2]};
  m.off0 = proj_[0][3];
  m.row1 = {proj_[1][0], proj_[1][1], proj_[1][2]};
  m.off1 = proj_[1][3];
  m.row2 = {proj_[2][0], proj_[2][1], proj_[2][2]};
  m.off2 = proj_[2][3];
  m.near = near_;
  m.far = far_;
  m.unresolved = unresolved_ ? 1u : 0u;
  m.trace_spread = trace_spread_;
  m.cap_tan = cap_tan_;
  m.width = width_;
  m.height = height_;
  m.eye = eye_;
  m.u0 = u0_;
  m.right = right_;
  m.v1 = v1_;
  m.up = up_;
  m.delta = delta_;
  m.forward = forward_;
  m.epsilon = epsilon_;
  m.open_epsilon = open_epsilon_;
  m.light_center = light_center_;
  m.light_area = light_area_;
  m.light_normal = light_normal_;
  m.light_radius = light_radius_;
  m.outline_count = static_cast<uint32_t>(outline_.size());
  m.slope = slope_ ? 1u : 0u;
  m.solid = std::find(solid_.begin(), solid_.end(), true) != solid_.end() ? 1u : 0u;
  m.empty = empty() ? 1u : 0u;
}

template <bool kBilinear, bool kSlope>
inline float AttenuationMap::visibility_impl(Vec3f p, Vec3f n, bool closed, uint64_t& texels) const {
  uint32_t t = 0;
  const float v = shader::lam_visibility(reinterpret_cast<const float*>(layers_.data()), offsets_.data(), 1, shared_, p,
                                         n, shader::lam_epsilon(shared_, closed), kBilinear, kSlope, t);
  texels += t;
  return v;
}

namespace {
// "LAMATDM4" (2: open_epsilon; 3: the projection takes p - eye, LightView::texel_projection, and
// the region's cut, cap_tan; 4: the tolerances scaled by the view's width, depth_tolerance_scale)
constexpr uint64_t kMapRecordMagic = 0x344d4454414d414cull;
}  // namespace

void AttenuationMap::write(std::ostream& out) const {
  static_assert(std::is_trivially_copyable_v<LightView>);
  binary::write(out, kMapRecordMagic);
  binary::write_array(out, outline_);
  binary::write(out, light_center_);
  binary::write(out, light_normal_);
  binary::write(out, light_area_);
  binary::write(out, light_radius_);
  binary::write_array(out, std::vector<uint8_t>(solid_.begin(), solid_.end()));
  binary::write(out, width_);
  binary::write(out, height_);
  binary::write(out, samples_);
  binary::write(out, epsilon_);
  binary::write(out, open_epsilon_);
  binary::write(out, view_);
  binary::write(out, proj_);
  binary::write(out, near_);
  binary::write(out, far_);
  binary::write(out, slope_);
  binary::write(out, eye_);
  binary::write(out, right_);
  binary::write(out, up_);
  binary::write(out, forward_);
  binary::write(out, u0_);
  binary::write(out, v1_);
  binary::write(out, delta_);
  binary::write(out, cap_tan_);
  binary::write_array(out, offsets_);
  binary::write_array(out, layers_);
  binary::write(out, kMapRecordMagic);
}

bool AttenuationMap::read(std::istream& in) {
  AttenuationMap m;
  uint64_t magic = 0, end_magic = 0;
  std::vector<uint8_t> solid;
  constexpr uint64_t kMaxElements = uint64_t{1} << 34;
  const bool ok =
      binary::read(in, magic) && magic == kMapRecordMagic && binary::read_array(in, m.outline_, kMaxOutline) &&
      binary::read(in, m.light_center_) && binary::read(in, m.light_normal_) && binary::read(in, m.light_area_) &&
      binary::read(in, m.light_radius_) && binary::read_array(in, solid, kMaxElements) &&
      binary::read(in, m.width_) && binary::read(in, m.height_) && binary::read(in, m.samples_) &&
      binary::read(in, m.epsilon_) && binary::read(in, m.open_epsilon_) && binary::read(in, m.view_) &&
      binary::read(in, m.proj_) &&
      binary::read(in, m.near_) && binary::read(in, m.far_) && binary::read(in, m.slope_) &&
      binary::read(in, m.eye_) && binary::read(in, m.right_) && binary::read(in, m.up_) &&
      binary::read(in, m.forward_) && binary::read(in, m.u0_) && binary::read(in, m.v1_) &&
      binary::read(in, m.delta_) && binary::read(in, m.cap_tan_) && binary::read_array(in, m.offsets_, kMaxElements) &&
      binary::read_array(in, m.layers_, kMaxElements) && binary::read(in, end_magic) && end_magic == kMapRecordMagic;
  if (!ok || m.width_ < 0 || m.height_ < 0) return false;
  // The lookups index offsets_ by texel and layers_ by offset: check they stay inside.
  if (m.width_ > 0) {
    const uint64_t texels = static_cast<uint64_t>(m.width_) * static_cast<uint64_t>(m.height_);
    if (m.offsets_.size() != texels + 1 || m.offsets_.front() != 0 || m.offsets_.back() != m.layers_.size())
      return false;
    for (size_t i = 0; i + 1 < m.offsets_.size(); ++i)
      if (m.offsets_[i] > m.offsets_[i + 1]) return false;
  }
  m.solid_.assign(solid.begin(), solid.end());
  m.update_shared();
  *this = std::move(m);
  return true;
}

float AttenuationMap::front_fraction(Vec3f p, Vec3f n) const {
  return shader::lam_front_fraction(reinterpret_cast<const float*>(outline_.data()), shared_, p, n);
}

float AttenuationMap::visibility(Vec3f p, Vec3f n, Filter filter, uint64_t* texels) const {
  if (empty()) return 1.0f;
  uint64_t t = 0;
  float v = filter == Filter::Bilinear
                ? (slope_ ? visibility_impl<true, true>(p, n, true, t) : visibility_impl<true, false>(p, n, true, t))
                : (slope_ ? visibility_impl<false, true>(p, n, true, t) : visibility_impl<false, false>(p, n, true, t));
  if (texels) *texels += t;
  return v;
}

template <bool kBilinear, bool kSlope>
void AttenuationMap::visibility_batch(std::span<const ViewSample> samples, std::span<float> out,
                                      uint64_t* texels) const {
  uint64_t t = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    const ViewSample& s = samples[i];
    const bool closed = s.object < solid_.size() && solid_[s.object];
    if (shader::lam_beyond_cap(shared_, s.p)) {
      out[i] = shader::kLamUnresolved;
      continue;
    }
    const float v = visibility_impl<kBilinear, kSlope>(s.p, s.ng, closed, t);
    out[i] = v > 0 && closed ? std::min(v, front_fraction(s.p, s.ng)) : v;
  }
  if (texels) *texels += t;
}

void AttenuationMap::visibility(std::span<const ViewSample> samples, std::span<float> out, Filter filter,
                                uint64_t* texels) const {
  if (empty()) {
    for (size_t i = 0; i < samples.size(); ++i) {
      const ViewSample& s = samples[i];
      out[i] = shader::lam_beyond_cap(shared_, s.p)                   ? shader::kLamUnresolved
               : s.object < solid_.size() && solid_[s.object] ? front_fraction(s.p, s.ng)
                                                              : 1.0f;
    }
    return;
  }
  if (filter == Filter::Bilinear)
    slope_ ? visibility_batch<true, true>(samples, out, texels) : visibility_batch<true, false>(samples, out, texels);
  else
    slope_ ? visibility_batch<false, true>(samples, out, texels) : visibility_batch<false, false>(samples, out, texels);
}

// ---------------------------------------------------------------------------------------
// Precomputation.

namespace {

// A layer while building (the GPU's LamBuildLayer, byte for byte: lam_kernels_shared.h).
struct BuildLayer {
  float z;       // running mean depth over the samples that matched it
  float count;   // light samples that counted it, or (weighted) the sum of the weights they added
  float weight;  // weighted: what the sample of `stamp` has added so far
  float peak;    // weighted: the most one sample added; < 0: a layer counted once per sample
  uint16_t hits;   // light samples that matched it (the running mean's count)
  uint16_t stamp;  // 1 + index of the last light sample that matched it
};
static_assert(sizeof(BuildLayer) == sizeof(shader::LamBuildLayer));

// A warped depth-map pixel (lam_shared.h LamSplat, in 32 bytes): the texel (ix, iy) whose
// centre is the top-left of the 4 it splats into, the depth extrapolated to that texel's
// centre along the surface's local plane, the plane's depth gradient per reference texel, and
// what its weights come from (LamSplat's ax, ay, area).
struct Splat {
  int16_t ix, iy;
  float z00, gx, gy;
  float ax, ay, area;
  bool open;  // from an open surface (lam_epsilon)
};

constexpr int kBandRows = 8;   // rows of the reference view one insertion task owns
constexpr int kChunkRows = 8;  // source rows per warp task

}  // namespace

class Builder {
 public:
  static AttenuationMap frame(const AreaLight& light, const ShadowRegion& region, int samples,
                              const BuildOptions& opt);
  static AttenuationMap build(RasterTriangleView tris, const AreaLight& light, const ShadowRegion& region,
                              std::span<const Vec2f> samples, const BuildOptions& opt, BuildStats* st);
};

AttenuationMap Builder::frame(const AreaLight& light, const ShadowRegion& region, int samples,
                              const BuildOptions& opt) {
  if (samples < 1) throw Error("lam: no light samples");
  if (samples > 65535) throw Error("lam: at most 65535 light samples (got {})", samples);
  if (opt.max_layers < 1 || opt.max_layers > 255) throw Error("lam: max_layers {} must be in [1, 255]", opt.max_layers);
  if (!(opt.epsilon >= 0)) throw Error("lam: epsilon {} must be >= 0", opt.epsilon);
  if (!(opt.open_epsilon >= 0)) throw Error("lam: open_epsilon {} must be >= 0", opt.open_epsilon);
  AttenuationMap map;
  map.samples_ = samples;
  map.epsilon_ = opt.epsilon;
  map.open_epsilon_ = opt.slope ? opt.open_epsilon : opt.epsilon;
  map.solid_ = opt.solid_objects;
  {
    // The light as the LDI's samples see it: the polygon its samples lie in.
    map.outline_ = light.outline(AttenuationMap::kMaxOutline);
    map.light_center_ = light.center;
    map.light_normal_ = normalize(light.frame.n);
    float area = 0, radius = 0;
    for (size_t i = 0; i < map.outline_.size(); ++i) {
      const Vec3f a = map.outline_[i] - light.center, b = map.outline_[(i + 1) % map.outline_.size()] - light.center;
      area += dot(map.light_normal_, cross(a, b));
      radius = std::max(radius, length(a));
    }
    map.light_area_ = std::max(0.5f * std::abs(area), 1e-30f);
    if (area < 0) map.light_normal_ = -map.light_normal_;  // counter-clockwise around the normal
    map.light_radius_ = radius * (1 + 1e-5f);
  }
  map.cap_tan_ = region.cap_tan;
  // The light's axes, also for an empty region (lam_beyond_cap reads them).
  const LightAxes axes = light_axes(light);
  map.eye_ = axes.eye;
  map.right_ = axes.right;
  map.up_ = axes.up;
  map.forward_ = axes.forward;
  if (!region.empty) {
    map.view_ = reference_view(axes, region, opt.resolution);
    const LightView& ref = map.view_;
    map.slope_ = opt.slope;
    map.delta_ = (ref.window_right() - ref.window_left()) / (ref.near() * ref.width());
    map.u0_ = ref.window_left() / ref.near();
    map.v1_ = ref.window_top() / ref.near();
    map.width_ = ref.width();
    map.height_ = ref.height();
    map.near_ = ref.near();
    map.far_ = ref.far();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) map.proj_[r][c] = ref.texel_projection().m[r][c];
    const float scale = depth_tolerance_scale(map.delta_ * static_cast<float>(std::max(ref.width(), ref.height())));
    map.epsilon_ = scaled_depth_tolerance(map.epsilon_, scale);
    map.open_epsilon_ = scaled_depth_tolerance(map.open_epsilon_, scale);
  }
  map.update_shared();
  return map;
}

AttenuationMap Builder::build(RasterTriangleView tris, const AreaLight& light, const ShadowRegion& region,
                              std::span<const Vec2f> samples, const BuildOptions& opt, BuildStats* st) {
  BuildStats local;
  BuildStats& s = st ? *st : local;
  s = BuildStats{};
  AttenuationMap map = frame(light, region, static_cast<int>(samples.size()), opt);
  if (map.empty()) return map;

  const LightAxes axes = light_axes(light);
  const LightView& ref = map.view_;
  const int W = ref.width(), H = ref.height();
  const size_t texels = static_cast<size_t>(W) * H;
  const int K = opt.max_layers;
  const float delta = map.delta_;
  const float eps = map.epsilon_;
  const float eps_open = map.open_epsilon_;
  const bool slope = opt.slope;

  const bool weighted = slope && opt.weighted_splats;
  std::vector<uint8_t> counts(texels, 0);
  // Weighted layers: the light sample that last splatted into each texel (1 + index; 0: none),
  // whose weights its layers still hold until flush_texel adds them.
  std::vector<uint16_t> texel_stamp(weighted ? texels : 0, 0);
  // Uninitialised: slot i of a texel is read only once counts says it exists, so the
  // planes of deep slots are never touched (nor committed) unless some texel needs them.
  auto layers = std::make_unique_for_overwrite<BuildLayer[]>(texels * K);
  // The weights light sample `stamp` added to a texel's weighted layers, complete: each adds them
  // to its count and its peak (lam_shared.h lam_flush_layer; the GPU's insert does it at its end).
  const auto flush_texel = [texels](BuildLayer* L, int n, uint16_t stamp) {
    if (stamp == 0) return;
    for (int i = 0; i < n; ++i) {
      BuildLayer& l = L[i * texels];
      if (l.stamp == stamp && l.peak >= 0) shader::lam_flush_layer(l.count, l.weight, l.peak);
    }
  };
  const int bands = (H + kBandRows - 1) / kBandRows;
  // Per band: layers created and texels that became non-empty (depth complexity per sample).
  std::vector<size_t> band_layers(bands, 0), band_nonempty(band_layers.size(), 0), band_dropped(bands, 0);
  std::vector<size_t> band_splats(bands, 0);
  size_t total_layers = 0, total_nonempty = 0;
  s.depth_complexity.reserve(samples.size());

  // 1 / k for the running mean of a layer's depth.
  std::vector<float> inv_count(samples.size() + 1, 0.0f);
  for (size_t k = 1; k < inv_count.size(); ++k) inv_count[k] = 1.0f / static_cast<float>(k);
  Rasterizer raster;
  DepthMap dm;
  std::vector<Splat> splats;
  std::vector<uint32_t> chunk_band_count;
  std::vector<Splat> binned;
  size_t peak_scratch = 0;
  for (size_t si = 0; si < samples.size(); ++si) {
    const Vec3f q = light.sample_area(samples[si]);
    int ox = 0, oy = 0;
    const LightView view = sample_view(axes, ref, q, &ox, &oy);
    Timer t_raster;
    raster.depth_map(tris, view, RasterFilter{}, &dm);
    s.raster_ms += t_raster.elapsed_ms();
    s.sample_texels += static_cast<size_t>(view.width()) * view.height();

    // Warp (eq. 3) every covered pixel; bucket the splats by the band(s) of reference rows
    // they touch (counting sort: fixed chunk order keeps the result thread-independent).
    Timer t_warp;
    const Vec3f d = q - axes.eye;
    const float bx = dot(d, axes.right) / delta, by = dot(d, axes.up) / delta;
    const int sw = view.width(), sh = view.height();
    const int chunks = (sh + kChunkRows - 1) / kChunkRows;
    splats.resize(static_cast<size_t>(sw) * sh);
    chunk_band_count.assign(static_cast<size_t>(chunks) * bands, 0);
    std::vector<uint32_t> chunk_splats(chunks, 0);
    parallel_for(chunks, 1, [&](size_t c0, size_t c1) {
      for (size_t c = c0; c < c1; ++c) {
        uint32_t* cnt = chunk_band_count.data() + c * bands;
        int y_begin = static_cast<int>(c) * kChunkRows, y_end = std::min(sh, y_begin + kChunkRows);
        Splat* out = splats.data() + static_cast<size_t>(y_begin) * sw;
        uint32_t m = 0;
        for (int y = y_begin; y < y_end; ++y) {
          const float* zr = dm.z.data() + static_cast<size_t>(y) * sw;
          for (int x = 0; x < sw; ++x) {
            float z = zr[x];
            if (!(z < kInfinity)) continue;
            // Eq. 3: the reference texel-space position minus 0.5 (the top-left splat centre).
            float fx, fy;
            int ix, iy;
            if (!shader::lam_warp(x, y, z, ox, oy, bx, by, W, H, fx, fy, ix, iy)) continue;
            // With local planes: the surface's depth gradient from the neighbours, carried
            // through the warp (lam_shared.h lam_splat).
            const shader::LamSplat sp = shader::lam_splat(
                z, x > 0 ? zr[x - 1] : kInfinity, x + 1 < sw ? zr[x + 1] : kInfinity, y > 0 ? zr[x - sw] : kInfinity,
                y + 1 < sh ? zr[x + sw] : kInfinity, bx, by, fx, fy, ix, iy, slope);
            const uint32_t object = tris[dm.triangle[static_cast<size_t>(y) * sw + x]].object;
            const bool open = !(object < map.solid_.size() && map.solid_[object]);
            out[m++] = {static_cast<int16_t>(ix), static_cast<int16_t>(iy), sp.z00, sp.gx, sp.gy, sp.ax, sp.ay, sp.area,
                        open};
            int b0 = std::max(iy, 0) / kBandRows, b1 = std::min(iy + 1, H - 1) / kBandRows;
            cnt[b0]++;
            if (b1 != b0) cnt[b1]++;
          }
        }
        chunk_splats[c] = m;
      }
    });
    // Offsets band-major, chunk-minor.
    std::vector<size_t> offs(static_cast<size_t>(chunks) * bands + 1, 0);
    {
      size_t acc = 0;
      for (int b = 0; b < bands; ++b)
        for (int c = 0; c < chunks; ++c) {
          offs[static_cast<size_t>(b) * chunks + c] = acc;
          acc += chunk_band_count[static_cast<size_t>(c) * bands + b];
        }
      offs.back() = acc;
      binned.resize(acc);
    }
    parallel_for(chunks, 1, [&](size_t c0, size_t c1) {
      std::vector<size_t> pos(bands);
      for (size_t c = c0; c < c1; ++c) {
        for (int b = 0; b < bands; ++b) pos[b] = offs[static_cast<size_t>(b) * chunks + c];
        const size_t base = static_cast<size_t>(c) * kChunkRows * sw;
        for (uint32_t k = 0; k < chunk_splats[c]; ++k) {
          const Splat& sp = splats[base + k];
          int b0 = std::max<int>(sp.iy, 0) / kBandRows, b1 = std::min<int>(sp.iy + 1, H - 1) / kBandRows;
          binned[pos[b0]++] = sp;
          if (b1 != b0) binned[pos[b1]++] = sp;
        }
      }
    });
    peak_scratch = std::max(peak_scratch, (splats.size() + binned.size()) * sizeof(Splat) +
                                              dm.z.size() * (3 * sizeof(float) + sizeof(uint32_t)));
    s.warp_ms += t_warp.elapsed_ms();

    // Insert (agrawala2000 §4, line 6): each band owns its rows, so no two threads touch a
    // texel; within a band the splats come in source scan order.
    Timer t_insert;
    const uint16_t stamp = static_cast<uint16_t>(si + 1);
    parallel_for(bands, 1, [&](size_t b0, size_t b1) {
      for (size_t b = b0; b < b1; ++b) {
        const int row0 = static_cast<int>(b) * kBandRows, row1 = std::min(H, row0 + kBandRows);
        size_t new_layers = 0, new_nonempty = 0, dropped = 0, n_splats = 0;
        auto insert = [&](int tx, int ty, float z, bool open, float w) {
          size_t t = static_cast<size_t>(ty) * W + tx;
          // Layer-major storage: slot i of texel t at i * texels + t, so the first layers
          // (almost every texel has one or two) are dense.
          BuildLayer* L = layers.get() + t;
          int n = counts[t];
          const bool by_weight = weighted && open;
          if (by_weight && !(w > 0)) return;  // lands on no part of this texel
          if (weighted && texel_stamp[t] != stamp) {
            // The first splat of this sample here: the previous sample's weights are complete.
            flush_texel(L, n, texel_stamp[t]);
            texel_stamp[t] = stamp;
          }
          const float tol = depth_tolerance(open ? eps_open : eps, z);
          int best = -1;
          float bestd = tol;
          for (int i = 0; i < n; ++i) {
            float dd = std::abs(L[i * texels].z - z);
            if (dd <= bestd) {
              bestd = dd;
              best = i;
            }
          }
          ++n_splats;
          if (best >= 0) {
            BuildLayer& l = L[best * texels];
            if (l.stamp != stamp) {  // the running mean and the paper's count: once per light sample
              l.stamp = stamp;
              l.hits++;
              l.z += (z - l.z) * inv_count[l.hits];
              if (l.peak < 0) l.count += 1.0f;
            }
            if (l.peak >= 0) l.weight += w;
          } else if (n < K) {
            // A layer is weighted by the kind of the splat that opened it.
            L[n * texels] = by_weight ? BuildLayer{z, 0.0f, w, 0.0f, 1, stamp} : BuildLayer{z, 1.0f, 0.0f, -1.0f, 1, stamp};
            counts[t] = static_cast<uint8_t>(n + 1);
            ++new_layers;
            if (n == 0) ++new_nonempty;
          } else {
            ++dropped;
          }
        };
        for (size_t k = offs[b * chunks]; k < offs[(b + 1) * chunks]; ++k) {
          const Splat& sp = binned[k];
          for (int j = 0; j < 2; ++j) {
            int ty = sp.iy + j;
            if (ty < row0 || ty >= row1) continue;
            const shader::LamSplat plane{sp.ix, sp.iy, sp.z00, sp.gx, sp.gy, sp.ax, sp.ay, sp.area};
            if (sp.ix >= 0)
              insert(sp.ix, ty, shader::lam_splat_depth(plane, 0, j), sp.open, shader::lam_splat_weight(plane, 0, j));
            if (sp.ix + 1 < W)
              insert(sp.ix + 1, ty, shader::lam_splat_depth(plane, 1, j), sp.open, shader::lam_splat_weight(plane, 1, j));
          }
        }
        band_layers[b] = new_layers;
        band_nonempty[b] = new_nonempty;
        band_dropped[b] += dropped;
        band_splats[b] += n_splats;
      }
    });
    for (int b = 0; b < bands; ++b) {
      total_layers += band_layers[b];
      total_nonempty += band_nonempty[b];
    }
    s.depth_complexity.emplace_back(static_cast<int>(si + 1),
                                    total_nonempty ? static_cast<double>(total_layers) / total_nonempty : 0.0);
    s.insert_ms += t_insert.elapsed_ms();
  }
  for (int b = 0; b < bands; ++b) {
    s.dropped += band_dropped[b];
    s.splats += band_splats[b];
  }

  if (weighted)
    parallel_for(texels, 4096, [&](size_t t0, size_t t1) {
      for (size_t t = t0; t < t1; ++t) flush_texel(layers.get() + t, counts[t], texel_stamp[t]);
    });
  // Process Attenuation Maps (line 7): attenuation = count / N (weighted layers: lam_shared.h
  // lam_layer_attenuation); layers sorted by depth in flat, texel-major storage.
  Timer t_fin;
  map.offsets_.assign(texels + 1, 0);
  uint32_t acc = 0;
  int max_depth = 0;
  for (size_t t = 0; t < texels; ++t) {
    map.offsets_[t] = acc;
    acc += counts[t];
    max_depth = std::max<int>(max_depth, counts[t]);
  }
  map.offsets_[texels] = acc;
  map.layers_.resize(acc);
  const float inv_n = 1.0f / static_cast<float>(samples.size());
  parallel_for(H, 8, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y < y1; ++y)
      for (int x = 0; x < W; ++x) {
        size_t t = y * W + x;
        BuildLayer L[256];
        int n = counts[t];
        for (int i = 0; i < n; ++i) L[i] = layers[i * texels + t];
        std::sort(L, L + n, [](const BuildLayer& a, const BuildLayer& b) { return a.z < b.z; });
        Layer* out = map.layers_.data() + map.offsets_[t];
        for (int i = 0; i < n; ++i) out[i] = {L[i].z, shader::lam_layer_attenuation(L[i].count, L[i].peak, inv_n)};
      }
  });
  s.finalize_ms = t_fin.elapsed_ms();
  s.nonempty_texels = total_nonempty;
  s.layers = total_layers;
  s.max_depth = max_depth;
  s.peak_bytes = counts.size() + texel_stamp.size() * sizeof(uint16_t) + texels * (max_depth * sizeof(BuildLayer)) +
                 peak_scratch + map.memory_bytes();
  return map;
}

int sample_view_side_bound(int resolution) {
  // The disparity of a light sample over the casters' depth range is at most the light's
  // half-extent over the nearest depth, which fit_shadow_region already added on each side
  // of the window: a sample view is at most about 1.5 times the LDI's side; 2 with margin,
  // within sample_view's own cap.
  return std::min(16384, 2 * resolution);
}

uint64_t build_bytes(int resolution, int max_layers) {
  const uint64_t texels = static_cast<uint64_t>(resolution) * static_cast<uint64_t>(resolution);
  const uint64_t slots = texels * static_cast<uint64_t>(max_layers);
  const int side = sample_view_side_bound(resolution);
  const uint64_t sample_texels = static_cast<uint64_t>(side) * static_cast<uint64_t>(side);
  // Splats: one per covered pixel, binned into up to two bands each; the per-(chunk, band)
  // counts and offsets.
  const uint64_t chunks = (side + kChunkRows - 1) / kChunkRows, bands = (resolution + kBandRows - 1) / kBandRows;
  const uint64_t sample_view = DepthMap::bytes(side, side) + 3 * sample_texels * sizeof(Splat) +
                               chunks * bands * (sizeof(uint32_t) + sizeof(size_t));
  const uint64_t map = (texels + 1) * sizeof(uint32_t) + slots * sizeof(Layer);
  // Per texel its layer count and (weighted splats) the last sample that splatted into it.
  return texels * (sizeof(uint8_t) + sizeof(uint16_t)) + slots * sizeof(BuildLayer) + sample_view + map;
}

nlohmann::json build_statistics(const BuildStats& bs, const AttenuationMap& map, int light_samples,
                                uint64_t ldi_bytes) {
  nlohmann::json dc = nlohmann::json::array();
  for (auto [k, c] : bs.depth_complexity) dc.push_back({{"samples", k}, {"depth_complexity", c}});
  const LightView& v = map.view();
  auto degrees_at = [&](float window) { return degrees(std::atan(window / v.near())); };
  return {
      {"light_samples", light_samples},
      {"depth_complexity", std::move(dc)},
      {"ldi",
       {{"width", map.width()},
        {"height", map.height()},
        {"layers", bs.layers},
        {"nonempty_texels", bs.nonempty_texels},
        {"max_depth", bs.max_depth},
        {"dropped_insertions", bs.dropped},
        {"bytes", ldi_bytes},
        {"window_degrees", map.empty() ? nlohmann::json(nullptr)
                                        : nlohmann::json({degrees_at(v.window_left()), degrees_at(v.window_right()),
                                                          degrees_at(v.window_bottom()), degrees_at(v.window_top())})}}},
      {"sample_texels", bs.sample_texels},
      {"splats", bs.splats},
  };
}

BuildOptions build_options(const ParamSet& p) {
  BuildOptions options;
  options.resolution = p.get_int("resolution");
  options.epsilon = p.get_float("epsilon");
  options.open_epsilon = p.get_float("open_epsilon");
  options.max_layers = p.get_int("max_layers");
  options.slope = p.get_bool("local_planes");
  options.weighted_splats = p.get_bool("weighted_splats");
  return options;
}

Filter display_filter(const ParamSet& p) {
  return p.get_string("filter") == "nearest" ? Filter::Nearest : Filter::Bilinear;
}

BuildOptions options_for_scene(BuildOptions options, const Scene& scene) {
  options.solid_objects.clear();
  if (options.slope)
    for (const SceneObject& o : scene.objects) options.solid_objects.push_back(o.closed);
  return options;
}

LightSampleSet light_sample_set(const ShadowContext& ctx) {
  return LightSampleSet(std::max(1, ctx.light_samples), hash_combine(ctx.seed, 0x4c414d00u + ctx.light_index),
                        /*per_pixel=*/false);
}

std::vector<Vec3f> light_points(const AreaLight& light, const LightSampleSet& set) {
  std::vector<Vec3f> points;
  points.reserve(set.base().size());
  for (const Vec2f& u : set.base()) points.push_back(light.sample_area(u));
  return points;
}

AttenuationMap attenuation_map_frame(const AreaLight& light, const ShadowRegion& region, int light_samples,
                                     const BuildOptions& options) {
  return Builder::frame(light, region, light_samples, options);
}

std::vector<float> closed_mesh_orientations(const Scene& scene) {
  std::vector<float> orientation(scene.objects.size(), 0.0f);
  for (size_t o = 0; o < scene.objects.size(); ++o) {
    const SceneObject& obj = scene.objects[o];
    if (!obj.closed) continue;
    const TriangleMesh& m = obj.mesh;
    double volume = 0;
    for (size_t t = 0; 3 * t + 2 < m.indices.size(); ++t) {
      Vec3f a = m.positions[m.indices[3 * t]], b = m.positions[m.indices[3 * t + 1]], c = m.positions[m.indices[3 * t + 2]];
      volume += dot(a, cross(b, c));
    }
    orientation[o] = volume > 0 ? 1.0f : (volume < 0 ? -1.0f : 0.0f);
  }
  return orientation;
}

AttenuationMap build_attenuation_map(RasterTriangleView triangles, const AreaLight& light,
                                     const ShadowRegion& region, std::span<const Vec2f> light_samples,
                                     const BuildOptions& options, BuildStats* stats) {
  return Builder::build(triangles, light, region, light_samples, options, stats);
}

}  // namespace penumbra::lam
