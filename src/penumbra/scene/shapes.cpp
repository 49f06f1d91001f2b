#include "penumbra/scene/shapes.h"

#include <vector>

#include "penumbra/core/error.h"

namespace penumbra {

namespace {
void add_triangle(TriangleMesh& m, size_t a, size_t b, size_t c) {
  m.indices.push_back(static_cast<uint32_t>(a));
  m.indices.push_back(static_cast<uint32_t>(b));
  m.indices.push_back(static_cast<uint32_t>(c));
}
size_t add_vertex(TriangleMesh& m, Vec3f p, Vec3f n) {
  m.positions.push_back(p);
  m.normals.push_back(n);
  return m.positions.size() - 1;
}
}  // namespace

TriangleMesh make_plane(Vec2f size) {
  TriangleMesh m;
  float hx = 0.5f * size.x, hz = 0.5f * size.y;
  const Vec3f up(0, 1, 0);
  add_vertex(m, {-hx, 0, -hz}, up);
  add_vertex(m, {-hx, 0, hz}, up);
  add_vertex(m, {hx, 0, hz}, up);
  add_vertex(m, {hx, 0, -hz}, up);
  // The image seen from above: u along +x, its top row (v = 1) at -z.
  m.uvs = {{0, 1}, {0, 0}, {1, 0}, {1, 1}};
  add_triangle(m, 0, 1, 2);
  add_triangle(m, 0, 2, 3);
  return m;
}

TriangleMesh make_box(Vec3f size) {
  TriangleMesh m;
  const Vec3f half = size * 0.5f;
  const Vec3f X(1, 0, 0), Y(0, 1, 0), Z(0, 0, 1);
  // (normal, u, v) with cross(u, v) = normal: corners in u, v order are counter-clockwise
  // seen from outside.
  const Vec3f faces[6][3] = {{X, Y, Z}, {-X, Z, Y}, {Y, Z, X}, {-Y, X, Z}, {Z, X, Y}, {-Z, Y, X}};
  for (const auto& f : faces) {
    size_t base = m.positions.size();
    const float corner[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (const auto& c : corner) {
      add_vertex(m, (f[0] + f[1] * c[0] + f[2] * c[1]) * half, f[0]);
      m.uvs.push_back({0.5f * (c[0] + 1), 0.5f * (c[1] + 1)});  // the whole image on each face
    }
    add_triangle(m, base, base + 1, base + 2);
    add_triangle(m, base, base + 2, base + 3);
  }
  return m;
}

TriangleMesh make_uv_sphere(float radius, int segments) {
  if (segments < 3) throw Error("make_uv_sphere: need at least 3 segments, got {}", segments);
  const int slices = segments, stacks = std::max(2, segments / 2);
  TriangleMesh m;
  size_t north = add_vertex(m, {0, radius, 0}, {0, 1, 0});
  for (int k = 1; k < stacks; ++k) {
    float theta = kPi * k / stacks;
    for (int j = 0; j < slices; ++j) {
      float phi = 2 * kPi * j / slices;
      Vec3f n(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi));
      add_vertex(m, n * radius, n);
    }
  }
  size_t south = add_vertex(m, {0, -radius, 0}, {0, -1, 0});
  auto ring = [&](int k, int j) { return 1 + static_cast<size_t>(k - 1) * slices + (j % slices); };
  for (int j = 0; j < slices; ++j) {
    add_triangle(m, north, ring(1, j + 1), ring(1, j));
    for (int k = 1; k + 1 < stacks; ++k) {
      add_triangle(m, ring(k, j), ring(k, j + 1), ring(k + 1, j));
      add_triangle(m, ring(k, j + 1), ring(k + 1, j + 1), ring(k + 1, j));
    }
    add_triangle(m, ring(stacks - 1, j), ring(stacks - 1, j + 1), south);
  }
  return m;
}

namespace {
// Rotates `v` about unit axis `axis` by `angle` (Rodrigues).
Vec3f rotate_about(Vec3f v, Vec3f axis, float angle) {
  float c = std::cos(angle), s = std::sin(angle);
  return v * c + cross(axis, v) * s + axis * (dot(axis, v) * (1 - c));
}
}  // namespace

TriangleMesh make_tube(std::span<const Vec3f> centre_in, std::span<const float> radii_in, int sides,
                       bool loop, bool caps) {
  if (sides < 3) throw Error("make_tube: need at least 3 sides, got {}", sides);
  if (radii_in.empty() || (radii_in.size() != 1 && radii_in.size() != centre_in.size()))
    throw Error("make_tube: {} radii for {} points", radii_in.size(), centre_in.size());
  // Drop consecutive duplicates (zero-length segments have no tangent).
  std::vector<Vec3f> p;
  std::vector<float> r;
  for (size_t i = 0; i < centre_in.size(); ++i) {
    if (!p.empty() && length_squared(centre_in[i] - p.back()) < 1e-20f) continue;
    p.push_back(centre_in[i]);
    r.push_back(radii_in.size() == 1 ? radii_in[0] : radii_in[i]);
  }
  if (loop && p.size() > 2 && length_squared(p.front() - p.back()) < 1e-20f) {
    p.pop_back();
    r.pop_back();
  }
  const size_t n = p.size();
  if (n < 2 || (loop && n < 3)) throw Error("make_tube: need at least {} distinct points", loop ? 3 : 2);

  // Tangents: central differences (wrapping for loops).
  std::vector<Vec3f> T(n);
  for (size_t i = 0; i < n; ++i) {
    Vec3f prev = (i > 0) ? p[i - 1] : (loop ? p[n - 1] : p[i]);
    Vec3f next = (i + 1 < n) ? p[i + 1] : (loop ? p[0] : p[i]);
    Vec3f d = next - prev;
    T[i] = length_squared(d) > 0 ? normalize(d) : normalize(p[std::min(i + 1, n - 1)] - p[i > 0 ? i - 1 : 0]);
  }
  // Rotation-minimizing normals by double reflection (Wang et al. 2008, Algorithm 1).
  std::vector<Vec3f> N(n);
  Vec3f b0;
  coordinate_system(T[0], &N[0], &b0);
  auto transport = [&](Vec3f n_prev, Vec3f t_prev, Vec3f x_prev, Vec3f x, Vec3f t) {
    Vec3f v1 = x - x_prev;
    float c1 = dot(v1, v1);
    Vec3f nl = n_prev - v1 * (2 / c1 * dot(v1, n_prev));
    Vec3f tl = t_prev - v1 * (2 / c1 * dot(v1, t_prev));
    Vec3f v2 = t - tl;
    float c2 = dot(v2, v2);
    Vec3f out = c2 > 1e-20f ? nl - v2 * (2 / c2 * dot(v2, nl)) : nl;
    out = out - t * dot(out, t);  // re-orthogonalise against float drift
    return normalize(out);
  };
  for (size_t i = 1; i < n; ++i) N[i] = transport(N[i - 1], T[i - 1], p[i - 1], p[i], T[i]);
  // A closed curve's transported frame comes back rotated about T[0] (holonomy): spread
  // the correction so ring n-1 meets ring 0 without a seam.
  std::vector<float> twist(n, 0.0f);
  if (loop) {
    Vec3f back = transport(N[n - 1], T[n - 1], p[n - 1], p[0], T[0]);
    float angle = std::atan2(dot(cross(back, N[0]), T[0]), dot(back, N[0]));
    for (size_t i = 0; i < n; ++i) twist[i] = angle * static_cast<float>(i) / static_cast<float>(n);
  }

  TriangleMesh m;
  m.positions.reserve(n * sides + (caps && !loop ? 2 * (sides + 1) : 0));
  std::vector<size_t> ring_start(n);
  for (size_t i = 0; i < n; ++i) {
    Vec3f ni = rotate_about(N[i], T[i], twist[i]);
    Vec3f bi = cross(T[i], ni);
    ring_start[i] = m.positions.size();
    for (int j = 0; j < sides; ++j) {
      float a = 2 * kPi * j / sides;
      Vec3f radial = ni * std::cos(a) + bi * std::sin(a);
      add_vertex(m, p[i] + radial * r[i], radial);
    }
  }
  const size_t segments = loop ? n : n - 1;
  for (size_t i = 0; i < segments; ++i) {
    size_t a = ring_start[i], b = ring_start[(i + 1) % n];
    for (int j = 0; j < sides; ++j) {
      int j1 = (j + 1) % sides;
      add_triangle(m, a + j, a + j1, b + j);
      add_triangle(m, a + j1, b + j1, b + j);
    }
  }
  if (caps && !loop) {
    // Flat end disks with their own vertices (sharp normals); the positions are copies of
    // the ring positions, so the surface is closed once vertices are welded by position.
    for (int end = 0; end < 2; ++end) {
      size_t i = end == 0 ? 0 : n - 1;
      Vec3f axis = end == 0 ? -T[i] : T[i];
      size_t centre = add_vertex(m, p[i], axis);
      size_t first = m.positions.size();
      for (int j = 0; j < sides; ++j) add_vertex(m, m.positions[ring_start[i] + j], axis);
      for (int j = 0; j < sides; ++j) {
        size_t c0 = first + j, c1 = first + (j + 1) % sides;
        if (end == 0)
          add_triangle(m, centre, c1, c0);
        else
          add_triangle(m, centre, c0, c1);
      }
    }
  }
  return m;
}

double signed_volume(const TriangleMesh& mesh) {
  double v = 0;
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    Vec3f a = mesh.vertex(t, 0), b = mesh.vertex(t, 1), c = mesh.vertex(t, 2);
    v += static_cast<double>(dot(a, cross(b, c)));
  }
  return v / 6.0;
}

}  // namespace penumbra
