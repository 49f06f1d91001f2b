#include "penumbra/scene/mesh_import.h"

#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <cctype>
#include <fstream>
#include <string>

#include "penumbra/core/error.h"

namespace penumbra {

namespace fs = std::filesystem;

namespace {
// A header line for a message: printable ASCII only, at most 60 characters.
std::string abbreviate_line(const std::string& line) {
  std::string out;
  for (char c : line) {
    if (out.size() >= 60) return out + "...";
    out += (c >= 32 && c < 127) ? c : '?';
  }
  return out;
}

// Assimp 5.2's PLY parser loops forever on some malformed headers (one that never reaches
// "end_header", or a mistyped magic or format line it half accepts: found by fuzz/mesh_fuzzer):
// reading fails and is retried. So a file named .ply, or one that starts like PLY in any
// letter case, must have a well-formed header before Assimp sees it: "ply", a format line,
// then only element, property, comment and obj_info lines up to "end_header".
bool looks_like_ply(const fs::path& path, const std::string& first_line) {
  std::string ext = path.extension().string(), magic = first_line.substr(0, 3);
  for (std::string* s : {&ext, &magic})
    for (char& c : *s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".ply" || magic == "ply";
}

void check_ply_header(const fs::path& path) {
  std::ifstream f(path, std::ios::binary);
  std::string line;
  if (!std::getline(f, line)) return;  // empty: Assimp reports it
  if (!line.empty() && line.back() == '\r') line.pop_back();
  if (!looks_like_ply(path, line)) return;
  if (line != "ply") throw Error("{}: not a PLY file (the first line must be \"ply\")", path.string());
  auto starts = [](const std::string& l, const char* word) { return l.rfind(word, 0) == 0; };
  for (int lines = 0; lines < 10000 && std::getline(f, line); ++lines) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line == "end_header") return;
    if (lines == 0) {
      if (line != "format ascii 1.0" && line != "format binary_little_endian 1.0" &&
          line != "format binary_big_endian 1.0")
        throw Error("{}: malformed PLY header line \"{}\" (expected the format line)", path.string(),
                    abbreviate_line(line));
      continue;
    }
    if (starts(line, "element ")) {
      size_t count_at = line.find_last_of(' ');
      std::string count = line.substr(count_at + 1);
      if (count.empty() || count.find_first_not_of("0123456789") != std::string::npos)
        throw Error("{}: malformed PLY header line \"{}\"", path.string(), abbreviate_line(line));
    } else if (!starts(line, "property ") && !starts(line, "comment") && !starts(line, "obj_info")) {
      throw Error("{}: malformed PLY header line \"{}\"", path.string(), abbreviate_line(line));
    }
  }
  throw Error("{}: malformed PLY header (no end_header line)", path.string());
}
}  // namespace

TriangleMesh import_mesh(const fs::path& path) {
  const std::string name = path.string();
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error("{}: no such file", name);
  if (fs::is_directory(path, ec)) throw Error("{}: is a folder, not a mesh file", name);

  check_ply_header(path);

  Assimp::Importer importer;
  // Points and lines (and triangles that collapse to them) carry no surface to cast a
  // shadow: let SortByPType drop them rather than hand them to the ray tracer.
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  const unsigned flags = aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                         aiProcess_PreTransformVertices | aiProcess_SortByPType |
                         aiProcess_ValidateDataStructure;
  const aiScene* scene = importer.ReadFile(name, flags);
  if (!scene) throw Error("{}: cannot import mesh: {}", name, importer.GetErrorString());

  TriangleMesh out;
  bool all_normals = true;
  for (unsigned mi = 0; mi < scene->mNumMeshes; ++mi) {
    const aiMesh* m = scene->mMeshes[mi];
    if (!(m->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
    all_normals = all_normals && m->HasNormals();
  }
  for (unsigned mi = 0; mi < scene->mNumMeshes; ++mi) {
    const aiMesh* m = scene->mMeshes[mi];
    if (!(m->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
    const uint32_t base = static_cast<uint32_t>(out.positions.size());
    for (unsigned v = 0; v < m->mNumVertices; ++v) {
      const aiVector3D& p = m->mVertices[v];
      Vec3f q(p.x, p.y, p.z);
      if (!is_finite(q)) throw Error("{}: vertex {} of mesh {} is not finite", name, v, mi);
      out.positions.push_back(q);
      if (all_normals) {
        const aiVector3D& n = m->mNormals[v];
        Vec3f nn(n.x, n.y, n.z);
        // Files do contain zero or NaN normals; a usable fallback is no smooth normal at
        // all, decided below for the whole mesh.
        out.normals.push_back(nn);
      }
    }
    for (unsigned f = 0; f < m->mNumFaces; ++f) {
      const aiFace& face = m->mFaces[f];
      if (face.mNumIndices != 3) continue;
      for (int k = 0; k < 3; ++k) out.indices.push_back(base + face.mIndices[k]);
    }
  }
  if (out.triangle_count() == 0) throw Error("{}: the file contains no triangles", name);
  // Normalise the normals; if any is degenerate, drop them all (flat shading) rather than
  // shade some vertices black.
  for (Vec3f& n : out.normals) {
    float len = length(n);
    if (!(len > 1e-12f) || !std::isfinite(len)) {
      out.normals.clear();
      break;
    }
    n = n / len;
  }
  return out;
}

}  // namespace penumbra
