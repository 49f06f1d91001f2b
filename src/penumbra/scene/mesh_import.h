// Triangle-mesh import through Assimp: OBJ, PLY (ASCII and binary, either endianness),
// glTF/GLB, OFF, STL and whatever else Assimp reads.
#pragma once

#include <filesystem>

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
TriangleMesh import_mesh(const std::filesystem::path& path, MeshImportReport* report = nullptr);

}  // namespace penumbra
