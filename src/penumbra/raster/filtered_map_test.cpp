// The prefiltered maps of filtered_map.h against brute-force box means.
#include "penumbra/raster/filtered_map.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "penumbra/core/rng.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// The exact mean of channel c over [x0, x1] x [y0, y1]: every texel weighted by its overlap,
// the outside part by `outside`.
double brute_mean(const ChannelImage& im, const float* outside, int c, double x0, double y0, double x1, double y1) {
  const double area = (x1 - x0) * (y1 - y0);
  double sum = 0, covered = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      const double ox = std::max(0.0, std::min(x1, x + 1.0) - std::max(x0, double(x)));
      const double oy = std::max(0.0, std::min(y1, y + 1.0) - std::max(y0, double(y)));
      sum += ox * oy * im.texels[(static_cast<size_t>(y) * im.width + x) * im.channels + c];
      covered += ox * oy;
    }
  return (sum + (area - covered) * outside[c]) / area;
}

TEST(FilteredMap, SummedAreaTableIsTheExactBoxMeanAnywhere) {
  const int w = 37, h = 23, C = 3;
  std::vector<float> texels(w * h * C);
  Rng rng(1, 2, 3);
  for (float& t : texels) t = rng.next_float();
  const float outside[C] = {1.0f, 0.25f, -2.0f};
  const ChannelImage im{w, h, C, texels};
  SummedAreaTable sat;
  sat.build(im, outside);
  for (int i = 0; i < 200; ++i) {
    // Rectangles of any size, some reaching out of the map.
    const double x0 = -5 + 45 * rng.next_float(), y0 = -5 + 30 * rng.next_float();
    const double x1 = x0 + 0.01 + 20 * rng.next_float(), y1 = y0 + 0.01 + 20 * rng.next_float();
    double m[C];
    sat.box_mean(x0, y0, x1, y1, m);
    for (int c = 0; c < C; ++c) EXPECT_NEAR(m[c], brute_mean(im, outside, c, x0, y0, x1, y1), 1e-9) << i << " " << c;
  }
}

TEST(FilteredMap, MipChainIsExactOnAlignedPowerOfTwoSquaresAndPadsWithTheOutsideValue) {
  const int w = 20, h = 16, C = 2;  // padded to 32 x 32
  std::vector<float> texels(w * h * C);
  Rng rng(4, 5, 6);
  for (float& t : texels) t = rng.next_float();
  const float outside[C] = {1.0f, 0.0f};
  const ChannelImage im{w, h, C, texels};
  MipChain mip;
  mip.build(im, outside);
  EXPECT_EQ(mip.levels(), 6);
  for (int side : {1, 2, 4, 8, 16, 32})
    for (int y = 0; y + side <= 32; y += side)
      for (int x = 0; x + side <= 32; x += side) {
        double m[C];
        mip.square_mean(x + 0.5f * side, y + 0.5f * side, static_cast<float>(side), m);
        for (int c = 0; c < C; ++c)
          ASSERT_NEAR(m[c], brute_mean(im, outside, c, x, y, x + side, y + side), 1e-5) << side << " " << x << " " << y;
      }
  EXPECT_LE(mip.memory_bytes(), MipChain::bytes(w, h, C));
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
