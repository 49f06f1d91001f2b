// Triangle-mesh import through Assimp: OBJ, PLY (ASCII and binary, either endianness),
// glTF/GLB, OFF, STL and whatever else Assimp reads.
#pragma once

#include <filesystem>

#include <vector>

#include "penumbra/scene/mesh.h"

namespace penumbra {

// Loads every mesh of the file into one TriangleMesh, with node transforms applied
// (aiProcess_PreTransformVertices), polygons triangulated, identical vertices joined and
// points/lines dropped. Vertex normals are kept when every mesh of the file has them
// (none are generated: without them, shading is flat). Throws Error naming the file if it
// is missing, unreadable, malformed (mesh_file_checks.h: declared counts the file cannot
// hold), has no triangles, non-finite coordinates or vertex indices out of range.
// Triangles of zero area are dropped and counted in `report`.
struct MeshImportReport {
  size_t degenerate_triangles = 0;
};
// The file's meshes as parts (issue 20): the meshes of every plain material (no texture, no
// alpha) as one part, and one part per textured material, named after it, with its
// base-colour texture (sRGB decoded; albedo 1, so the texture shows as it is) and its alpha: OBJ `map_d` is a mask (cutoff 0.5), glTF `alphaMode` MASK or
// BLEND reads the base colour's alpha, with `alphaCutoff`. Textures are files relative to the
// mesh file or embedded images (glTF data URIs, GLB). Colours of the file's materials are not
// read: a scene gives them. Every part keeps the texture coordinates (channel 0: OBJ `vt`,
// PLY `s,t`, `u,v` or `texture_u,texture_v`, glTF TEXCOORD_0) when all its meshes have them,
// so a scene file's material can texture a mesh file without materials; a textured
// material's part must have them. Errors also name a missing or unreadable texture, and a
// textured mesh without texture coordinates.
std::vector<SceneObject> import_mesh_parts(const std::filesystem::path& path, MeshImportReport* report = nullptr);
// How many times import_mesh_parts (or import_mesh) was called in this process: a scene that
// places one mesh file many times reads it once (the loader's cache; tested).
size_t mesh_file_reads();
// Every part's mesh as one (no materials).
TriangleMesh import_mesh(const std::filesystem::path& path, MeshImportReport* report = nullptr);

}  // namespace penumbra
