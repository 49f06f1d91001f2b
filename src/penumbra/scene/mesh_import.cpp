#include "penumbra/scene/mesh_import.h"

#include <assimp/BaseImporter.h>
#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/importerdesc.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <array>
#include <cctype>
#include <sstream>
#include <string>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/scene/mesh_file_checks.h"

namespace penumbra {

namespace fs = std::filesystem;

namespace {

// Leaves `importer` only the readers of `path`'s extension. Assimp otherwise tries every
// reader whose signature it finds in a file's first bytes (OBJ keywords, "iso-10303-21" for
// STEP and IFC, ...), and several of its less-used readers read past their buffers on
// malformed input (fuzz_mesh found the OBJ and STEP ones in files named .gltf). A file is
// read as what its name says, by a reader penumbra's checks (mesh_file_checks.h) know.
void keep_only_readers_for(Assimp::Importer& importer, const fs::path& path) {
  std::string ext = path.extension().string();
  if (!ext.empty()) ext.erase(0, 1);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  std::vector<Assimp::BaseImporter*> others;
  bool found = false;
  for (size_t i = 0; i < importer.GetImporterCount(); ++i) {
    const aiImporterDesc* desc = importer.GetImporterInfo(i);
    bool match = false;
    std::istringstream extensions(desc && desc->mFileExtensions ? desc->mFileExtensions : "");
    for (std::string e; extensions >> e;) match = match || e == ext;
    if (match) found = true;
    else others.push_back(importer.GetImporter(i));
  }
  if (!found || ext.empty())
    throw Error("{}: not a mesh format penumbra reads (by its extension: .obj, .ply, .stl, .off, .gltf, .glb, ...)",
                path.string());
  // UnregisterLoader hands the reader back without deleting it.
  for (Assimp::BaseImporter* reader : others) {
    importer.UnregisterLoader(reader);
    delete reader;
  }
}

}  // namespace

TriangleMesh import_mesh(const fs::path& path, MeshImportReport* report) {
  const std::string name = path.string();
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error("{}: no such file", name);
  if (fs::is_directory(path, ec)) throw Error("{}: is a folder, not a mesh file", name);

  check_mesh_file_header(path);

  Assimp::Importer importer;
  keep_only_readers_for(importer, path);
  // Points and lines (and triangles that collapse to them) carry no surface to cast a
  // shadow: let SortByPType drop them rather than hand them to the ray tracer.
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  // Import and validate first, post-process after penumbra's own check: Debian builds
  // Assimp with its assertions on, and its post-processing trusts the importers' output. A
  // fuzzed ASCII PLY face (fuzz_mesh) left a mesh flagged as holding polygons with none in
  // it, and aiProcess_Triangulate's assertion aborted the process.
  const aiScene* scene = importer.ReadFile(name, aiProcess_ValidateDataStructure);
  if (!scene) throw Error("{}: cannot import mesh: {}", name, importer.GetErrorString());
  for (unsigned mi = 0; mi < scene->mNumMeshes; ++mi) {
    // The importer's scene, still owned by `importer`, corrected before post-processing.
    aiMesh* m = const_cast<aiMesh*>(scene->mMeshes[mi]);
    unsigned types = 0;
    for (unsigned f = 0; f < m->mNumFaces; ++f) {
      const aiFace& face = m->mFaces[f];
      if (face.mNumIndices == 0 || face.mIndices == nullptr)
        throw Error("{}: face {} of mesh {} has no vertices", name, f, mi);
      for (unsigned k = 0; k < face.mNumIndices; ++k)
        if (face.mIndices[k] >= m->mNumVertices)
          throw Error("{}: face {} of mesh {} uses vertex {}, but the mesh has {} vertices", name, f, mi,
                      face.mIndices[k], m->mNumVertices);
      types |= face.mNumIndices == 1   ? aiPrimitiveType_POINT
               : face.mNumIndices == 2 ? aiPrimitiveType_LINE
               : face.mNumIndices == 3 ? aiPrimitiveType_TRIANGLE
                                       : aiPrimitiveType_POLYGON;
    }
    m->mPrimitiveTypes = types;  // what the faces are, whatever the importer said
  }
  scene = importer.ApplyPostProcessing(aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                                       aiProcess_PreTransformVertices | aiProcess_SortByPType);
  if (!scene) throw Error("{}: cannot import mesh: {}", name, importer.GetErrorString());

  TriangleMesh out;
  size_t degenerate = 0;
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
      const uint32_t a = base + face.mIndices[0], b = base + face.mIndices[1], c = base + face.mIndices[2];
      // A triangle of zero area (two corners equal, or all three on a line) casts no shadow,
      // and the rasterizing methods' edge set-up divides by its area: dropped.
      // In double: the cross product of a tiny but valid triangle can underflow in float.
      const auto corner = [&](uint32_t i) {
        const Vec3f& p = out.positions[i];
        return std::array<double, 3>{p.x, p.y, p.z};
      };
      const auto [pa, pb, pc] = std::array{corner(a), corner(b), corner(c)};
      const double e1[3] = {pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]};
      const double e2[3] = {pc[0] - pa[0], pc[1] - pa[1], pc[2] - pa[2]};
      const double nx = e1[1] * e2[2] - e1[2] * e2[1], ny = e1[2] * e2[0] - e1[0] * e2[2],
                   nz = e1[0] * e2[1] - e1[1] * e2[0];
      if (a == b || b == c || a == c || !(nx * nx + ny * ny + nz * nz > 0.0)) {
        ++degenerate;
        continue;
      }
      out.indices.insert(out.indices.end(), {a, b, c});
    }
  }
  if (report) report->degenerate_triangles = degenerate;
  if (out.triangle_count() == 0)
    throw Error("{}: the file contains no triangles{}", name,
                degenerate > 0 ? fmt::format(" of non-zero area ({} degenerate)", degenerate) : "");
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
