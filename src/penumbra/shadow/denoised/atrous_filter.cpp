#include "penumbra/shadow/denoised/atrous_filter.h"

#include <algorithm>
#include <cmath>

#include "penumbra/core/parallel.h"

namespace penumbra::denoise {
namespace {

// Keeps the weights finite where the depth does not change (a plane facing the camera) and
// where the variance is 0 (a fully lit or fully shadowed neighbourhood): §4.3's epsilon.
constexpr float kEpsilonDepth = 1e-6f;
constexpr float kEpsilonLuminance = 1e-4f;

// §4.2: the 1D B3-spline kernel (1/16, 1/4, 3/8, 1/4, 1/16); the 5x5 kernel is its product.
constexpr float kB3[5] = {1.0f / 16, 1.0f / 4, 3.0f / 8, 1.0f / 4, 1.0f / 16};

// The screen-space depth gradient (dz/dx, dz/dy) per pixel, each from the one-sided
// difference of smaller magnitude: SVGF takes the hardware derivative of clip-space depth
// inside a triangle; the smaller one-sided difference is that derivative wherever one side
// lies on the same surface, and never the jump across a depth discontinuity.
std::vector<Vec2f> depth_gradients(const GuidedImage& img) {
  std::vector<Vec2f> g(img.valid.size(), Vec2f{0, 0});
  parallel_for(static_cast<size_t>(img.height), 8, [&](size_t y0, size_t y1) {
    for (int y = static_cast<int>(y0); y < static_cast<int>(y1); ++y)
      for (int x = 0; x < img.width; ++x) {
        const size_t i = img.index(x, y);
        if (!img.valid[i]) continue;
        auto one_sided = [&](int dx, int dy) {
          float best = kInfinity;
          for (int sgn : {-1, 1}) {
            const int qx = x + sgn * dx, qy = y + sgn * dy;
            if (qx < 0 || qy < 0 || qx >= img.width || qy >= img.height) continue;
            const size_t j = img.index(qx, qy);
            if (!img.valid[j]) continue;
            const float d = (img.depth[j] - img.depth[i]) * sgn;
            if (std::abs(d) < std::abs(best)) best = d;
          }
          return best == kInfinity ? 0.0f : best;
        };
        g[i] = {one_sided(1, 0), one_sided(0, 1)};
      }
  });
  return g;
}

// §4.3 eq. 3 and 4: the depth and normal weights of q seen from p at pixel offset (dx, dy).
inline float geometry_weight(const GuidedImage& img, const std::vector<Vec2f>& grad, size_t p, size_t q, float dx,
                             float dy, const AtrousSettings& s) {
  const float expected = std::abs(grad[p].x * dx + grad[p].y * dy);
  const float w_z = std::exp(-std::abs(img.depth[p] - img.depth[q]) / (s.sigma_z * expected + kEpsilonDepth));
  const float w_n = std::pow(std::max(0.0f, dot(img.normal[p], img.normal[q])), s.sigma_n);
  return w_z * w_n;
}

}  // namespace

void GuidedImage::resize(int w, int h) {
  width = w;
  height = h;
  const size_t n = static_cast<size_t>(w) * static_cast<size_t>(h);
  valid.assign(n, 0);
  depth.assign(n, 0.0f);
  normal.assign(n, Vec3f(0.0f));
  shadowed.assign(n, 0.0f);
  unshadowed.assign(n, 0.0f);
  fallback.assign(n, 0.0f);
  variance.assign(n, 0.0f);
}

float GuidedImage::ratio(size_t i) const {
  const float v = unshadowed[i] > 0 ? shadowed[i] / unshadowed[i] : fallback[i];
  return std::clamp(v, 0.0f, 1.0f);
}

void estimate_variance_spatially(GuidedImage& img, const AtrousSettings& s) {
  const std::vector<Vec2f> grad = depth_gradients(img);
  std::vector<float> out(img.variance.size(), 0.0f);
  parallel_for(static_cast<size_t>(img.height), 4, [&](size_t y0, size_t y1) {
    for (int y = static_cast<int>(y0); y < static_cast<int>(y1); ++y)
      for (int x = 0; x < img.width; ++x) {
        const size_t p = img.index(x, y);
        if (!img.valid[p]) continue;
        double wsum = 0, m1 = 0, m2 = 0;
        for (int dy = -3; dy <= 3; ++dy)
          for (int dx = -3; dx <= 3; ++dx) {
            const int qx = x + dx, qy = y + dy;
            if (qx < 0 || qy < 0 || qx >= img.width || qy >= img.height) continue;
            const size_t q = img.index(qx, qy);
            if (!img.valid[q]) continue;
            const float w = geometry_weight(img, grad, p, q, static_cast<float>(dx), static_cast<float>(dy), s);
            const float v = img.ratio(q);
            wsum += w;
            m1 += w * v;
            m2 += w * v * v;
          }
        out[p] = wsum > 0 ? static_cast<float>(std::max(0.0, m2 / wsum - (m1 / wsum) * (m1 / wsum))) : 0.0f;
      }
  });
  img.variance = std::move(out);
}

void atrous_filter(GuidedImage& img, const AtrousSettings& s) {
  if (s.iterations <= 0 || img.valid.empty()) return;
  const std::vector<Vec2f> grad = depth_gradients(img);
  const size_t n = img.valid.size();
  std::vector<float> next_s(n), next_u(n), next_var(n), prefiltered_var(n);
  for (int it = 0; it < s.iterations; ++it) {
    const int step = 1 << it;  // §4.2: the kernel's taps 2^i pixels apart
    // §4.3 eq. 5: the luminance weight is scaled by the variance prefiltered by a 3x3
    // Gaussian (it is itself noisy).
    parallel_for(static_cast<size_t>(img.height), 8, [&](size_t y0, size_t y1) {
      constexpr float g3[3] = {0.25f, 0.5f, 0.25f};
      for (int y = static_cast<int>(y0); y < static_cast<int>(y1); ++y)
        for (int x = 0; x < img.width; ++x) {
          const size_t p = img.index(x, y);
          if (!img.valid[p]) continue;
          float sum = 0, wsum = 0;
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              const int qx = x + dx, qy = y + dy;
              if (qx < 0 || qy < 0 || qx >= img.width || qy >= img.height) continue;
              const size_t q = img.index(qx, qy);
              if (!img.valid[q]) continue;
              const float w = g3[dx + 1] * g3[dy + 1];
              sum += w * img.variance[q];
              wsum += w;
            }
          prefiltered_var[p] = sum / wsum;
        }
    });
    parallel_for(static_cast<size_t>(img.height), 4, [&](size_t y0, size_t y1) {
      for (int y = static_cast<int>(y0); y < static_cast<int>(y1); ++y)
        for (int x = 0; x < img.width; ++x) {
          const size_t p = img.index(x, y);
          if (!img.valid[p]) continue;
          const float v_p = img.ratio(p);
          const float l_scale = s.sigma_l * std::sqrt(prefiltered_var[p]) + kEpsilonLuminance;
          double ws = 0, wu = 0, wvar = 0, wsum = 0;
          for (int ky = -2; ky <= 2; ++ky)
            for (int kx = -2; kx <= 2; ++kx) {
              const int qx = x + kx * step, qy = y + ky * step;
              if (qx < 0 || qy < 0 || qx >= img.width || qy >= img.height) continue;
              const size_t q = img.index(qx, qy);
              if (!img.valid[q]) continue;
              const float w_l = std::exp(-std::abs(v_p - img.ratio(q)) / l_scale);
              const float w = kB3[kx + 2] * kB3[ky + 2] *
                              geometry_weight(img, grad, p, q, static_cast<float>(kx * step),
                                              static_cast<float>(ky * step), s) *
                              w_l;
              ws += w * img.shadowed[q];
              wu += w * img.unshadowed[q];
              wvar += static_cast<double>(w) * w * img.variance[q];  // §4.2: variance with w^2
              wsum += w;
            }
          // The centre tap has weight kB3[2]^2 > 0 (w_z = w_n = w_l = 1): wsum > 0.
          next_s[p] = static_cast<float>(ws / wsum);
          next_u[p] = static_cast<float>(wu / wsum);
          next_var[p] = static_cast<float>(wvar / (wsum * wsum));
        }
    });
    for (size_t i = 0; i < n; ++i) {
      if (!img.valid[i]) continue;
      img.shadowed[i] = next_s[i];
      img.unshadowed[i] = next_u[i];
      img.variance[i] = next_var[i];
    }
  }
}

}  // namespace penumbra::denoise
