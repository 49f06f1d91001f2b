#include "penumbra/shadow/denoised/atrous_filter.h"

#include <algorithm>
#include <cmath>

#include "penumbra/core/parallel.h"

namespace penumbra::denoise {
namespace {

shader::DenoiseSettings shared_settings(const AtrousSettings& s) { return {s.sigma_z, s.sigma_n, s.sigma_l}; }

// Every valid pixel's depth gradient (atrous_shared.h dn_depth_gradient).
std::vector<Vec2f> depth_gradients(const GuidedImage& img) {
  std::vector<Vec2f> g(img.valid.size(), Vec2f{0, 0});
  const shader::DenoiseImage im = img.shared();
  parallel_for(static_cast<size_t>(img.height), 8, [&](size_t y0, size_t y1) {
    for (int y = static_cast<int>(y0); y < static_cast<int>(y1); ++y)
      for (int x = 0; x < img.width; ++x)
        if (img.valid[img.index(x, y)]) g[img.index(x, y)] = shader::dn_depth_gradient(im, x, y);
  });
  return g;
}

}  // namespace

AtrousSettings atrous_settings_from(const ParamSet& p) {
  AtrousSettings s;
  s.iterations = p.get_int("iterations");
  s.sigma_z = p.get_float("sigma_z");
  s.sigma_n = p.get_float("sigma_n");
  s.sigma_l = p.get_float("sigma_l");
  return s;
}

void GuidedImage::resize(int w, int h) {
  width = w;
  height = h;
  const size_t n = static_cast<size_t>(w) * static_cast<size_t>(h);
  valid.assign(n, 0);
  depth.assign(n, 0.0f);
  normal.assign(n, Vec3f(0.0f));
  shadowed.assign(n, 0.0f);
  unshadowed.assign(n, 0.0f);
  area.assign(n, 0.0f);
  variance.assign(n, 0.0f);
}

shader::DenoiseImage GuidedImage::shared() const {
  return {width,           height,         1u,
          0u,              valid.data(),   depth.data(),
          normal.data(),   shadowed.data(), unshadowed.data(),
          area.data(),     variance.data()};
}

float GuidedImage::ratio(size_t i) const { return shader::dn_ratio(shared(), static_cast<uint32_t>(i)); }
float GuidedImage::visibility(size_t i) const { return shader::dn_visibility(shared(), static_cast<uint32_t>(i)); }

void estimate_variance_spatially(GuidedImage& img, const AtrousSettings& s) {
  const std::vector<Vec2f> grad = depth_gradients(img);
  std::vector<float> out(img.variance.size(), 0.0f);
  const shader::DenoiseImage im = img.shared();
  parallel_for(static_cast<size_t>(img.height), 4, [&](size_t y0, size_t y1) {
    for (int y = static_cast<int>(y0); y < static_cast<int>(y1); ++y)
      for (int x = 0; x < img.width; ++x)
        if (img.valid[img.index(x, y)])
          out[img.index(x, y)] = shader::dn_spatial_variance(im, grad.data(), x, y, shared_settings(s));
  });
  img.variance = std::move(out);
}

void atrous_filter(GuidedImage& img, const AtrousSettings& s) {
  if (s.iterations <= 0 || img.valid.empty()) return;
  const std::vector<Vec2f> grad = depth_gradients(img);
  const size_t n = img.valid.size();
  std::vector<float> next_s(n), next_u(n), next_a(n), next_var(n), prefiltered_var(n);
  const shader::DenoiseImage im = img.shared();
  for (int it = 0; it < s.iterations; ++it) {
    const int step = 1 << it;  // §4.2: the kernel's taps 2^i pixels apart
    parallel_for(static_cast<size_t>(img.height), 8, [&](size_t y0, size_t y1) {
      for (int y = static_cast<int>(y0); y < static_cast<int>(y1); ++y)
        for (int x = 0; x < img.width; ++x)
          if (img.valid[img.index(x, y)]) prefiltered_var[img.index(x, y)] = shader::dn_prefiltered_variance(im, x, y);
    });
    parallel_for(static_cast<size_t>(img.height), 4, [&](size_t y0, size_t y1) {
      for (int y = static_cast<int>(y0); y < static_cast<int>(y1); ++y)
        for (int x = 0; x < img.width; ++x) {
          const size_t p = img.index(x, y);
          if (!img.valid[p]) continue;
          const shader::DenoiseFiltered f =
              shader::dn_atrous(im, grad.data(), prefiltered_var[p], x, y, step, shared_settings(s));
          next_s[p] = f.shadowed;
          next_u[p] = f.unshadowed;
          next_a[p] = f.area;
          next_var[p] = f.variance;
        }
    });
    for (size_t i = 0; i < n; ++i) {
      if (!img.valid[i]) continue;
      img.shadowed[i] = next_s[i];
      img.unshadowed[i] = next_u[i];
      img.area[i] = next_a[i];
      img.variance[i] = next_var[i];
    }
  }
}

}  // namespace penumbra::denoise
