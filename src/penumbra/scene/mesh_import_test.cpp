#include "penumbra/scene/mesh_import.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <fstream>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "penumbra/core/file_util.h"
#include "penumbra/core/testing.h"
#include "penumbra/eval/report_util.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

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
  // Found by fuzz/mesh_fuzzer: Assimp 5.2's OBJ face parser reads past its buffer on a
  // malformed vertex reference, also in a file named .gltf (it sniffs OBJ keywords).
  for (const char* name : {"fuzzed.obj", "fuzzed.gltf"}) {
    write_text_file_atomic(dir / name, "f 1//1/1/23 / /\n1\n");
    EXPECT_EQ(error_message([&] { import_mesh(dir / name); }),
              (dir / name).string() + ": line 1: '1//1/1/23' is not a vertex reference (v, v/vt, v//vn or v/vt/vn)");
  }
  write_text_file_atomic(dir / "slash.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 /\n");
  EXPECT_NE(error_message([&] { import_mesh(dir / "slash.obj"); }).find("line 4: '/' is not"), std::string::npos);
  // Found by fuzz/mesh_fuzzer: Assimp 5.2 copies an accessor's bytes without checking its
  // buffer view's bounds.
  const std::string gltf_head =
      R"({"asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "scene": 0, "nodes": [{"mesh": 0}],
          "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
          "buffers": [{"uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA", "byteLength": 36}],
          "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}],)";
  write_text_file_atomic(dir / "offset.gltf", gltf_head + R"("accessors": [{"bufferView": 0, "byteOffset": 5,
      "componentType": 5126, "count": 3, "type": "VEC3", "max": [1, 1, 0], "min": [0, 0, 0]}]})");
  EXPECT_EQ(error_message([&] { import_mesh(dir / "offset.gltf"); }),
            (dir / "offset.gltf").string() +
                ": accessors[0] reads 3 elements of 12 bytes from byte 5 of bufferViews[0], which holds 36");
  write_text_file_atomic(dir / "ok.gltf", gltf_head + R"("accessors": [{"bufferView": 0, "byteOffset": 0,
      "componentType": 5126, "count": 3, "type": "VEC3", "max": [1, 1, 0], "min": [0, 0, 0]}]})");
  EXPECT_EQ(import_mesh(dir / "ok.gltf").triangle_count(), 1u);
  // Found by fuzz_mesh (2026-11-28): the same accessor behind a key of ill-formed UTF-8, which
  // Assimp's JSON parser accepts and the checks' parser refused, so they let it through.
  std::string bad_utf8 = gltf_head;
  bad_utf8.replace(bad_utf8.find("\"scene\""), 7, "\"sc\xe5ne\"");
  write_text_file_atomic(dir / "utf8.gltf", bad_utf8 + R"("accessors": [{"bufferView": 0, "byteOffset": 5,
      "componentType": 5126, "count": 3, "type": "VEC3", "max": [1, 1, 0], "min": [0, 0, 0]}]})");
  msg = error_message([&] { import_mesh(dir / "utf8.gltf"); });
  EXPECT_EQ(msg.rfind((dir / "utf8.gltf").string() + ": invalid glTF JSON: line 1, column ", 0), 0u) << msg;
  EXPECT_NE(msg.find("ill-formed UTF-8 byte"), std::string::npos) << msg;
  EXPECT_EQ(std::count_if(msg.begin(), msg.end(), [](char c) { return c < 32 || c >= 127; }), 0) << msg;
  std::string long_view = gltf_head, long_buffer = gltf_head;
  long_view.replace(long_view.rfind("\"byteLength\": 36}],"), 21, "\"byteLength\": 48}],");
  write_text_file_atomic(dir / "view.gltf", long_view + R"("accessors": []})");
  EXPECT_NE(error_message([&] { import_mesh(dir / "view.gltf"); })
                .find("bufferViews[0] spans bytes 0..48 of buffers[0], which holds 36"),
            std::string::npos);
  long_buffer.replace(long_buffer.find("\"byteLength\": 36}],"), 21, "\"byteLength\": 48}],");
  write_text_file_atomic(dir / "buffer.gltf", long_buffer + R"("accessors": []})");
  EXPECT_NE(error_message([&] { import_mesh(dir / "buffer.gltf"); }).find("buffers[0] declares 48 bytes but holds 36"),
            std::string::npos);
  // A file is read as what its name says: no reader sniffed from its first bytes (Assimp's
  // STEP reader, picked by "iso-10303-21" in a file named .gltf, read past its buffer).
  write_text_file_atomic(dir / "triangle.txt", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_EQ(error_message([&] { import_mesh(dir / "triangle.txt"); }),
            (dir / "triangle.txt").string() +
                ": not a mesh format penumbra reads (by its extension: .obj, .ply, .stl, .off, .gltf, .glb, ...)");
  write_text_file_atomic(dir / "step.gltf", "ISO-10303-21;\nHEADER;\nENDSEC;\n");
  msg = error_message([&] { import_mesh(dir / "step.gltf"); });
  EXPECT_EQ(msg.rfind((dir / "step.gltf").string() + ": cannot import mesh: ", 0), 0u) << msg;
  write_text_file_atomic(dir / "glued.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf//1/1//1/23 /1\n");
  EXPECT_NE(error_message([&] { import_mesh(dir / "glued.obj"); }).find("line 4: '//1/1//1/23' is not"),
            std::string::npos);
  write_text_file_atomic(dir / "comment.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 # no\n");
  EXPECT_NE(error_message([&] { import_mesh(dir / "comment.obj"); }).find("line 4: '#' is not"), std::string::npos);
  // Every well-formed kind of reference, CRLF and continuations still load.
  write_text_file_atomic(dir / "forms.obj",
                         "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvn 0 0 1\n"
                         "f 1 2 3\r\nf 2/1 4/1 3/1\nf -4//1 -3//1 \\\n -2//1\nf 1/1/1 2/1/1 4/1/1\n");
  EXPECT_EQ(import_mesh(dir / "forms.obj").triangle_count(), 4u);
}

// Issue 17: hostile meshes. A file that declares far more elements than it holds is refused
// from its header (Assimp would allocate for the declared counts, and for binary STL read
// past its end); indices out of range and non-finite vertices are refused; triangles of
// zero area are dropped and counted.
TEST(MeshImport, DeclaredCountsMustFitTheFile) {
  test::TempDir dir("hostile");
  const auto refused = [&](const std::string& file, const std::string& content) {
    write_text_file_atomic(dir / file, content);
    return error_message([&] { import_mesh(dir / file); });
  };
  const std::string ply_faces = (dir / "faces.ply").string();
  EXPECT_EQ(refused("faces.ply",
                    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                    "element face 100000000\nproperty list uchar int vertex_indices\nend_header\n"
                    "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
            ply_faces + ": PLY header declares 100000000 \"face\" entries, more than the 26 bytes after the header "
                        "can hold");
  std::string binary =
      "ply\nformat binary_little_endian 1.0\nelement vertex 100000000\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n";
  binary.append(12, '\0');
  EXPECT_NE(refused("vertices.ply", binary).find("vertices.ply: PLY header declares 100000000 \"vertex\" entries"),
            std::string::npos);
  // An ASCII list count far beyond the file (fuzz_mesh: Assimp reserved 13 GB for it).
  EXPECT_EQ(refused("list.ply",
                    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                    "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
                    "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n4444444444 0 1 2\n"),
            (dir / "list.ply").string() + ": PLY element \"face\" entry 1: list count \"4444444444\" is not a count the "
                                          "file can hold");
  // An element name that starts with digits: Assimp reads its count from there (fuzz_mesh: it
  // reserved 64 GB for "6666...vertex").
  EXPECT_EQ(refused("digits.ply",
                    "ply\nformat ascii 1.0\nelement 666666666666666666666666666666666vertex 4\nproperty float x\n"
                    "end_header\n0\n0\n0\n0\n"),
            (dir / "digits.ply").string() +
                ": PLY element name \"666666666666666666666666666666666vertex\" starts with a digit (Assimp would "
                "read it as the count)");
  // An element whose name Assimp does not know has no entries for it (the count is read from
  // the name), so the face's list count is the unknown element's first token (fuzz_mesh,
  // 2026-12-07: "7777...70" wrapped to 3.8 billion items, 15 GB).
  EXPECT_EQ(refused("unknown.ply",
                    "ply\nformat ascii 1.0\nelement ve2tex 3\nproperty float x\nproperty float y\nproperty float z\n"
                    "element face 1\nproperty list uchar int vertex_indices\nend_header\n" +
                        std::string(70, '7') + "0 0 0\n1 0 0\n0 a1 0\n3 0 1 2\n"),
            (dir / "unknown.ply").string() + ": PLY element \"face\" entry 0: list count \"" + std::string(60, '7') +
                "...\" is not a count the file can hold");
  // A known element's entries are one line each, as Assimp reads them: the count of the face
  // on the second line is its first token, whatever the first line held.
  EXPECT_EQ(refused("lines.ply",
                    "ply\nformat ascii 1.0\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
                    "3 0 1 2 9\n\n900 0 1 2\n"),
            (dir / "lines.ply").string() + ": PLY element \"face\" entry 1: list count \"900\" is not a count the "
                                           "file can hold");
  // In a "\r\n" file Assimp reads a blank line as an (empty) entry: the 900 is then no face's.
  EXPECT_EQ(refused("crlf.ply",
                    "ply\r\nformat ascii 1.0\r\nelement face 2\r\nproperty list uchar int vertex_indices\r\n"
                    "end_header\r\n3 0 1 2\r\n\r\n900 0 1 2\r\n")
                .find("list count"),
            std::string::npos);
  EXPECT_EQ(refused("huge.ply", "ply\nformat ascii 1.0\nelement vertex 99999999999\nproperty float x\nend_header\n"),
            (dir / "huge.ply").string() + ": PLY element \"vertex\" declares 99999999999 entries (at most 4294967295)");
  EXPECT_EQ(refused("empty_element.ply", "ply\nformat binary_little_endian 1.0\nelement nothing 4000000000\nend_header\n"),
            (dir / "empty_element.ply").string() +
                ": PLY element \"nothing\" declares 4000000000 entries but no properties");
  EXPECT_EQ(refused("off.off", "OFF\n# a comment\n100000000 1 0\n0 0 0\n3 0 0 0\n"),
            (dir / "off.off").string() +
                ": OFF header declares 100000000 vertices and 1 faces, more than the 17 bytes after it can hold");
  // Found by fuzz_mesh: counts may follow the keyword without a space, and Assimp reads them
  // as 32-bit numbers that wrap (91 sixes: 4,294,967,294 vertices, 32 GB).
  const std::string glued = "OFF" + std::string(91, '6') +
                            std::string("\n4::1 0ply0\0\0\0\0" "01 \0\0\x7f\xff\x06\xd3\xa5\x10mm\x01\0\0\0\0\0\0\0\0\0"
                                        "\x7f\xff\x06\xd3\xa5\x10" "2\n", 46);
  EXPECT_NE(refused("glued.off", glued).find("glued.off: OFF header declares "), std::string::npos);
  // 84 + 50 n wraps to the file's 88 bytes in 32 bits: Assimp would take it for binary STL
  // with 85,899,346 triangles and read gigabytes past the end.
  std::string stl(80, 'x');
  const uint32_t n = 85899346;
  stl.append(reinterpret_cast<const char*>(&n), 4);  // little-endian hosts only (as STL)
  stl.append(4, '\0');
  EXPECT_EQ(refused("wrap.stl", stl), (dir / "wrap.stl").string() +
                                          ": binary STL header declares 85899346 triangles, which need 4294967384 "
                                          "bytes; the file has 88");
}

TEST(MeshImport, BadIndicesAndCoordinatesAreRefusedDegenerateTrianglesDropped) {
  test::TempDir dir("hostile");
  // Found by fuzz_mesh: a garbled ASCII PLY face made Assimp 5.2 flag the mesh as holding
  // polygons with none in it, and its triangulation's assertion aborted the process.
  write_text_file_atomic(dir / "garbled.ply",
                         "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float "
                         "z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n" +
                             std::string(21, '\xff') + "3 0 1\x1c" "2\n");
  const std::string garbled = error_message([&] { import_mesh(dir / "garbled.ply"); });
  EXPECT_EQ(garbled.rfind((dir / "garbled.ply").string() + ": ", 0), 0u) << garbled;
  write_text_file_atomic(dir / "index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
  std::string msg = error_message([&] { import_mesh(dir / "index.obj"); });
  EXPECT_EQ(msg.rfind((dir / "index.obj").string() + ": ", 0), 0u) << msg;
  write_text_file_atomic(dir / "nan.obj", "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_EQ(error_message([&] { import_mesh(dir / "nan.obj"); }),
            (dir / "nan.obj").string() + ": vertex 0 of mesh 0 is not finite");
  // One real triangle, one with three collinear corners, one with a repeated corner.
  write_text_file_atomic(dir / "degenerate.obj",
                         "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\nf 1 1 3\n");
  MeshImportReport report;
  const TriangleMesh m = import_mesh(dir / "degenerate.obj", &report);
  EXPECT_EQ(m.triangle_count(), 1u);
  EXPECT_EQ(report.degenerate_triangles, 2u);
  // A tiny but real triangle (its area underflows in float) is kept.
  write_text_file_atomic(dir / "tiny.obj", "v 0 0 0\nv 1e-18 0 0\nv 0 1e-18 0\nf 1 2 3\n");
  EXPECT_EQ(import_mesh(dir / "tiny.obj").triangle_count(), 1u);
  write_text_file_atomic(dir / "flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
  EXPECT_EQ(error_message([&] { import_mesh(dir / "flat.obj"); }),
            (dir / "flat.obj").string() + ": the file contains no triangles of non-zero area (1 degenerate)");
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// Issue 20: an OBJ whose material has map_Kd and map_d (a leaf card as asset libraries ship it)
// imports as a part of its own with texture coordinates, the diffuse texture and a mask; a
// second, plain material's meshes form the other part.
TEST(MeshImportTextures, ObjMapDIsAMaskAndPlainMaterialsMergeIntoOnePart) {
  test::TempDir dir("import_obj_textures");
  // A 2 x 1 mask: left texel a hole, right texel solid; a 1 x 1 red diffuse image.
  Texture(2, 1, {1, 1, 1, 0, 1, 1, 1, 1}, true).write_png((dir / "mask.png").string());
  Texture(1, 1, {1, 0, 0, 1}, false).write_png((dir / "red.png").string());
  write_text_file_atomic(dir / "cards.mtl",
                         "newmtl leaf\nmap_Kd red.png\nmap_d mask.png\n"
                         "newmtl bark\nKd 0.4 0.3 0.2\n");
  write_text_file_atomic(dir / "cards.obj",
                         "mtllib cards.mtl\n"
                         "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                         "v 0 0 1\nv 1 0 1\nv 1 1 1\n"
                         "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                         "usemtl leaf\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n"
                         "usemtl bark\nf 5 6 7\n");
  const std::vector<SceneObject> parts = import_mesh_parts(dir / "cards.obj");
  ASSERT_EQ(parts.size(), 2u);
  const auto leaf = std::find_if(parts.begin(), parts.end(), [](const SceneObject& o) { return o.name == "leaf"; });
  ASSERT_NE(leaf, parts.end());
  EXPECT_EQ(leaf->mesh.triangle_count(), 2u);
  ASSERT_EQ(leaf->mesh.uvs.size(), leaf->mesh.positions.size());
  EXPECT_EQ(leaf->material.alpha.mode, AlphaMode::Mask);
  ASSERT_TRUE(leaf->material.alpha_textured());
  ASSERT_TRUE(leaf->material.albedo_texture);
  EXPECT_NEAR(leaf->material.albedo_at({0.5f, 0.5f}).x, 1.0f, 1e-3f);
  EXPECT_NEAR(leaf->material.albedo_at({0.5f, 0.5f}).y, 0.0f, 1e-3f);
  // Vertex (0.9, 0.5) of the card has uv (0.9, 0.5): the solid texel's side.
  EXPECT_EQ(leaf->material.alpha.opacity({0.9f, 0.5f}), 1.0f);
  EXPECT_EQ(leaf->material.alpha.opacity({0.6f, 0.5f}), 1.0f);
  EXPECT_EQ(leaf->material.alpha.opacity({0.4f, 0.5f}), 0.0f);
  const SceneObject& bark = parts[leaf == parts.begin() ? 1 : 0];
  EXPECT_EQ(bark.mesh.triangle_count(), 1u);
  EXPECT_FALSE(bark.material.alpha_textured());
  EXPECT_TRUE(bark.mesh.uvs.empty());
  // The merged mesh of every part, as before materials were read.
  EXPECT_EQ(import_mesh(dir / "cards.obj").triangle_count(), 3u);

  // A missing texture: one line naming the mesh file and the image.
  write_text_file_atomic(dir / "cards.mtl", "newmtl leaf\nmap_Kd red.png\nmap_d gone.png\n");
  const std::string msg = error_message([&] { import_mesh_parts(dir / "cards.obj"); });
  EXPECT_NE(msg.find((dir / "cards.obj").string()), std::string::npos) << msg;
  EXPECT_NE(msg.find((dir / "gone.png").string() + ": no such file"), std::string::npos) << msg;
  EXPECT_EQ(msg.find('\n'), std::string::npos);
}

// The project's glTF file (scripts/make_assets.py): alphaMode MASK with the base colour's
// alpha, embedded PNG, cutoff read; the leaf is where the generator's outline says, with glTF's
// v (down) turned into penumbra's (up): the outline is wider near the base than near the tip.
TEST(MeshImportTextures, ProjectsGltfLeafCardsAreMaskedTheRightWayUp) {
  const fs::path file = fs::path(PENUMBRA_SOURCE_DIR) / "scenes/assets/leaf_cards.gltf";
  const std::vector<SceneObject> parts = import_mesh_parts(file);
  ASSERT_EQ(parts.size(), 1u);
  const SceneObject& cards = parts[0];
  EXPECT_EQ(cards.name, "leaf");
  EXPECT_EQ(cards.mesh.triangle_count(), 6u);
  EXPECT_EQ(cards.material.alpha.mode, AlphaMode::Mask);
  EXPECT_FLOAT_EQ(cards.material.alpha.cutoff, 0.5f);
  ASSERT_TRUE(cards.material.alpha_textured());
  EXPECT_EQ(cards.material.alpha.texture->width(), 64);
  // Card 0's corners: base-left (-0.5, 0.8, 0.5) has uv (0, 0), tip-right (0.5, 0.8, -0.5) (1, 1).
  for (size_t i = 0; i < cards.mesh.positions.size(); ++i) {
    const Vec3f p = cards.mesh.positions[i];
    if (std::abs(p.y - 0.8f) > 1e-6f || std::abs(p.x) > 0.5f + 1e-6f) continue;  // card 0 only
    EXPECT_NEAR(cards.mesh.uvs[i].x, p.x + 0.5f, 1e-6f);
    EXPECT_NEAR(cards.mesh.uvs[i].y, 0.5f - p.z, 1e-6f);
  }
  // u = 0.5 +- 0.32: inside the leaf at v = 0.3 (half width 0.339), outside at v = 0.7 (0.294).
  const SurfaceAlpha& a = cards.material.alpha;
  EXPECT_EQ(a.opacity({0.82f, 0.3f}), 1.0f);
  EXPECT_EQ(a.opacity({0.18f, 0.3f}), 1.0f);
  EXPECT_EQ(a.opacity({0.82f, 0.7f}), 0.0f);
  EXPECT_EQ(a.opacity({0.5f, 0.5f}), 1.0f);
  EXPECT_EQ(a.opacity({0.02f, 0.02f}), 0.0f);
}

// Issue 32: texture coordinates come from every format that has them, whether or not the file
// has a material: a scene file's material may texture the mesh. Each mesh below is the unit
// square (two triangles) with uv = (x, y) at every corner, written the way other tools write it.
void expect_uv_is_xy(const TriangleMesh& m, const std::string& what) {
  SCOPED_TRACE(what);
  EXPECT_EQ(m.triangle_count(), 2u);
  ASSERT_EQ(m.uvs.size(), m.positions.size());
  for (size_t i = 0; i < m.positions.size(); ++i) {
    EXPECT_NEAR(m.uvs[i].x, m.positions[i].x, 1e-6f) << "vertex " << i;
    EXPECT_NEAR(m.uvs[i].y, m.positions[i].y, 1e-6f) << "vertex " << i;
  }
}

const float kSquare[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};

// An ASCII PLY square whose vertices carry uv as the properties `u_name` and `v_name`.
std::string square_ply(const std::string& u_name, const std::string& v_name) {
  std::string s = fmt::format(
      "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
      "property float {}\nproperty float {}\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n",
      u_name, v_name);
  for (const auto& p : kSquare) s += fmt::format("{} {} 0 {} {}\n", p[0], p[1], p[0], p[1]);
  return s + "3 0 1 2\n3 0 2 3\n";
}

// A glTF square per entry of `with_uvs` (one mesh each, side by side along z), with
// TEXCOORD_0 where true, buffers embedded as data URIs; no material.
std::string square_gltf(const std::vector<bool>& with_uvs) {
  std::string bin;
  auto put = [&](const void* p, size_t n) { bin.append(static_cast<const char*>(p), n); };
  for (const auto& p : kSquare) put(std::array<float, 3>{p[0], p[1], 0}.data(), 12);  // positions: bytes 0..48
  for (const auto& p : kSquare) {
    // glTF's v runs down the image (penumbra's up): the file holds 1 - v.
    const float uv[2] = {p[0], 1 - p[1]};
    put(uv, 8);  // bytes 48..80
  }
  for (uint16_t i : {0, 1, 2, 0, 2, 3}) put(&i, 2);  // bytes 80..92
  std::string meshes, nodes, node_list;
  for (size_t k = 0; k < with_uvs.size(); ++k) {
    meshes += fmt::format(R"({}{{"primitives": [{{"attributes": {{"POSITION": 0{}}}, "indices": 2}}]}})",
                          k ? ", " : "", with_uvs[k] ? R"(, "TEXCOORD_0": 1)" : "");
    nodes += fmt::format(R"({}{{"mesh": {}, "translation": [0, 0, {}]}})", k ? ", " : "", k, k);
    node_list += fmt::format("{}{}", k ? ", " : "", k);
  }
  return fmt::format(
      R"({{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [{}]}}], "nodes": [{}], "meshes": [{}],
          "buffers": [{{"uri": "data:application/octet-stream;base64,{}", "byteLength": {}}}],
          "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 32}},
                          {{"buffer": 0, "byteOffset": 80, "byteLength": 12}}],
          "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
                        {{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"}},
                        {{"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}}]}})",
      node_list, nodes, meshes, base64_encode(bin), bin.size());
}

TEST(MeshImportUvs, EveryFormatKeepsItsTextureCoordinatesWithoutAMaterial) {
  test::TempDir dir("import_uvs");
  // OBJ: vt lines, no mtllib (the way leaf cards come from a modelling tool without materials).
  write_text_file_atomic(dir / "card.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                                           "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n");
  std::vector<SceneObject> parts = import_mesh_parts(dir / "card.obj");
  ASSERT_EQ(parts.size(), 1u);
  expect_uv_is_xy(parts[0].mesh, "OBJ vt");
  EXPECT_FALSE(parts[0].material.albedo_texture);
  // PLY: the three namings other tools write (Assimp 5.2 reads each as texture coordinates).
  for (const auto& [u, v] : std::vector<std::pair<std::string, std::string>>{{"s", "t"}, {"u", "v"}, {"texture_u", "texture_v"}}) {
    const fs::path file = dir / fmt::format("square_{}.ply", u);
    write_text_file_atomic(file, square_ply(u, v));
    expect_uv_is_xy(import_mesh(file), "PLY " + u + "," + v);
  }
  // Binary big-endian PLY with double s,t, and MeshLab's per-face `texcoord` lists.
  {
    std::string s = "ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty double x\nproperty double y\n"
                    "property double z\nproperty double s\nproperty double t\nelement face 2\n"
                    "property list uchar int vertex_indices\nend_header\n";
    for (const auto& p : kSquare)
      for (double c : {double(p[0]), double(p[1]), 0.0, double(p[0]), double(p[1])}) put_be(s, c);
    for (const auto& f : {std::array<int32_t, 3>{0, 1, 2}, std::array<int32_t, 3>{0, 2, 3}}) {
      put_be(s, uint8_t{3});
      for (int32_t i : f) put_be(s, i);
    }
    write_text_file_atomic(dir / "square_be.ply", s);
    expect_uv_is_xy(import_mesh(dir / "square_be.ply"), "binary big-endian PLY s,t");
    std::string w = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                    "element face 2\nproperty list uchar int vertex_indices\nproperty list uchar float texcoord\n"
                    "end_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2 6 0 0 1 0 1 1\n3 0 2 3 6 0 0 1 1 0 1\n";
    write_text_file_atomic(dir / "square_wedge.ply", w);
    expect_uv_is_xy(import_mesh(dir / "square_wedge.ply"), "PLY face texcoord (MeshLab)");
  }
  // glTF TEXCOORD_0, no material; v turned up.
  write_text_file_atomic(dir / "square.gltf", square_gltf({true}));
  expect_uv_is_xy(import_mesh(dir / "square.gltf"), "glTF TEXCOORD_0");
  // Formats without texture coordinates, and files that have none: no uvs.
  write_text_file_atomic(dir / "square.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n");
  write_text_file_atomic(dir / "square.stl", "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                                             "vertex 1 1 0\nendloop\nendfacet\nfacet normal 0 0 1\nouter loop\n"
                                             "vertex 0 0 0\nvertex 1 1 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid s\n");
  write_text_file_atomic(dir / "bare.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n");
  for (const char* name : {"square.off", "square.stl", "bare.obj"}) {
    const TriangleMesh m = import_mesh(dir / name);
    EXPECT_EQ(m.triangle_count(), 2u) << name;
    EXPECT_TRUE(m.uvs.empty()) << name;
  }
}

// The meshes of plain materials merge into one part: it keeps uvs when every mesh has them,
// and has none (never uvs for some vertices only) when one lacks them.
TEST(MeshImportUvs, AMergedPartKeepsUvsOnlyWhenEveryMeshHasThem) {
  test::TempDir dir("import_uvs_merged");
  write_text_file_atomic(dir / "both.gltf", square_gltf({true, true}));
  std::vector<SceneObject> parts = import_mesh_parts(dir / "both.gltf");
  ASSERT_EQ(parts.size(), 1u);
  EXPECT_EQ(parts[0].mesh.triangle_count(), 4u);
  ASSERT_EQ(parts[0].mesh.uvs.size(), parts[0].mesh.positions.size());
  for (size_t i = 0; i < parts[0].mesh.positions.size(); ++i)
    EXPECT_NEAR(parts[0].mesh.uvs[i].x, parts[0].mesh.positions[i].x, 1e-6f);
  write_text_file_atomic(dir / "one.gltf", square_gltf({true, false}));
  parts = import_mesh_parts(dir / "one.gltf");
  ASSERT_EQ(parts.size(), 1u);
  EXPECT_EQ(parts[0].mesh.triangle_count(), 4u);
  EXPECT_TRUE(parts[0].mesh.uvs.empty());
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
