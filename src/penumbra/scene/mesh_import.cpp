#include "penumbra/scene/mesh_import.h"

#include <assimp/BaseImporter.h>
#include <assimp/GltfMaterial.h>
#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/importerdesc.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <array>
#include <atomic>
#include <cmath>
#include <memory>
#include <span>
#include <cctype>
#include <sstream>
#include <string>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/image.h"
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


// What penumbra reads of one material of the file: its base-colour texture and its alpha.
struct MaterialTextures {
  std::string name;
  std::shared_ptr<const Texture> albedo;
  SurfaceAlpha alpha;
  bool textured() const { return albedo != nullptr || alpha.active(); }
};

struct ImportedPart {
  std::string name;
  Material material;
  bool textured = false;
  std::vector<unsigned> meshes;
};

// A texture a material names: embedded ("*N" or an embedded file name: glTF data URIs and
// GLB buffers) or a file relative to the mesh file. Errors name both files.
std::shared_ptr<const Texture> load_material_texture(const aiScene& scene, const aiString& ref, const fs::path& mesh,
                                                     Texture::Encoding encoding) {
  const std::string r = ref.C_Str();
  if (const aiTexture* t = scene.GetEmbeddedTexture(r.c_str())) {
    const std::string label = fmt::format("{} (embedded image {})", mesh.string(), r);
    if (t->mHeight == 0)  // compressed: mWidth bytes of a PNG or JPEG file
      return Texture::decode(std::span(reinterpret_cast<const unsigned char*>(t->pcData), t->mWidth), encoding, label);
    // Raw ARGB8888 texels.
    const size_t n = static_cast<size_t>(t->mWidth) * t->mHeight;
    std::vector<float> rgba(4 * n);
    for (size_t i = 0; i < n; ++i) {
      const aiTexel& x = t->pcData[i];
      const unsigned char c[3] = {x.r, x.g, x.b};
      for (int k = 0; k < 3; ++k)
        rgba[4 * i + k] = encoding == Texture::Encoding::Srgb ? srgb_to_linear(c[k] / 255.0f) : c[k] / 255.0f;
      rgba[4 * i + 3] = x.a / 255.0f;
    }
    return std::make_shared<const Texture>(static_cast<int>(t->mWidth), static_cast<int>(t->mHeight), std::move(rgba),
                                           true, label);
  }
  if (r.empty() || r[0] == '*') throw Error("{}: material names texture '{}', which the file does not embed", mesh.string(), r);
  fs::path p(r);
  if (!p.is_absolute()) p = (mesh.parent_path() / p).lexically_normal();
  try {
    return Texture::load(p, encoding);
  } catch (const Error& e) {
    throw Error("{}: texture of a material: {}", mesh.string(), e.what());
  }
}

MaterialTextures read_material_textures(const aiScene& scene, unsigned index, const fs::path& mesh) {
  const aiMaterial& m = *scene.mMaterials[index];
  MaterialTextures out;
  aiString name;
  out.name = m.Get(AI_MATKEY_NAME, name) == AI_SUCCESS && name.length > 0 ? std::string(name.C_Str())
                                                                          : fmt::format("material{}", index);
  aiString ref;
  // glTF's baseColorTexture is both BASE_COLOR and DIFFUSE in Assimp 5; OBJ's map_Kd DIFFUSE.
  if (m.GetTexture(aiTextureType_BASE_COLOR, 0, &ref) == AI_SUCCESS || m.GetTexture(aiTextureType_DIFFUSE, 0, &ref) == AI_SUCCESS)
    out.albedo = load_material_texture(scene, ref, mesh, Texture::Encoding::Srgb);
  // OBJ's map_d: a mask (the practice of foliage assets); glTF's alphaMode and alphaCutoff.
  aiString mode;
  float cutoff = 0.5f;
  if (m.GetTexture(aiTextureType_OPACITY, 0, &ref) == AI_SUCCESS) {
    out.alpha.texture = load_material_texture(scene, ref, mesh, Texture::Encoding::Linear);
    out.alpha.mode = AlphaMode::Mask;
  } else if (m.Get(AI_MATKEY_GLTF_ALPHAMODE, mode) == AI_SUCCESS) {
    const std::string s = mode.C_Str();
    if (s == "MASK") out.alpha.mode = AlphaMode::Mask;
    else if (s == "BLEND") out.alpha.mode = AlphaMode::Blend;
    if (out.alpha.mode != AlphaMode::Opaque) {
      if (!out.albedo || !out.albedo->has_alpha())
        throw Error("{}: material {} has alphaMode {} but no base colour texture with an alpha channel", mesh.string(),
                    out.name, s);
      out.alpha.texture = out.albedo;
    }
  }
  if (m.Get(AI_MATKEY_GLTF_ALPHACUTOFF, cutoff) == AI_SUCCESS) {
    if (!(cutoff >= 0 && cutoff <= 1)) throw Error("{}: material {} has alphaCutoff {} outside [0, 1]", mesh.string(), out.name, cutoff);
    out.alpha.cutoff = cutoff;
  }
  return out;
}

}  // namespace

namespace {
std::atomic<size_t> g_mesh_file_reads{0};
}  // namespace

size_t mesh_file_reads() { return g_mesh_file_reads.load(); }

std::vector<SceneObject> import_mesh_parts(const fs::path& path, MeshImportReport* report) {
  ++g_mesh_file_reads;
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

  // Meshes are grouped by what penumbra reads of their material (issue 20): every mesh of a
  // plain material (no texture, no alpha) goes into one part; each textured material is a
  // part of its own, with texture coordinates.
  std::vector<MaterialTextures> looks(scene->mNumMaterials);
  for (unsigned k = 0; k < scene->mNumMaterials; ++k) looks[k] = read_material_textures(*scene, k, path);
  std::vector<int> part_of_material(scene->mNumMaterials, -1);
  std::vector<ImportedPart> parts;
  int plain_part = -1;
  for (unsigned mi = 0; mi < scene->mNumMeshes; ++mi) {
    const aiMesh* m = scene->mMeshes[mi];
    if (!(m->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
    const unsigned k = m->mMaterialIndex < looks.size() ? m->mMaterialIndex : ~0u;
    int* slot = k != ~0u && looks[k].textured() ? &part_of_material[k] : &plain_part;
    if (*slot < 0) {
      *slot = static_cast<int>(parts.size());
      parts.push_back({});
      if (k != ~0u && looks[k].textured()) {
        ImportedPart& part = parts.back();
        part.name = looks[k].name;
        part.material.albedo_texture = looks[k].albedo;
        if (looks[k].albedo) part.material.albedo = Vec3f(1.0f);
        part.material.alpha = looks[k].alpha;
        part.textured = true;
      }
    }
    parts[*slot].meshes.push_back(mi);
  }

  size_t degenerate = 0;
  std::vector<SceneObject> out;
  for (ImportedPart& part : parts) {
    SceneObject obj;
    obj.name = part.name;
    obj.material = part.material;
    TriangleMesh& mesh = obj.mesh;
    // Texture coordinates (channel 0: OBJ vt, PLY s,t / u,v / texture_u,texture_v, glTF
    // TEXCOORD_0) are kept for every part whose meshes all have them, textured or not: a scene
    // file's material may put a texture on a mesh whose file has no material (issue 32: leaf
    // cards from one tool, the leaf image chosen in the scene). Like normals, all or none.
    bool all_normals = true, all_uvs = true;
    for (unsigned mi : part.meshes) {
      all_normals = all_normals && scene->mMeshes[mi]->HasNormals();
      all_uvs = all_uvs && scene->mMeshes[mi]->HasTextureCoords(0);
    }
    for (unsigned mi : part.meshes) {
      const aiMesh* m = scene->mMeshes[mi];
      if (part.textured && !m->HasTextureCoords(0))
        throw Error("{}: mesh {} has a textured material ({}) but no texture coordinates", name, mi, part.name);
      const uint32_t base = static_cast<uint32_t>(mesh.positions.size());
      for (unsigned v = 0; v < m->mNumVertices; ++v) {
        const aiVector3D& p = m->mVertices[v];
        Vec3f q(p.x, p.y, p.z);
        if (!is_finite(q)) throw Error("{}: vertex {} of mesh {} is not finite", name, v, mi);
        mesh.positions.push_back(q);
        if (all_normals) {
          const aiVector3D& n = m->mNormals[v];
          // Files do contain zero or NaN normals; a usable fallback is no smooth normal at
          // all, decided below for the whole mesh.
          mesh.normals.push_back(Vec3f(n.x, n.y, n.z));
        }
        if (all_uvs) {
          const aiVector3D& t = m->mTextureCoords[0][v];
          if (!std::isfinite(t.x) || !std::isfinite(t.y))
            throw Error("{}: texture coordinates of vertex {} of mesh {} are not finite", name, v, mi);
          mesh.uvs.push_back({t.x, t.y});
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
          const Vec3f& p = mesh.positions[i];
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
        mesh.indices.insert(mesh.indices.end(), {a, b, c});
      }
    }
    // Normalise the normals; if any is degenerate, drop them all (flat shading) rather than
    // shade some vertices black.
    for (Vec3f& n : mesh.normals) {
      float len = length(n);
      if (!(len > 1e-12f) || !std::isfinite(len)) {
        mesh.normals.clear();
        break;
      }
      n = n / len;
    }
    if (mesh.triangle_count() > 0) out.push_back(std::move(obj));
  }
  if (report) report->degenerate_triangles = degenerate;
  if (out.empty())
    throw Error("{}: the file contains no triangles{}", name,
                degenerate > 0 ? fmt::format(" of non-zero area ({} degenerate)", degenerate) : "");
  return out;
}

TriangleMesh import_mesh(const fs::path& path, MeshImportReport* report) {
  TriangleMesh out;
  for (const SceneObject& part : import_mesh_parts(path, report)) out.append(part.mesh);
  return out;
}

}  // namespace penumbra
