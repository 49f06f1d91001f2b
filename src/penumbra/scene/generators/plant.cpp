// A plant: a branching skeleton from a parametric L-system carrying thousands of small
// leaves. The analogue of agrawala2000's plant scene (§6): many small, separated
// occluders that give complex, overlapping penumbrae.
//
// The skeleton is Honda's monopodial tree model as written in Prusinkiewicz & Lindenmayer,
// "The Algorithmic Beauty of Plants" (1990), §2.2, Fig. 2.6:
//   w : A(1, 10)
//   p1: A(l, w) -> !(w) F(l) [ &(a0) B(l r2, w wr) ] /(d) A(l r1, w wr)
//   p2: B(l, w) -> !(w) F(l) [ -(a2) $ C(l r2, w wr) ] C(l r1, w wr)
//   p3: C(l, w) -> !(w) F(l) [ +(a2) $ B(l r2, w wr) ] B(l r1, w wr)
// with d = 137.5 degrees (phyllotaxis), wr = 0.707, r1 = 0.9, r2 = 0.7 and
// a0 = a2 = branch_angle. Angles and lengths are jittered per module by `randomness`,
// keyed by (seed, iteration, module), so the plant is a pure function of its parameters.
// Leaves (two-sided diamonds, 2 triangles each) are attached to the twigs: the segments
// grown in the last three iterations. With leaf_texture = "mask" each leaf is instead a quad
// carrying the generator's RGBA leaf image as an alpha mask (issue 20: foliage as asset
// libraries ship it), and with "triangles" the same outline is modelled in triangles, for
// comparing the two.
#include <cmath>
#include <memory>

#include "penumbra/scene/generators/plant.h"

#include "penumbra/core/error.h"
#include "penumbra/core/rng.h"
#include "penumbra/scene/generators.h"
#include "penumbra/scene/shapes.h"

namespace penumbra {
namespace {

using nlohmann::json;

struct Module {
  char sym;
  float a = 0, b = 0;  // F: length; !: width; turns: angle (degrees); A/B/C: (length, width)
  int gen = 0;         // the iteration that created it
};

struct LSystem {
  float branch_angle, randomness;
  uint64_t seed;
  static constexpr float kDivergence = 137.5f, kWidthRatio = 0.707f, kR1 = 0.9f, kR2 = 0.7f;

  std::vector<Module> derive(int iterations) const {
    std::vector<Module> s = {{'A', 1.0f, 10.0f, 0}};
    for (int it = 1; it <= iterations; ++it) {
      std::vector<Module> next;
      next.reserve(s.size() * 3);
      for (size_t i = 0; i < s.size(); ++i) {
        const Module& m = s[i];
        if (m.sym != 'A' && m.sym != 'B' && m.sym != 'C') {
          next.push_back(m);
          continue;
        }
        Rng rng(seed, static_cast<uint64_t>(it), i);
        auto vary = [&](float v, float amount) { return v * (1 + amount * randomness * (2 * rng.next_float() - 1)); };
        const float l = m.a, w = m.b, w2 = w * kWidthRatio;
        const float angle = vary(branch_angle, 0.4f);
        next.push_back({'!', w, 0, it});
        next.push_back({'F', vary(l, 0.3f), 0, it});
        next.push_back({'[', 0, 0, it});
        if (m.sym == 'A') {
          next.push_back({'&', angle, 0, it});
          next.push_back({'B', l * kR2, w2, it});
          next.push_back({']', 0, 0, it});
          next.push_back({'/', vary(kDivergence, 0.1f), 0, it});
          next.push_back({'A', l * kR1, w2, it});
        } else {
          // B turns right into a C, C turns left into a B: branches alternate sides.
          next.push_back({m.sym == 'B' ? '-' : '+', angle, 0, it});
          next.push_back({'$', 0, 0, it});
          next.push_back({m.sym == 'B' ? 'C' : 'B', l * kR2, w2, it});
          next.push_back({']', 0, 0, it});
          next.push_back({m.sym == 'B' ? 'C' : 'B', l * kR1, w2, it});
        }
      }
      s = std::move(next);
    }
    return s;
  }
};

struct Segment {
  Vec3f a, b;
  int gen;
};

// An axis of the plant: consecutive F's not separated by a branch, drawn as one tube
// (no caps inside it, and no coincident caps where two segments meet).
struct Chain {
  std::vector<Vec3f> points;
  std::vector<float> widths;  // per point
};

Vec3f rotate_about(Vec3f v, Vec3f axis, float deg) {
  float c = std::cos(radians(deg)), s = std::sin(radians(deg));
  return v * c + cross(axis, v) * s + axis * (dot(axis, v) * (1 - c));
}

// The turtle of ABOP §1.5: heading H, left L, up U (H x L = U).
void interpret(const std::vector<Module>& modules, std::vector<Segment>* segments,
               std::vector<Chain>* chains) {
  struct Turtle {
    Vec3f pos{0, 0, 0}, H{0, 1, 0}, L{-1, 0, 0}, U{0, 0, 1};
    float width = 1;
    int chain = -1;  // the axis being drawn; -1: the next F starts a new one
  };
  std::vector<Turtle> stack;
  Turtle t;
  for (const Module& m : modules) {
    switch (m.sym) {
      case 'F': {
        Vec3f next = t.pos + t.H * m.a;
        segments->push_back({t.pos, next, m.gen});
        if (t.chain < 0) {
          t.chain = static_cast<int>(chains->size());
          chains->push_back({{t.pos}, {t.width}});
        }
        (*chains)[t.chain].points.push_back(next);
        (*chains)[t.chain].widths.push_back(t.width);
        t.pos = next;
        break;
      }
      case '!': t.width = m.a; break;
      case '+': t.H = rotate_about(t.H, t.U, m.a); t.L = rotate_about(t.L, t.U, m.a); break;
      case '-': t.H = rotate_about(t.H, t.U, -m.a); t.L = rotate_about(t.L, t.U, -m.a); break;
      case '&': t.H = rotate_about(t.H, t.L, m.a); t.U = rotate_about(t.U, t.L, m.a); break;
      case '/': t.L = rotate_about(t.L, t.H, m.a); t.U = rotate_about(t.U, t.H, m.a); break;
      case '$': {  // roll so that L is horizontal (ABOP eq. 2.2)
        Vec3f l = cross(Vec3f(0, 1, 0), t.H);
        if (length_squared(l) > 1e-8f) {
          t.L = normalize(l);
          t.U = cross(t.H, t.L);
        }
        break;
      }
      case '[':
        stack.push_back(t);
        t.chain = -1;  // a branch is a new axis
        break;
      case ']': t = stack.back(); stack.pop_back(); break;
      default: break;  // A, B, C: apices left after the last iteration
    }
  }
}

// The outline of a textured leaf on its card ([0,1]^2, u across, v from base to tip): half
// width h(v) = 0.46 sin(pi v) (1 - 0.3 v) around u = 0.5, a pointed oval. `leaf_texture`
// "mask" draws it into an image, "triangles" models it as a polygon of the same curve: the two
// cast the same shadow up to the image's resolution (~1/4 texel on the edge).
struct LeafOutline {
  static constexpr int kSegments = 24;  // per side; the chord error is ~1e-3 of the leaf's length
  static float half_width(float v) { return 0.46f * std::sin(kPi * v) * (1.0f - 0.3f * v); }
  std::vector<Vec2f> points;  // counter-clockwise (u right, v up)
  Vec2f centre{0.5f, 0.45f};  // sees every edge from inside
  LeafOutline() {
    for (int i = 0; i <= kSegments; ++i) {  // right side, base to tip
      const float v = static_cast<float>(i) / kSegments;
      points.push_back({0.5f + half_width(v), v});
    }
    for (int i = kSegments - 1; i > 0; --i) {  // left side, tip to base
      const float v = static_cast<float>(i) / kSegments;
      points.push_back({0.5f - half_width(v), v});
    }
  }
  bool inside(Vec2f uv) const { return std::abs(uv.x - 0.5f) <= half_width(uv.y) && uv.y >= 0 && uv.y <= 1; }
};

// The leaf's RGBA image: alpha = the outline's coverage of each texel (4 x 4 samples, so the
// bilinear 0.5 contour follows the curve within a fraction of a texel); green with a lighter
// midrib. Row 0 is the tip (v = 1).
Texture leaf_image(const LeafOutline& outline, int resolution) {
  const int n = resolution;
  std::vector<float> rgba(static_cast<size_t>(n) * n * 4);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      int covered = 0;
      for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i)
          covered += outline.inside({(x + (i + 0.5f) / 4) / n, 1.0f - (y + (j + 0.5f) / 4) / n});
      const float u = (x + 0.5f) / n;
      const bool midrib = std::abs(u - 0.5f) < 0.02f;
      const Vec3f c = midrib ? Vec3f(0.35f, 0.55f, 0.2f) : Vec3f(0.22f, 0.45f, 0.12f);
      float* t = &rgba[(static_cast<size_t>(y) * n + x) * 4];
      t[0] = c.x, t[1] = c.y, t[2] = c.z, t[3] = covered / 16.0f;
    }
  return Texture(n, n, std::move(rgba), true, "plant leaf image");
}

}  // namespace

std::shared_ptr<const Texture> plant_leaf_image(int resolution) {
  return std::make_shared<const Texture>(leaf_image(LeafOutline(), resolution));
}

std::vector<SceneObject> grow_plant(const PlantSettings& p) {
  const uint64_t seed = p.seed;
  const int leaves = p.leaves, iterations = p.iterations, sides = p.sides;
  const float height = p.height, leaf_size = p.leaf_size, trunk_radius = p.trunk_radius;
  LSystem lsys{p.branch_angle, p.randomness, seed};
  std::vector<Segment> segs;
  std::vector<Chain> chains;
  interpret(lsys.derive(iterations), &segs, &chains);

  // Scale the skeleton to the requested height, trunk base at the origin.
  float top = 0;
  for (const auto& s : segs) top = std::max(top, std::max(s.a.y, s.b.y));
  if (!(top > 0)) throw Error("the skeleton has no height (branch_angle too large?)");
  const float scale = height / top;
  const float w0 = 10.0f;  // the axiom's width
  SceneObject stems;
  stems.name = "stems";
  stems.material.albedo = Vec3f(0.42f, 0.3f, 0.2f);
  for (Chain& c : chains) {
    for (Vec3f& p : c.points) p = p * scale;
    // Thin twigs are kept at a visible minimum radius (8% of the trunk's).
    for (float& w : c.widths) w = trunk_radius * height * std::max(w / w0, 0.08f);
    stems.mesh.append(make_tube(c.points, c.widths, sides, /*loop=*/false, /*caps=*/true));
  }
  std::vector<size_t> twigs;
  for (size_t i = 0; i < segs.size(); ++i) {
    segs[i].a = segs[i].a * scale;
    segs[i].b = segs[i].b * scale;
    if (segs[i].gen > iterations - 3) twigs.push_back(i);
  }

  const std::string& leaf_mode = p.leaf_texture;
  if (leaf_mode != "none" && leaf_mode != "mask" && leaf_mode != "triangles")
    throw Error("leaf_texture \"{}\": expected \"none\", \"mask\" or \"triangles\"", leaf_mode);
  const LeafOutline outline;
  SceneObject foliage;
  foliage.name = "leaves";
  foliage.material.albedo = Vec3f(0.22f, 0.45f, 0.12f);
  foliage.material.two_sided = true;
  if (leaf_mode == "mask") {
    // issue 20: a quad per leaf, the leaf drawn by the generator's own RGBA image.
    std::shared_ptr<const Texture> image = p.leaf_image ? p.leaf_image : plant_leaf_image(p.leaf_texture_resolution);
    foliage.material.albedo = Vec3f(1.0f);
    foliage.material.albedo_texture = image;
    foliage.material.alpha = SurfaceAlpha{image, AlphaMode::Mask, 0.5f};
  }
  TriangleMesh& m = foliage.mesh;
  m.positions.reserve(4 * static_cast<size_t>(leaves));
  m.indices.reserve(6 * static_cast<size_t>(leaves));
  const Vec3f up(0, 1, 0);
  for (int k = 0; k < leaves; ++k) {
    // One stream per leaf: leaf k does not move when `leaves` changes.
    Rng rng(seed, 0x6c656166 /* "leaf" */, static_cast<uint64_t>(k));
    const Segment& s = segs[twigs[rng.uniform_int(static_cast<uint32_t>(twigs.size()))]];
    Vec3f axis = normalize(s.b - s.a);
    Vec3f pos = s.a + (s.b - s.a) * rng.next_float();
    Vec3f e1, e2;
    coordinate_system(axis, &e1, &e2);
    float around = 2 * kPi * rng.next_float();
    Vec3f out = e1 * std::cos(around) + e2 * std::sin(around);
    // Leaves point outward and along the twig, a little upward (toward the light).
    Vec3f d = normalize(out + axis * 0.6f + up * 0.3f);
    Vec3f w = cross(up, d);
    w = length_squared(w) > 1e-6f ? normalize(w) : e1;
    w = rotate_about(w, d, 60.0f * (rng.next_float() - 0.5f));
    float len = leaf_size * height * (0.75f + 0.5f * rng.next_float()), half_width = 0.25f * len;
    uint32_t base = static_cast<uint32_t>(m.positions.size());
    if (leaf_mode != "none") {
      // The leaf's card: u across (along w), v from the base (pos) to the tip (pos + d len).
      auto at = [&](Vec2f uv) { return pos + w * ((uv.x - 0.5f) * 2 * half_width) + d * (uv.y * len); };
      if (leaf_mode == "mask") {
        for (Vec2f uv : {Vec2f{0, 0}, Vec2f{1, 0}, Vec2f{1, 1}, Vec2f{0, 1}}) {
          m.positions.push_back(at(uv));
          m.uvs.push_back(uv);
        }
        // Counter-clockwise seen from the side cross(w, d) points to.
        m.indices.insert(m.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
      } else {
        // The same outline in triangles: a fan from an inner point of the (star-shaped) leaf.
        m.positions.push_back(at(outline.centre));
        for (Vec2f uv : outline.points) m.positions.push_back(at(uv));
        const uint32_t n = static_cast<uint32_t>(outline.points.size());
        for (uint32_t i = 0; i < n; ++i)
          m.indices.insert(m.indices.end(), {base, base + 1 + i, base + 1 + (i + 1) % n});
      }
      continue;
    }
    m.positions.push_back(pos);
    m.positions.push_back(pos + d * (0.4f * len) + w * half_width);
    m.positions.push_back(pos + d * len);
    m.positions.push_back(pos + d * (0.4f * len) - w * half_width);
    // Front face (counter-clockwise) upward.
    m.indices.insert(m.indices.end(), {base, base + 2, base + 1, base, base + 3, base + 2});
  }
  return {std::move(stems), std::move(foliage)};
}

namespace {

std::vector<SceneObject> generate_plant(const json& params) {
  PlantSettings p;
  p.seed = params["seed"].get<uint64_t>();
  p.leaves = params["leaves"].get<int>();
  p.iterations = params["iterations"].get<int>();
  p.sides = params["sides"].get<int>();
  p.height = params["height"].get<float>();
  p.leaf_size = params["leaf_size"].get<float>();
  p.trunk_radius = params["trunk_radius"].get<float>();
  p.branch_angle = params["branch_angle"].get<float>();
  p.randomness = params["randomness"].get<float>();
  p.leaf_texture = params["leaf_texture"].get<std::string>();
  p.leaf_texture_resolution = params["leaf_texture_resolution"].get<int>();
  return grow_plant(p);
}

json plant_example(const json& params) {
  ExampleSceneLayout layout;
  layout.eye = Vec3f(0, 1.25f, 2.2f);
  layout.target = Vec3f(0.1f, 0.45f, 0);
  json object = {{"generator", "plant"}, {"params", params}};
  return example_scene_document(object, layout);
}

GeneratorRegistration reg(GeneratorInfo{
    "plant",
    "an L-system tree (Honda's model, ABOP §2.2) with thousands of small two-sided leaves, on y = 0",
    {
        {"seed", 1, "random seed: same seed, same plant", 0, 2147483647},
        {"leaves", 3000, "number of leaves (2 triangles each)", 0, 1000000},
        {"iterations", 9, "L-system derivation steps (branching depth)", 1, 14},
        {"height", 1.0, "height of the skeleton", 1e-3, 1000},
        {"leaf_size", 0.06, "leaf length as a fraction of the height (varies +-25%)", 1e-4, 1},
        {"trunk_radius", 0.015, "trunk radius as a fraction of the height", 1e-4, 0.5},
        {"branch_angle", 45.0, "branching angle in degrees (a0 = a2 of Honda's model)", 0, 120},
        {"randomness", 0.3, "jitter of angles and lengths (0 = the exact L-system)", 0, 1},
        {"sides", 5, "sides of the stem tubes", 3, 64},
        {"leaf_texture", "none",
         "leaf shape: \"none\" (diamonds of 2 triangles), \"mask\" (a quad per leaf with the generator's RGBA "
         "leaf image, alpha-masked), \"triangles\" (the same leaf outline modelled as 48 triangles)"},
        {"leaf_texture_resolution", 128, "size of the leaf image in texels (leaf_texture = mask)", 8, 4096},
    },
    generate_plant,
    plant_example,
});

}  // namespace
}  // namespace penumbra
