#include "penumbra/scene/texture.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "penumbra/core/error.h"
#include "penumbra/core/image.h"
#include "penumbra/core/testing.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

namespace fs = std::filesystem;

// An n x n checkerboard: alpha 1 on texels with (x + y) even, 0 elsewhere; colour = (x, y, 0) / n.
Texture checkerboard(int n) {
  std::vector<float> rgba(static_cast<size_t>(n) * n * 4);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      float* t = &rgba[(static_cast<size_t>(y) * n + x) * 4];
      t[0] = static_cast<float>(x) / n, t[1] = static_cast<float>(y) / n, t[2] = 0;
      t[3] = (x + y) % 2 == 0 ? 1.0f : 0.0f;
    }
  return Texture(n, n, std::move(rgba), true, "checkerboard");
}

// The centre of texel (x, y) (row 0 at the top) in texture coordinates.
Vec2f centre(int x, int y, int n) { return {(x + 0.5f) / n, 1.0f - (y + 0.5f) / n}; }

TEST(Texture, TexelCentresReadTheirTexelRowZeroAtTheTop) {
  const Texture t = checkerboard(4);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) {
      const Vec3f c = t.rgb(centre(x, y, 4));
      EXPECT_NEAR(c.x, x / 4.0f, 1e-6f);
      EXPECT_NEAR(c.y, y / 4.0f, 1e-6f);
      EXPECT_NEAR(t.alpha(centre(x, y, 4)), (x + y) % 2 == 0 ? 1.0f : 0.0f, 1e-6f);
    }
}

TEST(Texture, BilinearBetweenCentresAndRepeatOutside) {
  const Texture t = checkerboard(4);
  // Half-way between texels (0, 0) and (1, 0): the mean of their values.
  EXPECT_NEAR(t.rgb({0.25f, 1.0f - 0.125f}).x, 0.5f * (0 + 0.25f), 1e-6f);
  EXPECT_NEAR(t.alpha({0.25f, 1.0f - 0.125f}), 0.5f, 1e-6f);
  // Repeat: whole periods away reads the same.
  for (Vec2f uv : {Vec2f{0.3f, 0.7f}, Vec2f{0.9f, 0.1f}}) {
    EXPECT_NEAR(t.alpha(uv + Vec2f{2, -3}), t.alpha(uv), 1e-5f);
    EXPECT_NEAR(t.rgb(uv + Vec2f{-1, 1}).x, t.rgb(uv).x, 1e-5f);
  }
  // Across the wrap the edge texels blend: u = 0 is between texel 3 and texel 0 of a row.
  EXPECT_NEAR(t.alpha({0.0f, 1.0f - 0.125f}), 0.5f, 1e-6f);
}

// A two-valued checkerboard thresholded at 0.5 after bilinear filtering has its edges exactly
// on the texel borders, corners included (f - 0.5 changes sign with x y around a corner): the
// mask a renderer sees is the checkerboard itself.
TEST(Texture, MaskOfACheckerboardIsTheCheckerboard) {
  const Texture t = checkerboard(8);
  const auto tex = std::make_shared<const Texture>(t);
  const SurfaceAlpha mask{tex, AlphaMode::Mask, 0.5f};
  int wrong = 0;
  for (int j = 0; j < 200; ++j)
    for (int i = 0; i < 200; ++i) {
      const Vec2f uv{(i + 0.37f) / 200, (j + 0.61f) / 200};
      const int x = static_cast<int>(uv.x * 8), y = static_cast<int>((1 - uv.y) * 8);
      wrong += mask.opacity(uv) != ((x + y) % 2 == 0 ? 1.0f : 0.0f);
    }
  EXPECT_EQ(wrong, 0);
  // Half of any whole number of periods is solid; blend averages alpha.
  // (Not a triangle with an edge on u = 1: that is the repeat seam, where texels 7 and 0 blend.)
  const Vec2f tri[3] = {{0, 0}, {1, 0}, {0, 1}};
  EXPECT_NEAR(mask.mean_opacity(tri, 64), 0.5f, 0.02f);
  const SurfaceAlpha blend{tex, AlphaMode::Blend, 0.5f};
  EXPECT_NEAR(blend.mean_opacity(tri, 64), 0.5f, 0.02f);
  EXPECT_FLOAT_EQ(blend.opacity({0.25f, 1.0f - 0.125f}), 0.5f);
  // Camera rays: seen where alpha reaches the cutoff, in both modes.
  EXPECT_TRUE(mask.seen(centre(0, 0, 8)));
  EXPECT_FALSE(blend.seen(centre(1, 0, 8)));
  const SurfaceAlpha opaque{tex, AlphaMode::Opaque, 0.5f};
  EXPECT_EQ(opaque.opacity(centre(1, 0, 8)), 1.0f);
  EXPECT_FALSE(opaque.active());
}

TEST(Texture, PngRoundTripKeepsAlphaAndDecodesSrgbColour) {
  const test::TempDir dir("texture_png");
  const std::string path = (dir / "leaf.png").string();
  checkerboard(4).write_png(path);
  const auto srgb = Texture::load(path, Texture::Encoding::Srgb);
  const auto linear = Texture::load(path, Texture::Encoding::Linear);
  ASSERT_EQ(srgb->width(), 4);
  EXPECT_TRUE(srgb->has_alpha());
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) {
      EXPECT_NEAR(srgb->alpha(centre(x, y, 4)), (x + y) % 2 == 0 ? 1.0f : 0.0f, 1e-6f);
      EXPECT_NEAR(srgb->rgb(centre(x, y, 4)).x, x / 4.0f, 0.01f);  // 8 bits of sRGB
      // Read as linear data, the stored bytes are the sRGB encoding of the value.
      EXPECT_NEAR(linear->rgb(centre(x, y, 4)).x, linear_to_srgb(x / 4.0f), 1.0f / 255);
    }
}

TEST(Texture, GreyImageWithoutAlphaIsItsOwnMask) {
  std::vector<float> rgba = {0.2f, 0.2f, 0.2f, 1, 0.9f, 0.9f, 0.9f, 1};
  const Texture t(2, 1, rgba, false, "grey");
  EXPECT_FALSE(t.has_alpha());
  EXPECT_NEAR(t.alpha({0.25f, 0.5f}), 0.2f, 1e-6f);
  EXPECT_NEAR(t.alpha({0.75f, 0.5f}), 0.9f, 1e-6f);
}

TEST(Texture, BadFilesGiveOneLineErrorsNamingThem) {
  const test::TempDir dir("texture_bad");
  const std::string missing = (dir / "nope.png").string();
  auto message = [](const fs::path& p) {
    return test::error_message([&] { Texture::load(p, Texture::Encoding::Srgb); });
  };
  EXPECT_EQ(message(missing), missing + ": no such file");
  const fs::path garbage = dir / "garbage.png";
  std::ofstream(garbage) << "not an image";
  EXPECT_EQ(message(garbage).rfind(garbage.string() + ": cannot read image", 0), 0u) << message(garbage);
  EXPECT_NE(message(dir.path()).find("is a folder"), std::string::npos);
  EXPECT_THROW(Texture(2, 2, std::vector<float>(3), true, "short"), Error);
  EXPECT_EQ(message("/dev/null"), "/dev/null: not a regular file");
  // A PNG header claiming 100000 x 1 texels is refused before decoding.
  const unsigned char wide[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13, 'I', 'H', 'D', 'R',
                                0, 1, 0x86, 0xa0, 0, 0, 0, 1, 8, 6, 0, 0, 0, 0, 0, 0, 0};
  const std::string huge = test::error_message([&] { Texture::decode(wide, Texture::Encoding::Srgb, "wide.png"); });
  EXPECT_NE(huge.find("wide.png: a 100000x1 image; textures are read up to 8192x8192"), std::string::npos) << huge;
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
