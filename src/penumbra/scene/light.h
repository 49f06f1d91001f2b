// Area lights: rectangles, disks, spheres and ellipsoids of uniform radiance. Visibility V
// is the fraction of the light's area a point sees (agrawala2000 eq. 2); irradiance E is eq. 1.
//
// An ellipsoid is the image of the unit sphere under the affine map A: x -> center +
// R S x (R = frame, S = diag(radii)); every sphere quantity is carried over through A
// (sintorn2008 §4.1: "a virtual scaling of the entire scene allows us to reestablish a
// spherical light source"): its sampled disk is A of the unit sphere's, i.e. a central
// ellipse, and its outline is A of the unit sphere's outline polygon.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/core/sampling.h"
#include "penumbra/scene/texture.h"
#include "penumbra/scene/light_batch.h"
#include "penumbra/scene/light_shared.h"

namespace penumbra {

enum class LightShape { Rect, Disk, Sphere, Ellipsoid };
const char* to_string(LightShape s);

// An emission image over a rect light (issue 20 part 3; sintorn2008 §1, §4: a stained-glass
// window, a lamp shade): linear RGB multiplied with the light's radiance, u along frame.s and v
// along frame.t, (0, 0) at the corner center - s size.x/2 - t size.y/2. With one sampling
// table per colour channel (its texels' values) and one for luminance.
struct LightTexture {
  std::shared_ptr<const Texture> image;
  Vec3f mean{1, 1, 1};                // the image's mean colour
  PiecewiseConstant2D channel[3];      // importance sampling of R, G, B
  PiecewiseConstant2D luminance;
  // Throws Error naming the image if a texel is not finite.
  explicit LightTexture(std::shared_ptr<const Texture> image);
  // The table of channel c (0..2), or luminance for c < 0.
  const PiecewiseConstant2D& table(int c) const { return c >= 0 && c < 3 ? channel[c] : luminance; }
};

struct AreaLight {
  LightShape shape = LightShape::Rect;
  Vec3f center{0, 0, 0};
  // frame.n is the emitting normal (rect, disk; one-sided), frame.s the rect's `u` axis.
  // For a sphere, frame.n points from the light toward the scene (set by the loader),
  // which is the axis of the disk that light-space methods sample.
  // For an ellipsoid, the frame of its semi-axes (radii.x along s, .y along t, .z along n),
  // given by the scene; light-space methods sample its central ellipse facing frame.n.
  Frame frame;
  Vec2f size{1, 1};     // rect: full width (along s) and height (along t)
  float radius = 0.5f;  // disk, sphere
  Vec3f radii{0.5f, 0.5f, 0.5f};  // ellipsoid: semi-axes along frame.s, frame.t, frame.n
  Vec3f radiance{1, 1, 1};
  // Rect only: an emission texture (radiance times the image). A renderer draws such a light as
  // one light per colour channel (expand_textured_lights): that light's texture_channel says
  // whose table sample_area() follows; -1 (the light as a scene gives it) follows luminance.
  std::shared_ptr<const LightTexture> texture;
  int texture_channel = -1;
  bool textured() const { return texture != nullptr && shape == LightShape::Rect; }
  // One face of a sphere or ellipsoid light that the scene reaches behind (split_sphere_lights):
  // this light serves only the points of face `split_face` of `split_frame` (sphere_face,
  // light_shared.h: a face of the cube around the centre; without split_cube, face 0 is the
  // whole half-space in front), and its frame.n is that face's axis. -1: a whole light, serving
  // every point.
  int split_face = -1;
  int split_faces = 0;     // how many faces its sphere became (0: a whole light)
  bool split_cube = false;  // sphere_face's `cube`: the whole cube (a sphere inside the scene's bounds)
  Frame split_frame;
  // Whether this light draws p (always, unless it is a face of a split sphere).
  bool serves(Vec3f p) const {
    return split_face < 0 || shader::sphere_face(split_frame.s, split_frame.t, split_frame.n, split_cube,
                                                 p - center) == static_cast<uint32_t>(split_face);
  }

  // rect and disk: the emitting area; sphere: its cross-section disk; ellipsoid: its central
  // ellipse facing frame.n (pi radii.x radii.y).
  float area() const;
  // Diameter of the light: rect, the diagonal; disk and sphere, 2r (parker1998's D);
  // ellipsoid, twice its largest semi-axis.
  float diameter() const;
  // Largest distance from the centre to a point of the light (the "light radius" of
  // xie2007 eq. 4 and sintorn2008).
  float extent_radius() const;
  // The light as light_shared.h's functions take it (the CPU and the GPU kernels).
  shader::LightGeometry geometry() const;

  // Map u in [0,1)^2 uniformly onto the light's area: the rect, the disk, or for a sphere
  // the disk through its centre perpendicular to frame.n (what a light-space method sees).
  // A textured rect maps u through its texture's table instead: the points follow the
  // emission, while every caller keeps weighting them as uniform area samples. That is exact
  // importance sampling for a light whose radiance is the texture's mean (what
  // expand_textured_lights gives each channel): E = mean L A E[V G] = integral of L V G.
  Vec3f sample_area(Vec2f u) const;
  // For a sphere, the disk perpendicular to the direction toward `p` (the silhouette seen
  // from p); for an ellipsoid, A of the unit sphere's disk toward A^-1(p) (the central
  // ellipse conjugate to the direction of p); identical to sample_area for rect and disk.
  Vec3f sample_area_toward(Vec2f u, Vec3f p) const;

  // Ellipsoid only: the affine map A from the unit sphere to the light, and its inverse.
  Vec3f from_unit_sphere(Vec3f x) const;
  Vec3f to_unit_sphere(Vec3f p) const;
  // Ellipsoid only: a planar ellipse center + a x + b y, (x, y) in the unit disk; normal =
  // unit normal of its plane, area = pi |a x b|.
  struct Ellipse {
    Vec3f center, a, b, normal;
    float area = 0;
  };
  // The central ellipse sample_area_toward(., p) samples.
  Ellipse section_toward(Vec3f p) const;
  // The contour seen from p (p outside): A of the unit sphere's silhouette circle seen from
  // A^-1(p), the circle of radius sqrt(1 - 1/d^2) around A^-1(p)/d^2 (d = |A^-1(p)|). The
  // cone from p over it is the ellipsoid's tangent cone: every ray through it hits the
  // ellipsoid and every ray that hits the ellipsoid crosses it.
  Ellipse contour_toward(Vec3f p) const;

  // Sample a direction from p toward the light, uniform in solid angle where possible
  // (spherical rectangles, Urena et al. 2013, for rects; cones for spheres; area
  // sampling for disks converted to solid angle; for ellipsoids area sampling of the contour
  // ellipse, weighted to the fraction of the tangent cone's solid angle as for spheres). Returns false if p sees no part of
  // the emitting side. *dir is unit, *dist the distance to the light point, *pdf the
  // solid-angle density, *area_weight = (area pdf)/(solid-angle pdf) for self-normalised
  // estimates of area-fraction visibility.
  struct DirectionSample {
    Vec3f dir;
    float dist = 0;
    float pdf = 0;          // solid angle
    float area_weight = 0;  // p_A / p_omega, both as solid-angle densities
  };
  // (One-off; a loop over many samples at one point should use LightPointSampler.)
  bool sample_direction(Vec3f p, Vec2f u, DirectionSample* out) const;

  // Unshadowed irradiance at p with normal n (closed form): Lambert's polygon formula for
  // rects (clipped to n's hemisphere), disks as a 256-gon (error < 1e-4 relative), and
  // pi * L * sin^2(alpha) * cos(theta) for spheres entirely above the horizon (numeric
  // quadrature across the horizon). Ellipsoids: the surface integral of cos cos / r^2 over
  // the elements facing p equals the projected solid angle of the tangent cone from p (a
  // convex emitter of uniform radiance), whose contour is A of the unit sphere's silhouette
  // circle seen from A^-1(p): Lambert's formula on a 256-gon of that ellipse (rescaled to
  // its area), clipped to n's hemisphere. Per colour channel: radiance times the scalar.
  float unshadowed_irradiance_scalar(Vec3f p, Vec3f n) const;
  Vec3f unshadowed_irradiance(Vec3f p, Vec3f n) const { return radiance * unshadowed_irradiance_scalar(p, n); }
  // The same at many points, out[i] for (p[i], n[i]): equal up to rounding (SIMD for rects,
  // light_kernels::rect_irradiance, in chunks; the other shapes one point at a time).
  void unshadowed_irradiance_scalar(std::span<const Vec3f> p, std::span<const Vec3f> n, std::span<float> out) const;

  // The light's outline as a convex polygon in world space (rect: 4 corners in
  // counter-clockwise order around frame.n; disk: `segments`-gon circumscribing the disk;
  // sphere: circumscribed polygon of the disk facing frame.n; ellipsoid: A of the unit
  // sphere's polygon, which circumscribes its central ellipse facing frame.n).
  std::vector<Vec3f> outline(int segments = 16) const;
  // Whether the emitting side faces p (spheres and ellipsoids: whether p is outside).
  bool faces(Vec3f p) const;
};

// cos and sin of 2 pi i / 256 for i < 256, interleaved (512 floats): the vertices of the disk's
// and the ellipsoid's 256-gons (light_shared.h light_irradiance), computed once; the GPU
// uploads the same floats.
const float* unit_circle_table();

// The lights a renderer draws for `lights`: each textured rect becomes three lights, one per
// colour channel with radiance = that channel of radiance x the image's mean (zero channels
// left out) and sampling that channel's table; V of each is the fraction of its channel's
// emission a point sees, so composing V x unshadowed irradiance per light gives coloured
// penumbrae with every light-sampling method unchanged. Other lights are kept as they are.
std::vector<AreaLight> expand_textured_lights(std::span<const AreaLight> lights);

// The lights a light-space method draws for `lights` in a scene of bounds `scene_bounds`
// (MethodInfo::sphere_through_disk). Such a method samples a sphere through its central disk
// facing frame.n (toward the scene's centre, orient_sphere_lights; an ellipsoid through its
// central ellipse facing the frame.n the scene gave), and a point behind that disk's plane sees
// none of it: right for a sphere beside or above the scene, wrong for a bulb inside a room. So a
// sphere whose scene reaches behind that plane becomes several lights
// (sphere_face, light_shared.h), as a cube shadow map does for a point light: one per face of
// the cube around the centre that the scene reaches, the same sphere with frame.n along the
// face's axis, serving the points whose direction leaves through that face (AreaLight::serves),
// which see its disk within 54.7 degrees of its axis. A sphere outside the scene's bounds (a lamp
// above a ground that reaches a little behind it) keeps its light as it was for the points in
// front of that plane, so they draw what they drew unsplit, and only the points behind go to the
// cube's faces. E stays the sphere's closed form. An ellipsoid is split alike, each face the same
// ellipsoid in a frame whose n is the face's axis (its radii permuted with the axes). Other
// lights are kept.
std::vector<AreaLight> split_sphere_lights(std::span<const AreaLight> lights, const Bounds3f& scene_bounds);
// How many whole lights `lights` holds: each split sphere's faces count once together.
float whole_light_count(std::span<const AreaLight> lights);
// True if any of `lights` is a face of a split sphere (the frame then keeps each face's copy of
// the view samples it serves).
bool has_split_light(std::span<const AreaLight> lights);

// Direction sampling toward a light from one point p: the per-point set-up (the spherical
// rectangle's corner normals and solid angle, the cone's frame) is done once, then each
// sample costs a few trigonometric calls (AreaLight::sample_direction for the estimators).
class LightPointSampler {
 public:
  LightPointSampler(const AreaLight& light, Vec3f p);
  // False if p sees no part of the emitting side (sample() must not be called then).
  bool valid() const { return state_.mode != shader::kSamplerNone; }
  bool sample(Vec2f u, AreaLight::DirectionSample* out) const;
  // The samples u_i = (ux[i], uy[i]), i < n, at once into `out` (structure of arrays; SIMD for
  // rects and spheres, light_batch.h): the same directions as sample() up to rounding.
  // Samples p cannot use are dropped and the rest packed in order; returns how many remain.
  // ux and uy must be padded to a multiple of LightSampleBatch::kLanePad.
  int sample_batch(const float* ux, const float* uy, int n, LightSampleBatch& out) const;

 private:
  const AreaLight* light_;
  shader::LightGeometry geometry_;
  shader::LightSampler state_;  // light_shared.h: the mode and its per-point set-up
  // The SIMD kernels' copies of the spherical rectangle's and the cone's set-up.
  light_kernels::SphericalRect rect_{};
  light_kernels::Cone cone_{};
};

}  // namespace penumbra
