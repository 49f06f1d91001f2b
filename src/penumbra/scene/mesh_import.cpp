#include "penumbra/scene/mesh_import.h"

#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <fstream>
#include <string>

#include "penumbra/core/error.h"

namespace penumbra {

namespace fs = std::filesystem;

namespace {
// Assimp 5.2's PLY parser loops forever on a header that never reaches "end_header"
// (a truncated or mistyped file): reading fails and is retried. Check the header first,
// so a bad file is an error and not a hang.
void check_ply_header(const fs::path& path) {
  std::ifstream f(path, std::ios::binary);
  std::string line;
  if (!std::getline(f, line) || line.rfind("ply", 0) != 0) return;  // not PLY: Assimp decides
  for (int lines = 0; lines < 10000 && std::getline(f, line); ++lines) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line == "end_header") return;
    if (line.rfind("element ", 0) == 0) {
      size_t count_at = line.find_last_of(' ');
      std::string count = line.substr(count_at + 1);
      if (count.empty() || count.find_first_not_of("0123456789") != std::string::npos)
        throw Error("{}: malformed PLY header line \"{}\"", path.string(), line);
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
