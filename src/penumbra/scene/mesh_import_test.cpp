#include "penumbra/scene/mesh_import.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <fstream>

#include <gtest/gtest.h>

#include "penumbra/core/file_util.h"
#include "penumbra/core/testing.h"

namespace penumbra {
namespace {

namespace fs = std::filesystem;
using test::error_message;

// Appends v in big-endian byte order.
template <typename T>
void put_be(std::string& out, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if constexpr (std::endian::native == std::endian::little) std::reverse(b, b + sizeof(T));
  out.append(b, sizeof(T));
}

// A unit square in z = 1 (two triangles) as binary big-endian PLY, the format of the
// Stanford scanning repository's files.
void write_square_ply(const fs::path& path) {
  std::string s =
      "ply\nformat binary_big_endian 1.0\nelement vertex 4\n"
      "property float x\nproperty float y\nproperty float z\n"
      "element face 2\nproperty list uchar int vertex_indices\nend_header\n";
  const float v[4][3] = {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  for (const auto& p : v)
    for (float c : p) put_be(s, c);
  for (const auto& f : {std::array<int32_t, 3>{0, 1, 2}, std::array<int32_t, 3>{0, 2, 3}}) {
    put_be(s, uint8_t{3});
    for (int32_t i : f) put_be(s, i);
  }
  write_text_file_atomic(path, s);
}

// The triangles as sorted lists of corner positions, independent of vertex order.
std::vector<std::array<std::array<float, 3>, 3>> triangle_set(const TriangleMesh& m) {
  std::vector<std::array<std::array<float, 3>, 3>> out;
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    std::array<std::array<float, 3>, 3> tri;
    for (int k = 0; k < 3; ++k) tri[k] = {m.vertex(t, k).x, m.vertex(t, k).y, m.vertex(t, k).z};
    // Rotate so the smallest corner comes first: keeps the winding, drops the start.
    std::rotate(tri.begin(), std::min_element(tri.begin(), tri.end()), tri.end());
    out.push_back(tri);
  }
  std::sort(out.begin(), out.end());
  return out;
}

TEST(MeshImport, BinaryBigEndianPly) {
  test::TempDir dir("ply");
  write_square_ply(dir / "square.ply");
  TriangleMesh m = import_mesh(dir / "square.ply");
  ASSERT_EQ(m.triangle_count(), 2u);
  TriangleMesh expected;
  expected.positions = {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  expected.indices = {0, 1, 2, 0, 2, 3};
  EXPECT_EQ(triangle_set(m), triangle_set(expected));
  EXPECT_TRUE(m.normals.empty());  // none in the file, none invented
}

TEST(MeshImport, ObjWithNormalsKeepsThem) {
  test::TempDir dir("obj");
  write_text_file_atomic(dir / "q.obj",
                         "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 2\n"
                         "f 1//1 2//1 3//1 4//1\n");  // a quad: triangulated
  TriangleMesh m = import_mesh(dir / "q.obj");
  EXPECT_EQ(m.triangle_count(), 2u);
  ASSERT_EQ(m.normals.size(), m.positions.size());
  EXPECT_NEAR(m.normals[0].z, 1, 1e-6f);  // normalised
}

TEST(MeshImport, StanfordBunnyFromGlmark2) {
  const fs::path bunny = "/usr/share/glmark2/models/bunny.obj";
  if (!fs::exists(bunny)) GTEST_SKIP() << bunny << " not installed (package glmark2-data)";
  TriangleMesh m = import_mesh(bunny);
  EXPECT_EQ(m.triangle_count(), 69666u);
  EXPECT_NEAR(m.bounds().hi.x, 1.0f, 1e-5f);
  EXPECT_NEAR(m.bounds().lo.y, -0.991233f, 1e-5f);
}

TEST(MeshImport, ErrorsNameTheFile) {
  test::TempDir dir("badmesh");
  std::string missing = (dir / "nope.obj").string();
  EXPECT_EQ(error_message([&] { import_mesh(missing); }), missing + ": no such file");
  // Assimp 5.2 hangs on these two unless import_mesh checks the header first.
  write_text_file_atomic(dir / "garbage.ply", "ply\nformat ascii 1.0\nelement vertex banana\n");
  std::string msg = error_message([&] { import_mesh(dir / "garbage.ply"); });
  EXPECT_EQ(msg.rfind((dir / "garbage.ply").string() + ": ", 0), 0u) << msg;
  write_text_file_atomic(dir / "truncated.ply", "ply\nformat ascii 1.0\nelement vertex 3\n");
  msg = error_message([&] { import_mesh(dir / "truncated.ply"); });
  EXPECT_EQ(msg, (dir / "truncated.ply").string() + ": malformed PLY header (no end_header line)");
  write_text_file_atomic(dir / "magic.ply", "not a ply file\n");
  msg = error_message([&] { import_mesh(dir / "magic.ply"); });
  EXPECT_EQ(msg.rfind((dir / "magic.ply").string() + ": ", 0), 0u) << msg;
  // Found by fuzz/mesh_fuzzer: a mistyped magic and format line made Assimp 5.2 spin forever.
  const std::string fuzzed("plY\nformat ascii 5.0\nelemefloat\x01p z\nelement faormal 1 0l\xf9\nf", 59);
  write_text_file_atomic(dir / "fuzzed.ply", fuzzed);
  EXPECT_EQ(error_message([&] { import_mesh(dir / "fuzzed.ply"); }),
            (dir / "fuzzed.ply").string() + ": not a PLY file (the first line must be \"ply\")");
  write_text_file_atomic(dir / "format.ply", "ply\nformat ascii 5.0\nend_header\n");
  EXPECT_EQ(error_message([&] { import_mesh(dir / "format.ply"); }),
            (dir / "format.ply").string() +
                ": malformed PLY header line \"format ascii 5.0\" (expected the format line)");
  write_text_file_atomic(dir / "keyword.ply", "ply\nformat ascii 1.0\nelemefloat\x01p z\nend_header\n");
  EXPECT_EQ(error_message([&] { import_mesh(dir / "keyword.ply"); }),
            (dir / "keyword.ply").string() + ": malformed PLY header line \"elemefloat?p z\"");
  write_text_file_atomic(dir / "points.obj", "v 0 0 0\nv 1 0 0\n");
  msg = error_message([&] { import_mesh(dir / "points.obj"); });
  EXPECT_NE(msg.find("points.obj: "), std::string::npos) << msg;
}

}  // namespace
}  // namespace penumbra
