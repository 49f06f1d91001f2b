#include "penumbra/eval/report_util.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

TEST(ReportUtil, Base64Rfc4648Vectors) {
  EXPECT_EQ(base64_encode(""), "");
  EXPECT_EQ(base64_encode("f"), "Zg==");
  EXPECT_EQ(base64_encode("fo"), "Zm8=");
  EXPECT_EQ(base64_encode("foo"), "Zm9v");
  EXPECT_EQ(base64_encode("foob"), "Zm9vYg==");
  EXPECT_EQ(base64_encode("fooba"), "Zm9vYmE=");
  EXPECT_EQ(base64_encode("foobar"), "Zm9vYmFy");
  const unsigned char bytes[] = {0xff, 0xfe, 0x00, 0x3e, 0x3f};
  EXPECT_EQ(base64_encode(bytes, sizeof bytes), "//4APj8=");
}

TEST(ReportUtil, PngInMemoryDecodesToTheSamePixels) {
  Image img(3, 2, 3);
  for (size_t i = 0; i < img.data().size(); ++i) img.data()[i] = static_cast<float>(i) / 17.0f;
  std::vector<unsigned char> png = encode_png(img);
  ASSERT_GT(png.size(), 8u);
  EXPECT_EQ(std::string(png.begin(), png.begin() + 8), std::string("\x89PNG\r\n\x1a\n", 8));
  auto path = std::filesystem::temp_directory_path() / ("penumbra-png-" + std::to_string(::getpid()) + ".png");
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(png.data()), png.size());
  Image back = read_image(path.string());
  std::filesystem::remove(path);
  ASSERT_EQ(back.width(), 3);
  ASSERT_EQ(back.height(), 2);
  for (size_t i = 0; i < img.data().size(); ++i)
    EXPECT_NEAR(back.data()[i], std::min(1.0f, img.data()[i]), 0.01f) << i;  // 8-bit sRGB round trip
  EXPECT_EQ(png_data_uri(img).rfind("data:image/png;base64,iVBORw0KGgo", 0), 0u);
  Image grey(2, 2, 1, 0.5f);
  std::vector<unsigned char> g = encode_png(grey, /*linear=*/true);
  EXPECT_GT(g.size(), 8u);
  EXPECT_THROW(encode_png(Image()), Error);
}

TEST(ReportUtil, Formatting) {
  EXPECT_EQ(xml_escape("a<b & \"c\" 'd'>"), "a&lt;b &amp; &quot;c&quot; &#39;d&#39;&gt;");
  EXPECT_EQ(format_significant(0.0031234), "0.00312");
  EXPECT_EQ(format_significant(1234.6), "1235");  // no exponent for large values
  EXPECT_EQ(format_significant(12.345), "12.3");
  EXPECT_EQ(format_significant(0.09996), "0.100");
  EXPECT_EQ(format_significant(-0.5), "-0.500");
  EXPECT_EQ(format_significant(0), "0");
  EXPECT_EQ(format_significant(3.2e-6), "3.20e-06");
  EXPECT_EQ(format_significant(INFINITY), "inf");
  EXPECT_EQ(format_significant(NAN), "nan");
  EXPECT_EQ(format_grouped(0), "0");
  EXPECT_EQ(format_grouped(999), "999");
  EXPECT_EQ(format_grouped(1000), "1,000");
  EXPECT_EQ(format_grouped(12345678), "12,345,678");
  EXPECT_EQ(format_bytes(512), "512 B");
  EXPECT_EQ(format_bytes(1536), "1.50 KiB");
  EXPECT_EQ(format_bytes(3u << 20), "3.00 MiB");
  EXPECT_EQ(format_light_samples(4), "4");
  EXPECT_EQ(format_light_samples(63.24), "63.2");
  EXPECT_EQ(format_light_samples(1.5), "1.5");
  EXPECT_EQ(format_light_samples(1024), "1024");
  EXPECT_EQ(format_light_samples(181.6), "182");
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
