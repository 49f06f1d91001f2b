// FLIP (Andersson et al. 2020), LDR version. The pipeline, per pixel of two images:
//
//   colour:  linear sRGB -> XYZ -> YyCxCz opponent space
//            -> contrast sensitivity filter per channel (sum of Gaussians, in degrees)
//            -> XYZ -> linear sRGB, clamped to [0,1] -> XYZ -> CIELAB -> Hunt-adjusted
//            -> HyAB distance -> ^qc -> piecewise-linear remap to [0,1]      = dE_c
//   feature: achromatic channel Y/Yn -> Gaussian first / second derivative filters
//            -> |edge| and |point| magnitudes -> normalized difference ^qf  = dE_f
//   FLIP = dE_c ^ (1 - dE_f)
//
// Constants are cited where they are defined below. Section names rather than numbers
// are cited for the paper ("Color Pipeline", "Feature Pipeline", ...).
#include "penumbra/eval/flip.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"

namespace penumbra {

float flip_pixels_per_degree(float distance_m, float width_m, float resolution_px) {
  // A pixel of width w/r metres at distance d subtends (w/r)/d radians (small angle).
  return distance_m * (resolution_px / width_m) * (kPi / 180.0f);
}

// Andersson et al. 2020, default viewing conditions: d = 0.7 m, w = 0.7 m, r = 3840 px.
float flip_default_ppd() { return flip_pixels_per_degree(0.7f, 0.7f, 3840.0f); }

namespace {

// --- Constants ---------------------------------------------------------------------

// Linear sRGB (Rec. 709 primaries, D65) to CIE XYZ, IEC 61966-2-1 / Lindbloom. The
// reference white (Xn, Yn, Zn) is this matrix applied to RGB (1,1,1), so that grey is
// exactly achromatic (a* = b* = Cx = Cz = 0) and round trips are consistent.
constexpr double kRgbToXyz[3][3] = {{0.4124564, 0.3575761, 0.1804375},
                                    {0.2126729, 0.7151522, 0.0721750},
                                    {0.0193339, 0.1191920, 0.9503041}};

// Contrast sensitivity functions, Andersson et al. 2020, "Color Pipeline", Table 1
// (after Johnson & Fairchild / Movshon & Kiorpes): in the frequency domain
// S(f) = a1 exp(-b1 f^2) + a2 exp(-b2 f^2), f in cycles per degree; in the spatial domain
// s(x) = sum_i a_i sqrt(pi / b_i) exp(-pi^2 x^2 / b_i), x in degrees (its Fourier pair).
// a2 = 0 for the achromatic and red-green channels: one Gaussian each.
struct CsfParams {
  double a1, b1, a2, b2;
};
constexpr CsfParams kCsfA = {1.0, 0.0047, 0.0, 1e-5};    // achromatic (Yy)
constexpr CsfParams kCsfRG = {1.0, 0.0053, 0.0, 1e-5};   // red-green (Cx)
constexpr CsfParams kCsfBY = {34.1, 0.04, 13.5, 0.025};  // blue-yellow (Cz)
// The filter radius covers 3 standard deviations of the widest Gaussian (b = 0.04):
// a Gaussian exp(-pi^2 x^2 / b) has std sqrt(b / (2 pi^2)) degrees.
constexpr double kCsfMaxB = 0.04;

// Colour difference exponent and remapping, Andersson et al. 2020, "Color Pipeline":
// dE_hyab is raised to qc = 0.7 (compresses large differences); errors below
// pc * cmax map linearly onto [0, pt], the rest linearly onto [pt, 1], where cmax is the
// (exponentiated) HyAB distance between Hunt-adjusted green and blue, the largest
// distance between sRGB primaries.
constexpr double kQc = 0.7;
constexpr double kPc = 0.4;
constexpr double kPt = 0.95;

// Feature detectors, Andersson et al. 2020, "Feature Pipeline": Gaussian derivative
// filters with std sigma = 0.5 * w * ppd pixels, w = 0.082 degrees (the distance between
// the extrema of the edge filter, matched to the achromatic CSF), radius 3 sigma; the
// feature difference is raised to qf = 0.5.
constexpr double kFeatureW = 0.082;
constexpr double kQf = 0.5;

// --- Colour transforms ----------------------------------------------------------------

struct ColorSpace {
  double to_xyz[3][3];
  double to_rgb[3][3];
  double white[3];  // Xn, Yn, Zn
};

const ColorSpace& color_space() {
  static const ColorSpace cs = [] {
    ColorSpace c{};
    for (int i = 0; i < 3; ++i) {
      c.white[i] = 0;
      for (int j = 0; j < 3; ++j) {
        c.to_xyz[i][j] = kRgbToXyz[i][j];
        c.white[i] += kRgbToXyz[i][j];
      }
    }
    // Inverse by cofactors (the matrix is well conditioned).
    const auto& m = kRgbToXyz;
    double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                 m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                 m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        int i1 = (j + 1) % 3, i2 = (j + 2) % 3, j1 = (i + 1) % 3, j2 = (i + 2) % 3;
        c.to_rgb[i][j] = (m[i1][j1] * m[i2][j2] - m[i1][j2] * m[i2][j1]) / det;
      }
    return c;
  }();
  return cs;
}

inline std::array<double, 3> mul(const double m[3][3], double x, double y, double z) {
  return {m[0][0] * x + m[0][1] * y + m[0][2] * z, m[1][0] * x + m[1][1] * y + m[1][2] * z,
          m[2][0] * x + m[2][1] * y + m[2][2] * z};
}

// CIELAB's cube-root response with its linear segment near black (CIE 15).
inline double lab_f(double t) {
  constexpr double d = 6.0 / 29.0;
  return t > d * d * d ? std::cbrt(t) : t / (3 * d * d) + 4.0 / 29.0;
}

// Linear sRGB (already clamped to [0,1]) -> Hunt-adjusted L*a*b*. Andersson et al. 2020,
// "Color Pipeline": the Hunt effect (chroma appears stronger at higher luminance) is
// modelled as a_H = 0.01 L* a*, b_H = 0.01 L* b*; L* is kept.
inline std::array<double, 3> hunt_lab(double r, double g, double b) {
  const ColorSpace& cs = color_space();
  auto xyz = mul(cs.to_xyz, r, g, b);
  double fx = lab_f(xyz[0] / cs.white[0]), fy = lab_f(xyz[1] / cs.white[1]),
         fz = lab_f(xyz[2] / cs.white[2]);
  double L = 116 * fy - 16, A = 500 * (fx - fy), B = 200 * (fy - fz);
  return {L, 0.01 * L * A, 0.01 * L * B};
}

// HyAB distance (Abasi et al. 2020, adopted in Andersson et al. 2020, "Color Pipeline"):
// city-block in lightness plus Euclidean in chroma, better than CIEDE2000 for large
// differences.
inline double hyab(const std::array<double, 3>& p, const std::array<double, 3>& q) {
  double da = p[1] - q[1], db = p[2] - q[2];
  return std::abs(p[0] - q[0]) + std::sqrt(da * da + db * db);
}

// cmax: Andersson et al. 2020, "Color Pipeline": the largest HyAB^qc distance between
// the sRGB primaries, found between green and blue (about 41.28).
double flip_cmax() {
  static const double c = std::pow(hyab(hunt_lab(0, 1, 0), hunt_lab(0, 0, 1)), kQc);
  return c;
}

// The remap of Andersson et al. 2020, "Color Pipeline": [0, pc cmax) -> [0, pt) and
// [pc cmax, cmax] -> [pt, 1], both linear; clamped at 1 for safety (cmax is the largest
// distance in gamut, and the inputs are clamped to the gamut).
inline double remap_color(double e_hyab, double cmax) {
  double e = std::pow(e_hyab, kQc);
  double knee = kPc * cmax;
  double v = e < knee ? (kPt / knee) * e : kPt + (e - knee) / (cmax - knee) * (1 - kPt);
  return std::min(1.0, v);
}

// --- Planes and separable filters -------------------------------------------------------

struct Plane {
  int w = 0, h = 0;
  std::vector<float> v;
  Plane() = default;
  Plane(int w_, int h_) : w(w_), h(h_), v(size_t(w_) * h_, 0.0f) {}
  float* row(int y) { return v.data() + size_t(y) * w; }
  const float* row(int y) const { return v.data() + size_t(y) * w; }
};

// 1-D convolution along rows, borders clamped to the edge pixel. The kernel has odd size
// 2r+1 and is applied as correlation (k[j] weights in[x + j - r]); every kernel here is
// symmetric or antisymmetric, and the feature magnitudes do not depend on the sign.
// `zero_sum` kernels (the derivative filters) are applied as sum_j k[j] (in[x+j-r] - in[x]),
// equal in exact arithmetic since sum_j k[j] = 0, but exactly 0 on constant regions in
// floating point too: the feature difference is raised to qf = 0.5, which would turn a
// rounding residual of 1e-8 into a visible 1e-4.
void filter_rows(const Plane& in, Plane& out, const std::vector<float>& k, bool zero_sum = false) {
  const int r = int(k.size()) / 2, w = in.w;
  parallel_for(in.h, 16, [&](size_t y0, size_t y1) {
    std::vector<float> pad(w + 2 * r), acc(w);
    for (size_t y = y0; y < y1; ++y) {
      const float* src = in.row(int(y));
      for (int x = 0; x < w + 2 * r; ++x) pad[x] = src[std::clamp(x - r, 0, w - 1)];
      std::fill(acc.begin(), acc.end(), 0.0f);
      const float* centre = pad.data() + r;
      for (int j = 0; j <= 2 * r; ++j) {
        const float kj = k[j];
        const float* p = pad.data() + j;
        if (zero_sum)
          for (int x = 0; x < w; ++x) acc[x] += kj * (p[x] - centre[x]);
        else
          for (int x = 0; x < w; ++x) acc[x] += kj * p[x];  // vectorizes over x
      }
      std::copy(acc.begin(), acc.end(), out.row(int(y)));
    }
  });
}

// 1-D convolution along columns, clamped borders: each output row is a weighted sum of
// input rows, so the inner loop runs along memory. `zero_sum` as in filter_rows.
void filter_cols(const Plane& in, Plane& out, const std::vector<float>& k, bool zero_sum = false) {
  const int r = int(k.size()) / 2, w = in.w, h = in.h;
  parallel_for(h, 16, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y < y1; ++y) {
      float* dst = out.row(int(y));
      const float* centre = in.row(int(y));
      std::fill(dst, dst + w, 0.0f);
      for (int j = 0; j <= 2 * r; ++j) {
        const float kj = k[j];
        const float* src = in.row(std::clamp(int(y) + j - r, 0, h - 1));
        if (zero_sum)
          for (int x = 0; x < w; ++x) dst[x] += kj * (src[x] - centre[x]);
        else
          for (int x = 0; x < w; ++x) dst[x] += kj * src[x];
      }
    }
  });
}

// in * (kx along rows, then ky along columns).
Plane filter_separable(const Plane& in, const std::vector<float>& kx,
                       const std::vector<float>& ky) {
  Plane tmp(in.w, in.h), out(in.w, in.h);
  filter_rows(in, tmp, kx);
  filter_cols(tmp, out, ky);
  return out;
}

// A contrast sensitivity filter as a weighted sum of separable normalized Gaussians.
struct CsfFilter {
  std::vector<std::vector<float>> gaussians;  // 1-D, each summing to 1
  std::vector<float> weights;                 // summing to 1
};

// The 2-D kernel s(sqrt(x^2 + y^2)) of the spatial CSF (see kCsfA), sampled at pixel
// centres x = i / ppd degrees for |i|, |j| <= radius and normalized to sum 1, as
// Andersson et al. 2020 ("Color Pipeline") normalize the filters. Each term
// a sqrt(pi/b) exp(-pi^2 (x^2+y^2)/b) = a sqrt(pi/b) g(x) g(y) is separable, so the
// normalized kernel is sum_i c_i (g_i/|g_i|) x (g_i/|g_i|), c_i = a_i sqrt(pi/b_i) |g_i|^2 / Z,
// with |g| the sum of the 1-D samples and Z the sum of the whole 2-D kernel.
CsfFilter make_csf(const CsfParams& p, double ppd, int radius) {
  CsfFilter f;
  double terms[2][2] = {{p.a1, p.b1}, {p.a2, p.b2}};
  std::vector<double> raw_weight;
  for (auto& t : terms) {
    double a = t[0], b = t[1];
    if (a == 0) continue;
    std::vector<double> g(2 * radius + 1);
    double sum = 0;
    for (int i = -radius; i <= radius; ++i) {
      double x = i / ppd;
      g[i + radius] = std::exp(-kPi * kPi * x * x / b);
      sum += g[i + radius];
    }
    std::vector<float> gn(g.size());
    for (size_t i = 0; i < g.size(); ++i) gn[i] = float(g[i] / sum);
    f.gaussians.push_back(gn);
    raw_weight.push_back(a * std::sqrt(kPi / b) * sum * sum);
  }
  double z = 0;
  for (double w : raw_weight) z += w;
  for (double w : raw_weight) f.weights.push_back(float(w / z));
  return f;
}

Plane apply_csf(const Plane& in, const CsfFilter& f) {
  if (f.gaussians.size() == 1) return filter_separable(in, f.gaussians[0], f.gaussians[0]);
  Plane out(in.w, in.h);
  for (size_t t = 0; t < f.gaussians.size(); ++t) {
    Plane part = filter_separable(in, f.gaussians[t], f.gaussians[t]);
    const float wt = f.weights[t];
    for (size_t i = 0; i < out.v.size(); ++i) out.v[i] += wt * part.v[i];
  }
  return out;
}

// Feature kernels (Andersson et al. 2020, "Feature Pipeline"): a Gaussian g, its first
// derivative (edges) and its second derivative (points), sampled on |i| <= ceil(3 sigma).
// Normalization: g sums to 1; each derivative kernel's positive weights sum to 1 and its
// negative weights to -1. The 2-D kernels are d(x) g(y) and a(x) g(y) (and transposes),
// whose positive/negative parts are then also normalized to +1/-1, so a constant image
// gives exactly 0 and, on inputs in [0,1], each filter response lies in [-1, 1].
struct FeatureKernels {
  std::vector<float> gauss, d1, d2;
};

std::vector<float> normalize_signed(const std::vector<double>& k) {
  double pos = 0, neg = 0;
  for (double v : k) (v > 0 ? pos : neg) += v;
  std::vector<float> out(k.size());
  for (size_t i = 0; i < k.size(); ++i)
    out[i] = float(k[i] > 0 ? k[i] / pos : (k[i] < 0 ? k[i] / -neg : 0.0));
  return out;
}

FeatureKernels make_feature_kernels(double ppd) {
  const double sigma = 0.5 * kFeatureW * ppd;
  const int radius = std::max(1, int(std::ceil(3 * sigma)));
  std::vector<double> g(2 * radius + 1), d1(g.size()), d2(g.size());
  double gsum = 0;
  for (int i = -radius; i <= radius; ++i) {
    double x = i, gi = std::exp(-x * x / (2 * sigma * sigma));
    g[i + radius] = gi;
    gsum += gi;
    d1[i + radius] = -x / (sigma * sigma) * gi;
    d2[i + radius] = (x * x / (sigma * sigma) - 1) / (sigma * sigma) * gi;
  }
  FeatureKernels k;
  k.gauss.resize(g.size());
  for (size_t i = 0; i < g.size(); ++i) k.gauss[i] = float(g[i] / gsum);
  k.d1 = normalize_signed(d1);
  k.d2 = normalize_signed(d2);
  return k;
}

// Edge and point magnitudes of an achromatic plane: |(d1 x g, g x d1) * I| and
// |(d2 x g, g x d2) * I| (Andersson et al. 2020, "Feature Pipeline").
void features(const Plane& y, const FeatureKernels& k, Plane& edge, Plane& point) {
  Plane hd(y.w, y.h), hg(y.w, y.h), ha(y.w, y.h);
  filter_rows(y, hd, k.d1, true);
  filter_rows(y, hg, k.gauss);
  filter_rows(y, ha, k.d2, true);
  Plane ex(y.w, y.h), ey(y.w, y.h), px(y.w, y.h), py(y.w, y.h);
  filter_cols(hd, ex, k.gauss);
  filter_cols(hg, ey, k.d1, true);
  filter_cols(ha, px, k.gauss);
  filter_cols(hg, py, k.d2, true);
  edge = Plane(y.w, y.h);
  point = Plane(y.w, y.h);
  for (size_t i = 0; i < y.v.size(); ++i) {
    edge.v[i] = std::sqrt(ex.v[i] * ex.v[i] + ey.v[i] * ey.v[i]);
    point.v[i] = std::sqrt(px.v[i] * px.v[i] + py.v[i] * py.v[i]);
  }
}

// Input image -> YyCxCz planes (Zhang & Wandell 1997, as used by Andersson et al. 2020,
// "Color Pipeline"): Yy = 116 Y/Yn - 16, Cx = 500 (X/Xn - Y/Yn), Cz = 200 (Y/Yn - Z/Zn);
// the linear counterpart of CIELAB, so the CSF filters act on a linear signal. Inputs
// are clamped to [0,1] (LDR-FLIP); one-channel images are grey.
void to_opponent(const Image& im, Plane& yy, Plane& cx, Plane& cz) {
  const ColorSpace& cs = color_space();
  yy = Plane(im.width(), im.height());
  cx = Plane(im.width(), im.height());
  cz = Plane(im.width(), im.height());
  parallel_for(im.pixel_count(), 4096, [&](size_t i0, size_t i1) {
    for (size_t i = i0; i < i1; ++i) {
      const float* p = im.pixel(i);
      double r = clamp01(p[0]), g = im.channels() >= 3 ? clamp01(p[1]) : r,
             b = im.channels() >= 3 ? clamp01(p[2]) : r;
      auto xyz = mul(cs.to_xyz, r, g, b);
      double xn = xyz[0] / cs.white[0], yn = xyz[1] / cs.white[1], zn = xyz[2] / cs.white[2];
      yy.v[i] = float(116 * yn - 16);
      cx.v[i] = float(500 * (xn - yn));
      cz.v[i] = float(200 * (yn - zn));
    }
  });
}

}  // namespace

FlipResult flip(const Image& test, const Image& reference, const FlipOptions& options) {
  if (test.width() != reference.width() || test.height() != reference.height())
    throw Error("FLIP needs images of equal size: test is {}x{}, reference is {}x{}",
                test.width(), test.height(), reference.width(), reference.height());
  if (test.empty()) throw Error("FLIP: empty images");
  if (test.channels() != 1 && test.channels() < 3)
    throw Error("FLIP: test image has {} channels, needs 1 or >= 3", test.channels());
  if (reference.channels() != 1 && reference.channels() < 3)
    throw Error("FLIP: reference image has {} channels, needs 1 or >= 3", reference.channels());
  if (!(options.ppd > 0)) throw Error("FLIP: pixels per degree must be > 0, got {}", options.ppd);

  const int w = test.width(), h = test.height();
  const double ppd = options.ppd;
  const int csf_radius =
      std::max(1, int(std::ceil(3 * std::sqrt(kCsfMaxB / (2 * kPi * kPi)) * ppd)));
  const CsfFilter csf[3] = {make_csf(kCsfA, ppd, csf_radius), make_csf(kCsfRG, ppd, csf_radius),
                            make_csf(kCsfBY, ppd, csf_radius)};
  const FeatureKernels fk = make_feature_kernels(ppd);
  const double cmax = flip_cmax();

  // Per image: filtered opponent planes and feature magnitudes.
  struct Prepared {
    Plane yy, cx, cz, edge, point;
  };
  auto prepare = [&](const Image& im) {
    Prepared p;
    Plane yy, cx, cz;
    to_opponent(im, yy, cx, cz);
    // Feature pipeline input: the unfiltered achromatic channel normalized to [0,1],
    // (Yy + 16) / 116 = Y/Yn (the paper's erratum: division by 116, not 100).
    Plane ynorm(w, h);
    for (size_t i = 0; i < yy.v.size(); ++i) ynorm.v[i] = (yy.v[i] + 16.0f) / 116.0f;
    features(ynorm, fk, p.edge, p.point);
    p.yy = apply_csf(yy, csf[0]);
    p.cx = apply_csf(cx, csf[1]);
    p.cz = apply_csf(cz, csf[2]);
    return p;
  };
  const Prepared t = prepare(test), r = prepare(reference);

  FlipResult result;
  result.error = Image(w, h, 1);
  if (options.keep_components) {
    result.color = Image(w, h, 1);
    result.feature = Image(w, h, 1);
  }
  const ColorSpace& cs = color_space();
  // Filtered YyCxCz -> XYZ -> linear RGB clamped to [0,1] -> Hunt-adjusted L*a*b*
  // (Andersson et al. 2020, "Color Pipeline": the filtered colours may leave the gamut).
  auto filtered_lab = [&](const Prepared& p, size_t i) {
    double yn = (p.yy.v[i] + 16.0) / 116.0;
    double xn = p.cx.v[i] / 500.0 + yn, zn = yn - p.cz.v[i] / 200.0;
    auto rgb = mul(cs.to_rgb, xn * cs.white[0], yn * cs.white[1], zn * cs.white[2]);
    return hunt_lab(std::clamp(rgb[0], 0.0, 1.0), std::clamp(rgb[1], 0.0, 1.0),
                    std::clamp(rgb[2], 0.0, 1.0));
  };
  std::vector<double> row_sums(h, 0.0);
  parallel_for(h, 8, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y < y1; ++y) {
      double sum = 0;
      for (int x = 0; x < w; ++x) {
        size_t i = y * w + x;
        double dc = remap_color(hyab(filtered_lab(t, i), filtered_lab(r, i)), cmax);
        // Feature difference (Andersson et al. 2020, "Feature Pipeline"): the larger of the
        // edge and point magnitude differences, over sqrt(2) (each magnitude is at most
        // sqrt(2) with the kernels normalized as above), raised to qf.
        double de = std::abs(double(t.edge.v[i]) - r.edge.v[i]);
        double dp = std::abs(double(t.point.v[i]) - r.point.v[i]);
        double df = std::pow(std::min(1.0, std::max(de, dp) / std::sqrt(2.0)), kQf);
        // Final difference (Andersson et al. 2020, "Final Difference Map"): features act
        // as an exponent, raising the colour error towards 1 where structure differs.
        double e = std::pow(dc, 1.0 - df);
        result.error.data()[i] = float(e);
        if (options.keep_components) {
          result.color.data()[i] = float(dc);
          result.feature.data()[i] = float(df);
        }
        sum += e;
      }
      row_sums[y] = sum;
    }
  });
  double total = 0;
  for (double s : row_sums) total += s;  // row order: thread-count independent
  result.mean = total / double(size_t(w) * h);
  return result;
}

}  // namespace penumbra
