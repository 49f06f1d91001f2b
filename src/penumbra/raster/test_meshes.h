// Meshes for the raster tests and benchmarks only (header-only, not part of the library
// proper): a minimal OBJ reader for the Stanford bunny that Debian's glmark2-data ships, and a
// procedural plant-like mesh of many small quads. They stand in for the scene loader and the
// plant generator so the raster layer can be tested on its own.
#pragma once

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "penumbra/core/rng.h"
#include "penumbra/raster/raster_triangle.h"

namespace penumbra::test_meshes {

inline constexpr const char* kBunnyPath = "/usr/share/glmark2/models/bunny.obj";

// Triangles of an OBJ file ("v x y z" and "f a b c ..." lines with 1-based or negative
// indices, "a/b/c" forms accepted, polygons fanned). Empty if the file cannot be read.
inline std::vector<RasterTriangle> read_obj(const std::string& path) {
  std::ifstream in(path);
  std::vector<RasterTriangle> tris;
  if (!in) return tris;
  std::vector<Vec3f> v;
  std::string line;
  std::vector<int> face;
  while (std::getline(in, line)) {
    if (line.size() < 2) continue;
    if (line[0] == 'v' && line[1] == ' ') {
      Vec3f p;
      std::sscanf(line.c_str() + 2, "%f %f %f", &p.x, &p.y, &p.z);
      v.push_back(p);
    } else if (line[0] == 'f' && line[1] == ' ') {
      std::istringstream s(line.substr(2));
      std::string tok;
      face.clear();
      while (s >> tok) {
        int idx = std::atoi(tok.c_str());
        face.push_back(idx > 0 ? idx - 1 : static_cast<int>(v.size()) + idx);
      }
      for (size_t k = 1; k + 1 < face.size(); ++k) {
        RasterTriangle t;
        t.p[0] = v[face[0]];
        t.p[1] = v[face[k]];
        t.p[2] = v[face[k + 1]];
        t.prim = static_cast<uint32_t>(tris.size());
        tris.push_back(t);
      }
    }
  }
  return tris;
}

inline Bounds3f bounds_of(const std::vector<RasterTriangle>& tris) {
  Bounds3f b;
  for (const RasterTriangle& t : tris)
    for (const Vec3f& p : t.p) b.extend(p);
  return b;
}

// A plant-like caster: `leaves` small quads (two triangles each, 0.016 to 0.028 across) hung at
// random orientations along a few curved stems inside the unit cube, the depth-complex
// foliage of agrawala2000's plant and xie2007's trees (40,000 leaves seen from above as in
// raster_bench: about 19 fragments per texel, averaged over the whole fitted view).
// Deterministic from `seed`.
inline std::vector<RasterTriangle> plant(int leaves, uint64_t seed = 7) {
  std::vector<RasterTriangle> tris;
  tris.reserve(static_cast<size_t>(leaves) * 2);
  Rng rng(seed);
  const int stems = 12;
  for (int i = 0; i < leaves; ++i) {
    int stem = i % stems;
    float h = rng.next_float();  // height along the stem
    float angle = 2 * kPi * (stem + 0.3f * h) / stems;
    float r = 0.45f * h * (1.2f - h);
    Vec3f c{0.5f + r * std::cos(angle) + 0.08f * (rng.next_float() - 0.5f), 0.05f + 0.9f * h,
            0.5f + r * std::sin(angle) + 0.08f * (rng.next_float() - 0.5f)};
    Vec3f n = normalize(Vec3f(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f) + Vec3f(1e-3f));
    Vec3f s, t;
    coordinate_system(n, &s, &t);
    float size = 0.008f + 0.006f * rng.next_float();  // half the side
    Vec3f q[4] = {c - s * size - t * size, c + s * size - t * size, c + s * size + t * size, c - s * size + t * size};
    RasterTriangle a, b;
    a.p[0] = q[0]; a.p[1] = q[1]; a.p[2] = q[2];
    b.p[0] = q[0]; b.p[1] = q[2]; b.p[2] = q[3];
    a.prim = static_cast<uint32_t>(tris.size());
    tris.push_back(a);
    b.prim = static_cast<uint32_t>(tris.size());
    tris.push_back(b);
  }
  return tris;
}

}  // namespace penumbra::test_meshes
