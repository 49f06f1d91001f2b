// Area lights in the common subset of C++ and GLSL (core/shader_compat.h): the shape's
// geometry, the direction sampling toward a point (LightPointSampler's modes: spherical
// rectangles, cones, area samples, ellipses) and the closed-form unshadowed irradiance.
// AreaLight (scene/light.h) calls these functions; the GPU kernels include this header, so the
// reference draws the same light points on both devices (issue 28 part 5). light_batch.cpp's
// SIMD kernels are the CPU's fast path of the spherical rectangle and the cone; they mirror
// light_sampler_sample and are tested against it.
#ifndef PENUMBRA_SCENE_LIGHT_SHARED_H
#define PENUMBRA_SCENE_LIGHT_SHARED_H

#include "penumbra/core/sampling_shared.h"
#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// LightShape's values.
PN_CONST uint kLightRect = 0u;
PN_CONST uint kLightDisk = 1u;
PN_CONST uint kLightSphere = 2u;
PN_CONST uint kLightEllipsoid = 3u;

// What the functions below need of an AreaLight, 80 bytes (scalar layout):
//   0-11 center  12-15 shape   16-27 s  28-31 size_x   32-43 t  44-47 size_y
//   48-59 n  60-63 radius   64-75 radii  76-79 area (AreaLight::area())
struct LightGeometry {
  vec3 center;
  uint shape;
  vec3 s;
  float size_x;
  vec3 t;
  float size_y;
  vec3 n;
  float radius;
  vec3 radii;
  float area;
};

// Frame::from_z: n normalised and two unit vectors perpendicular to it (Duff et al. 2017).
PN_INLINE void frame_from_z(vec3 axis, PN_OUT(vec3) s, PN_OUT(vec3) t, PN_OUT(vec3) n) {
  n = normalize(axis);
  float sgn = (floatBitsToUint(n.z) >> 31) != 0u ? -1.0f : 1.0f;  // copysign(1, n.z)
  float a = -1.0f / (sgn + n.z);
  float c = n.x * n.y * a;
  s = vec3(1.0f + sgn * n.x * n.x * a, sgn * c, -sgn * n.x);
  t = vec3(c, sgn + n.y * n.y * a, -n.y);
}

PN_INLINE bool light_faces(LightGeometry L, vec3 p) {
  if (L.shape == kLightSphere) {
    vec3 d = p - L.center;
    return dot(d, d) > L.radius * L.radius;
  }
  if (L.shape == kLightEllipsoid) {
    vec3 d = p - L.center;
    vec3 u = vec3(dot(d, L.s) / L.radii.x, dot(d, L.t) / L.radii.y, dot(d, L.n) / L.radii.z);
    return dot(u, u) > 1.0f;
  }
  return dot(p - L.center, L.n) > 0.0f;
}

// A sphere light drawn as faces (scene/light.h split_sphere_lights): which face serves the
// point in direction d from the centre, for the frame (s, t, n) whose n points toward the scene.
// The faces of the cube around the centre that d leaves through: 0 = +n, 1 = -n, 2 = +s,
// 3 = -s, 4 = +t, 5 = -t (ties go to the earlier), each of whose disks the points it serves
// see within 54.7 degrees of its axis. Without `cube`, face 0 is the whole half-space in front
// (d.n >= 0, the one disk facing n that light-space methods sample in any case) and the cube's
// faces serve only what lies behind it. The same float operations on both devices.
PN_INLINE uint sphere_face(vec3 s, vec3 t, vec3 n, bool cube, vec3 d) {
  float x = dot(d, s), y = dot(d, t), z = dot(d, n);
  if (!cube && z >= 0.0f) return 0u;
  float ax = abs(x), ay = abs(y), az = abs(z);
  if (az >= ax && az >= ay) return z >= 0.0f ? 0u : 1u;
  if (ax >= ay) return x >= 0.0f ? 2u : 3u;
  return y >= 0.0f ? 4u : 5u;
}

// AreaLight::sample_area for an untextured light (a textured rect warps u through its table
// first): the rect, the disk, a sphere's disk facing frame.n, an ellipsoid's central ellipse.
PN_INLINE vec3 light_sample_area(LightGeometry L, vec2 u) {
  if (L.shape == kLightRect) return L.center + L.s * ((u.x - 0.5f) * L.size_x) + L.t * ((u.y - 0.5f) * L.size_y);
  vec2 d = concentric_disk(u);
  if (L.shape == kLightEllipsoid) return L.center + L.s * (d.x * L.radii.x) + L.t * (d.y * L.radii.y);
  return L.center + L.s * (d.x * L.radius) + L.t * (d.y * L.radius);
}

// The affine map A of an ellipsoid from the unit sphere, and its inverse.
PN_INLINE vec3 light_from_unit_sphere(LightGeometry L, vec3 x) {
  return L.center + L.s * (x.x * L.radii.x) + L.t * (x.y * L.radii.y) + L.n * (x.z * L.radii.z);
}
PN_INLINE vec3 light_to_unit_sphere(LightGeometry L, vec3 p) {
  vec3 d = p - L.center;
  return vec3(dot(d, L.s) / L.radii.x, dot(d, L.t) / L.radii.y, dot(d, L.n) / L.radii.z);
}

// A planar ellipse center + a x + b y over the unit disk (AreaLight::Ellipse).
struct LightEllipse {
  vec3 center;
  vec3 a;
  vec3 b;
  vec3 normal;
  float area;
};

// AreaLight::section_toward: the unit sphere's central disk perpendicular to A^-1(p), mapped by A.
PN_INLINE LightEllipse light_section_toward(LightGeometry L, vec3 p) {
  vec3 axis = light_to_unit_sphere(L, p);
  vec3 fs = vec3(1.0f, 0.0f, 0.0f);
  vec3 ft = vec3(0.0f, 1.0f, 0.0f);
  vec3 fn = vec3(0.0f, 0.0f, 1.0f);
  if (!(dot(axis, axis) < 1e-20f)) frame_from_z(axis, fs, ft, fn);
  LightEllipse e;
  e.center = L.center;
  e.a = light_from_unit_sphere(L, fs) - L.center;
  e.b = light_from_unit_sphere(L, ft) - L.center;
  vec3 nn = cross(e.a, e.b);
  float len = length(nn);
  e.normal = nn / len;
  e.area = kPiShared * len;
  return e;
}

// AreaLight::contour_toward: A of the unit sphere's silhouette circle seen from A^-1(p).
PN_INLINE LightEllipse light_contour_toward(LightGeometry L, vec3 p) {
  vec3 pu = light_to_unit_sphere(L, p);
  float d2 = max(dot(pu, pu), 1.0f);
  vec3 fs;
  vec3 ft;
  vec3 fn;
  frame_from_z(pu, fs, ft, fn);
  float rho = sqrt(max(0.0f, 1.0f - 1.0f / d2));
  LightEllipse e;
  e.center = light_from_unit_sphere(L, pu / d2);
  e.a = light_from_unit_sphere(L, fs * rho) - L.center;
  e.b = light_from_unit_sphere(L, ft * rho) - L.center;
  vec3 nn = cross(e.a, e.b);
  float len = length(nn);
  e.normal = len > 0.0f ? nn / len : fn;
  e.area = kPiShared * len;
  return e;
}

// AreaLight::sample_area_toward for an untextured light: a sphere's disk perpendicular to the
// direction toward p, an ellipsoid's central ellipse conjugate to it, else sample_area.
PN_INLINE vec3 light_sample_area_toward(LightGeometry L, vec2 u, vec3 p) {
  if (L.shape == kLightEllipsoid) {
    LightEllipse e = light_section_toward(L, p);
    vec2 d = concentric_disk(u);
    return L.center + e.a * d.x + e.b * d.y;
  }
  if (L.shape != kLightSphere) return light_sample_area(L, u);
  vec3 axis = p - L.center;
  if (dot(axis, axis) < 1e-20f) return light_sample_area(L, u);
  vec3 fs;
  vec3 ft;
  vec3 fn;
  frame_from_z(axis, fs, ft, fn);
  vec2 d = concentric_disk(u);
  return L.center + fs * (d.x * L.radius) + ft * (d.y * L.radius);
}

// ---------------------------------------------------------------------------------------------
// Direction sampling from one point (LightPointSampler): the per-point set-up once, then each
// sample. Modes:
PN_CONST uint kSamplerNone = 0u;           // p sees no part of the emitting side
PN_CONST uint kSamplerSphericalRect = 1u;  // Urena, Fajardo, King 2013, Algorithm 1
PN_CONST uint kSamplerCone = 2u;           // uniform in the cone toward a sphere
PN_CONST uint kSamplerArea = 3u;           // disks, textured or tiny rects: area samples
PN_CONST uint kSamplerEllipse = 4u;        // area samples on an ellipsoid's contour ellipse

struct LightSampler {
  uint mode;
  vec3 p;
  // Spherical rectangle: the rect's frame around p (x, y, z) and Algorithm 1's quantities.
  vec3 rx;
  vec3 ry;
  vec3 rz;
  float z0;
  float x0;
  float y0;
  float x1;
  float y1;
  float b0;
  float b1;
  float k;
  float solid_angle;
  // Cone: its frame (n toward the centre), cos of its half-angle, centre - p.
  vec3 cs;
  vec3 ct;
  vec3 cn;
  float cos_max;
  vec3 to_center;
  float dist2_minus_r2;
  float cone_inv_pdf;
  // Ellipse: the contour seen from p, |centre - p|^2 and the cosine at its centre.
  LightEllipse ellipse;
  float dist2;
  float contour_cos;
};

PN_INLINE LightSampler light_sampler_init(LightGeometry L, bool textured, vec3 p) {
  LightSampler S;
  S.mode = kSamplerNone;
  S.p = p;
  S.rx = vec3(0.0f);
  S.ry = vec3(0.0f);
  S.rz = vec3(0.0f);
  S.z0 = 0.0f;
  S.x0 = 0.0f;
  S.y0 = 0.0f;
  S.x1 = 0.0f;
  S.y1 = 0.0f;
  S.b0 = 0.0f;
  S.b1 = 0.0f;
  S.k = 0.0f;
  S.solid_angle = 0.0f;
  S.cs = vec3(0.0f);
  S.ct = vec3(0.0f);
  S.cn = vec3(0.0f);
  S.cos_max = 0.0f;
  S.to_center = vec3(0.0f);
  S.dist2_minus_r2 = 0.0f;
  S.cone_inv_pdf = 0.0f;
  S.ellipse.center = vec3(0.0f);
  S.ellipse.a = vec3(0.0f);
  S.ellipse.b = vec3(0.0f);
  S.ellipse.normal = vec3(0.0f);
  S.ellipse.area = 0.0f;
  S.dist2 = 0.0f;
  S.contour_cos = 1.0f;
  if (!light_faces(L, p)) return S;
  if (L.shape == kLightSphere) {
    vec3 to_c = L.center - p;
    S.dist2 = dot(to_c, to_c);
    S.cos_max = sqrt(max(0.0f, 1.0f - L.radius * L.radius / S.dist2));
    frame_from_z(to_c / sqrt(S.dist2), S.cs, S.ct, S.cn);
    S.to_center = to_c;
    S.dist2_minus_r2 = S.dist2 - L.radius * L.radius;
    S.cone_inv_pdf = 1.0f / uniform_cone_pdf(S.cos_max);
    S.mode = kSamplerCone;
    return S;
  }
  if (L.shape == kLightEllipsoid) {
    // Uniform area samples on the contour ellipse cover exactly the tangent cone; the weights
    // make V the fraction of the cone's solid angle p sees, as the cone does for a sphere.
    S.ellipse = light_contour_toward(L, p);
    if (!(S.ellipse.area > 0.0f)) return S;
    vec3 dc = S.ellipse.center - p;
    S.dist2 = dot(dc, dc);
    S.contour_cos = abs(dot(normalize(dc), S.ellipse.normal));
    S.mode = kSamplerEllipse;
    return S;
  }
  S.mode = kSamplerArea;
  if (L.shape != kLightRect || textured) return S;
  // Spherical rectangle set-up: the rect's frame with p at the origin, the four corner planes
  // and the solid angle.
  vec3 ex = L.s * L.size_x;
  vec3 ey = L.t * L.size_y;
  vec3 corner = L.center - ex * 0.5f - ey * 0.5f;
  vec3 x = L.s;
  vec3 y = L.t;
  vec3 z = cross(x, y);
  vec3 d = corner - p;
  S.z0 = dot(d, z);
  if (S.z0 > 0.0f) {
    z = -z;
    S.z0 = -S.z0;
  }
  S.rx = x;
  S.ry = y;
  S.rz = z;
  S.x0 = dot(d, x);
  S.y0 = dot(d, y);
  S.x1 = S.x0 + L.size_x;
  S.y1 = S.y0 + L.size_y;
  vec3 v00 = vec3(S.x0, S.y0, S.z0);
  vec3 v01 = vec3(S.x0, S.y1, S.z0);
  vec3 v10 = vec3(S.x1, S.y0, S.z0);
  vec3 v11 = vec3(S.x1, S.y1, S.z0);
  vec3 n0 = normalize(cross(v00, v10));
  vec3 n1 = normalize(cross(v10, v11));
  vec3 n2 = normalize(cross(v11, v01));
  vec3 n3 = normalize(cross(v01, v00));
  float g0 = pn_acos(clamp(-dot(n0, n1), -1.0f, 1.0f));
  float g1 = pn_acos(clamp(-dot(n1, n2), -1.0f, 1.0f));
  float g2 = pn_acos(clamp(-dot(n2, n3), -1.0f, 1.0f));
  float g3 = pn_acos(clamp(-dot(n3, n0), -1.0f, 1.0f));
  S.b0 = n0.z;
  S.b1 = n2.z;
  S.k = 2.0f * kPiShared - g2 - g3;
  S.solid_angle = g0 + g1 - S.k;
  // Too small a solid angle for the parametrisation to be accurate: sample by area.
  if (!isinf(S.solid_angle) && !isnan(S.solid_angle) && S.solid_angle > 1e-5f && -S.z0 > 1e-6f)
    S.mode = kSamplerSphericalRect;
  return S;
}

// One sample (LightPointSampler::sample): the unit direction, the distance to the light point,
// the solid-angle density and area_weight = (area density) / (solid-angle density). False
// where the sample is unusable. In kSamplerArea mode a textured light's caller has already
// warped u through its table (light_sample_area then places it uniformly).
PN_INLINE bool light_sampler_sample(LightSampler S, LightGeometry L, vec2 u, PN_OUT(vec3) dir, PN_OUT(float) dist,
                                    PN_OUT(float) pdf, PN_OUT(float) area_weight) {
  dir = vec3(0.0f);
  dist = 0.0f;
  pdf = 0.0f;
  area_weight = 0.0f;
  if (S.mode == kSamplerCone) {
    vec3 c = uniform_cone(u, S.cos_max);
    vec3 w = S.cs * c.x + S.ct * c.y + S.cn * c.z;
    // Distance to the near intersection with the sphere.
    float b = dot(w, L.center - S.p);
    float disc = b * b - (S.dist2 - L.radius * L.radius);
    dir = w;
    dist = b - sqrt(max(0.0f, disc));
    pdf = uniform_cone_pdf(S.cos_max);
    area_weight = 1.0f;  // visibility of a sphere: the fraction of its solid angle
    return true;
  }
  if (S.mode == kSamplerSphericalRect) {
    float au = u.x * S.solid_angle + S.k;
    float fu = (pn_cos(au) * S.b0 - S.b1) / pn_sin(au);
    float sign_fu = (floatBitsToUint(fu) >> 31) != 0u ? -1.0f : 1.0f;  // copysign(1, fu)
    float cu = sign_fu / sqrt(fu * fu + S.b0 * S.b0);
    cu = clamp(cu, -1.0f, 1.0f);
    float xu = -(cu * S.z0) / sqrt(max(1e-12f, 1.0f - cu * cu));
    xu = clamp(xu, S.x0, S.x1);
    float d = sqrt(xu * xu + S.z0 * S.z0);
    float h0 = S.y0 / sqrt(d * d + S.y0 * S.y0);
    float h1 = S.y1 / sqrt(d * d + S.y1 * S.y1);
    float hv = h0 + u.y * (h1 - h0);
    float hv2 = hv * hv;
    float yv = hv2 < 1.0f - 1e-6f ? (hv * d) / sqrt(1.0f - hv2) : S.y1;
    yv = clamp(yv, S.y0, S.y1);
    vec3 q = S.p + S.rx * xu + S.ry * yv + S.rz * S.z0;
    vec3 dq = q - S.p;
    dist = length(dq);
    dir = dq / dist;
    pdf = 1.0f / S.solid_angle;
    float cos_l = abs(dot(dir, L.n));
    // p_A expressed per solid angle: dist^2 / (A cos_l); its ratio to 1/Omega.
    area_weight = cos_l > 1e-8f ? dist * dist / (L.area * cos_l) * S.solid_angle : 0.0f;
    return true;
  }
  if (S.mode == kSamplerArea) {
    vec3 dq = light_sample_area(L, u) - S.p;
    dist = length(dq);
    if (dist < 1e-12f) return false;
    dir = dq / dist;
    float cos_l = abs(dot(dir, L.n));
    if (cos_l < 1e-8f) return false;
    pdf = dist * dist / (L.area * cos_l);
    area_weight = 1.0f;
    return true;
  }
  if (S.mode == kSamplerEllipse) {
    vec2 e = concentric_disk(u);
    vec3 dq = S.ellipse.center + S.ellipse.a * e.x + S.ellipse.b * e.y - S.p;
    dist = length(dq);
    if (dist < 1e-12f) return false;
    dir = dq / dist;
    float cos_l = abs(dot(dir, S.ellipse.normal));
    if (cos_l < 1e-8f) return false;
    pdf = dist * dist / (S.ellipse.area * cos_l);
    // Uniform solid angle over the cone relative to this density, up to a constant (the
    // estimate is self-normalised): 1/pdf, scaled to about 1 by the centre's value.
    area_weight = cos_l * S.dist2 / (dist * dist * S.contour_cos);
    return true;
  }
  return false;
}

// ---------------------------------------------------------------------------------------------
// Unshadowed irradiance (AreaLight::unshadowed_irradiance_scalar): Lambert's formula
// E = 1/2 |sum_i theta_i (n . gamma_i)| over a convex polygon of unit radiance, clipped to the
// hemisphere of n (Sutherland-Hodgman against one plane), in double precision; streamed vertex
// by vertex so no array is needed.
struct PolygonIrradiance {
  dvec3 n;
  dvec3 first_in;  // the input polygon's first vertex (relative to p)
  dvec3 prev_in;
  double prev_d;   // dot(prev_in, n)
  dvec3 first_out;  // the clipped polygon's first and last vertices
  dvec3 last_out;
  int count_in;
  int count_out;
  double sum;
};

PN_INLINE PolygonIrradiance polygon_irradiance_begin(vec3 n) {
  PolygonIrradiance s;
  s.n = dvec3(n);
  s.first_in = dvec3(double(0.0f));
  s.prev_in = dvec3(double(0.0f));
  s.prev_d = double(0.0f);
  s.first_out = dvec3(double(0.0f));
  s.last_out = dvec3(double(0.0f));
  s.count_in = 0;
  s.count_out = 0;
  s.sum = double(0.0f);
  return s;
}

// One edge's term theta (n . gamma) / |gamma|, gamma = a x b, theta = atan2(|a x b|, a . b):
// accurate for the small angles of far lights, where acos loses half its digits.
PN_INLINE double polygon_edge_term(dvec3 a, dvec3 b, dvec3 n) {
  dvec3 c = cross(a, b);
  double lc = sqrt(dot(c, c));
  if (lc < double(1e-15f)) return double(0.0f);  // an edge through p, or a degenerate one
  return atan2_double(lc, dot(a, b)) * dot(c, n) / lc;
}

PN_INLINE void polygon_irradiance_emit(PN_INOUT(PolygonIrradiance) s, dvec3 v) {
  if (s.count_out > 0) s.sum += polygon_edge_term(s.last_out, v, s.n);
  else s.first_out = v;
  s.last_out = v;
  s.count_out += 1;
}

// The input edge from a to b (relative to p): a if above the horizon, then the crossing.
PN_INLINE void polygon_irradiance_edge(PN_INOUT(PolygonIrradiance) s, dvec3 a, double da, dvec3 b, double db) {
  if (da >= double(0.0f)) polygon_irradiance_emit(s, a);
  if ((da >= double(0.0f)) != (db >= double(0.0f))) {
    double t = da / (da - db);
    polygon_irradiance_emit(s, dvec3(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y), a.z + t * (b.z - a.z)));
  }
}

// The next vertex q of the polygon (world space), seen from p.
PN_INLINE void polygon_irradiance_vertex(PN_INOUT(PolygonIrradiance) s, vec3 q, vec3 p) {
  dvec3 v = dvec3(double(q.x) - double(p.x), double(q.y) - double(p.y), double(q.z) - double(p.z));
  double d = dot(v, s.n);
  if (s.count_in == 0) s.first_in = v;
  else polygon_irradiance_edge(s, s.prev_in, s.prev_d, v, d);
  s.prev_in = v;
  s.prev_d = d;
  s.count_in += 1;
}

PN_INLINE double polygon_irradiance_end(PN_INOUT(PolygonIrradiance) s) {
  if (s.count_in > 0) polygon_irradiance_edge(s, s.prev_in, s.prev_d, s.first_in, dot(s.first_in, s.n));
  if (s.count_out < 3) return double(0.0f);
  s.sum += polygon_edge_term(s.last_out, s.first_out, s.n);
  return double(0.5f) * abs(s.sum);
}

// The vertices of a disk's and an ellipse's 256-gon: unit_circle holds cos and sin of
// 2 pi i / 256 (512 floats, interleaved), computed once by the CPU and uploaded to the GPU.
PN_CONST int kCircleSegments = 256;

// AreaLight::unshadowed_irradiance_scalar for rect, disk and ellipsoid (sphere below).
PN_INLINE float light_irradiance_polygon(LightGeometry L, vec3 p, vec3 n, PN_FLOAT_ARRAY unit_circle) {
  PolygonIrradiance s = polygon_irradiance_begin(n);
  if (L.shape == kLightRect) {
    vec3 hs = L.s * (0.5f * L.size_x);
    vec3 ht = L.t * (0.5f * L.size_y);
    polygon_irradiance_vertex(s, L.center - hs - ht, p);  // as AreaLight::outline()
    polygon_irradiance_vertex(s, L.center + hs - ht, p);
    polygon_irradiance_vertex(s, L.center + hs + ht, p);
    polygon_irradiance_vertex(s, L.center - hs + ht, p);
  } else if (L.shape == kLightDisk) {
    // A 256-gon inscribed in the disk, rescaled to the disk's area: the relative error of the
    // irradiance is below 1e-4 for any point.
    float r = L.radius * sqrt((2.0f * kPiShared / float(kCircleSegments)) / pn_sin(2.0f * kPiShared / float(kCircleSegments)));
    for (int i = 0; i < kCircleSegments; ++i)
      polygon_irradiance_vertex(
          s, L.center + L.s * (r * PN_AT(unit_circle, uint(2 * i))) + L.t * (r * PN_AT(unit_circle, uint(2 * i + 1))), p);
  } else {
    // Ellipsoid: the tangent cone from p, whose contour is A of the unit sphere's silhouette
    // circle seen from A^-1(p); a 256-gon inscribed in it, rescaled to the ellipse's area.
    LightEllipse e = light_contour_toward(L, p);
    float scale = sqrt((2.0f * kPiShared / float(kCircleSegments)) / pn_sin(2.0f * kPiShared / float(kCircleSegments)));
    for (int i = 0; i < kCircleSegments; ++i)
      polygon_irradiance_vertex(
          s, e.center + (e.a * PN_AT(unit_circle, uint(2 * i)) + e.b * PN_AT(unit_circle, uint(2 * i + 1))) * scale, p);
  }
  return float(polygon_irradiance_end(s));
}

// A sphere: pi sin^2(alpha) cos(theta) when the whole cap is above the horizon; across the
// horizon, a deterministic stratified quadrature over the cone.
PN_INLINE float light_irradiance_sphere(LightGeometry L, vec3 p, vec3 n) {
  vec3 to_c = L.center - p;
  float d2 = dot(to_c, to_c);
  float d = sqrt(d2);
  float sin2 = L.radius * L.radius / d2;
  float sin_a = sqrt(sin2);
  float cos_t = dot(n, to_c / d);
  if (cos_t >= sin_a) return kPiShared * sin2 * cos_t;
  if (cos_t <= -sin_a) return 0.0f;
  float cos_max = sqrt(max(0.0f, 1.0f - sin2));
  vec3 fs;
  vec3 ft;
  vec3 fn;
  frame_from_z(to_c / d, fs, ft, fn);
  const int k = 64;
  double sum = double(0.0f);
  for (int j = 0; j < k; ++j)
    for (int i = 0; i < k; ++i) {
      vec3 c = uniform_cone(vec2((float(i) + 0.5f) / float(k), (float(j) + 0.5f) / float(k)), cos_max);
      vec3 w = fs * c.x + ft * c.y + fn * c.z;
      sum += double(max(0.0f, dot(w, n)));
    }
  return float(sum / double(k * k) / double(uniform_cone_pdf(cos_max)));
}

// The unshadowed irradiance of unit radiance at p with normal n (0 where p does not face it).
PN_INLINE float light_irradiance(LightGeometry L, vec3 p, vec3 n, PN_FLOAT_ARRAY unit_circle) {
  if (!light_faces(L, p)) return 0.0f;
  if (L.shape == kLightSphere) return light_irradiance_sphere(L, p, n);
  return light_irradiance_polygon(L, p, n, unit_circle);
}

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::LightGeometry) == 80);
#endif

#endif  // PENUMBRA_SCENE_LIGHT_SHARED_H
