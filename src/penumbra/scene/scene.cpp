#include "penumbra/scene/scene.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <unordered_map>

#include "penumbra/core/error.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/generators.h"
#include "penumbra/scene/json_reader.h"
#include "penumbra/scene/mesh_import.h"
#include "penumbra/scene/scene_values.h"
#include "penumbra/scene/shapes.h"

namespace penumbra {

namespace fs = std::filesystem;
using nlohmann::json;

Bounds3f Scene::bounds() const {
  Bounds3f b;
  for (const auto& o : objects) b.extend(o.mesh.bounds());
  return b;
}

size_t Scene::triangle_count() const {
  size_t n = 0;
  for (const auto& o : objects) n += o.mesh.triangle_count();
  return n;
}

bool Scene::semi_transparent() const {
  for (const SceneObject& o : objects)
    if (o.semi_transparent()) return true;
  return false;
}

void Scene::finalize() {
  // A closed mesh with an alpha texture is not closed to light: its mask has holes; nor is a
  // semi-transparent one: light passes through it, so a point on it sees the light behind its own
  // plane through the mesh, as the rays do (the methods' closed-mesh rules assume an opaque
  // solid). A shared mesh is checked once, in its own space: placing it neither opens nor closes it.
  std::unordered_map<const TriangleMesh*, bool> shared_closed;
  for (auto& o : objects) {
    bool closed = false;
    if (o.shared_mesh) {
      auto [it, first] = shared_closed.try_emplace(o.shared_mesh.get(), false);
      if (first) it->second = o.shared_mesh->is_closed();
      closed = it->second;
    } else {
      closed = o.mesh.is_closed();
    }
    o.closed = closed && !o.material.alpha_textured() && !o.semi_transparent();
  }
  orient_sphere_lights();
}

namespace {
// A rect light's default u: world x projected onto the light's plane (z if the normal is
// along x), so a rect light facing straight down has its width along x and height along z.
Vec3f default_rect_u(Vec3f unit_normal) { return std::abs(unit_normal.x) > 0.999f ? Vec3f(0, 0, 1) : Vec3f(1, 0, 0); }
}  // namespace

Frame light_frame(LightShape shape, Vec3f normal, const std::optional<Vec3f>& u) {
  const Vec3f n = normalize(normal);
  if (u) return Frame::from_zx(n, normalize(*u));
  if (shape == LightShape::Rect) return Frame::from_zx(n, default_rect_u(n));
  return Frame::from_z(n);
}

bool light_frame_defined(Vec3f normal, Vec3f u) {
  return length_squared(cross(normalize(normal), normalize(u))) >= 1e-8f;
}

float read_fov_y(const JsonValue& v) {
  constexpr const char* kWhat = "an angle in degrees in (0, 180)";
  if (!v.raw().is_number()) v.fail_expected(kWhat);
  const float fov = v.number();
  if (!(fov > 0 && fov < 180)) v.fail_expected(kWhat);
  return fov;
}

Vec3f read_scale(const JsonValue& v) {
  constexpr const char* kWhat = "a non-zero number or three non-zero numbers";
  Vec3f s;
  if (v.raw().is_number()) {
    s = Vec3f(v.number());
  } else {
    if (!v.raw().is_array()) v.fail_expected(kWhat);
    s = v.vec3();
  }
  if (!scale_defined(s)) v.fail_expected(kWhat);
  return s;
}

bool scale_defined(Vec3f s) { return std::abs(s.x) >= 1e-12f && std::abs(s.y) >= 1e-12f && std::abs(s.z) >= 1e-12f; }

void Scene::orient_sphere_lights() { penumbra::orient_sphere_lights(lights, bounds()); }

void orient_sphere_lights(std::vector<AreaLight>& lights, const Bounds3f& b) {
  // A sphere light looks the same from everywhere; light-space methods need an axis, and
  // the one that sees the most of the scene is toward its centre.
  for (auto& l : lights) {
    if (l.shape != LightShape::Sphere) continue;
    Vec3f d = b.empty() ? Vec3f(0, -1, 0) : b.center() - l.center;
    if (!(length_squared(d) > 1e-12f)) d = Vec3f(0, -1, 0);
    l.frame = Frame::from_z(d);
  }
}

namespace {

// Parses one document; `file` starts every message, `folder` resolves relative paths.
class SceneParser {
 public:
  SceneParser(std::string file, fs::path folder) : file_(std::move(file)), folder_(std::move(folder)) {}

  Scene parse(const json& doc) {
    JsonValue root(doc, file_);
    if (!doc.is_object()) throw Error("{}: expected a JSON object at the top level, got {}", file_, abbreviate_json(doc));
    root.expect_object({"description", "camera", "lights", "objects", "methods", "animation"});
    Scene scene;
    if (root.has("description")) root["description"].string();
    scene.camera = read_camera(root["camera"]);
    scene.lights = read_lights(root["lights"]);
    JsonValue objects = root["objects"];
    if (objects.size() == 0) objects.fail("expected at least one object");
    // The animation's tracks are read before the objects (their errors come before a long
    // import), so the objects they move can keep their parts unplaced.
    std::optional<AnimationReader> animation;
    if (root.has("animation")) animation.emplace(root["animation"], scene.lights, light_u_);
    animation_ = animation ? &*animation : nullptr;
    for (size_t i = 0; i < objects.size(); ++i) read_object(objects.at(i), &scene.objects);
    animation_ = nullptr;
    mesh_files_.clear();
    unshare_single_placements(scene.objects);
    if (root.has("methods")) {
      JsonValue methods = root["methods"];
      methods.expect_object();
      // The methods validate their own tables later (ParamSet); here only the shape.
      for (const auto& [name, table] : methods.raw().items()) methods[name].expect_object();
      scene.method_params = methods.raw();
    }
    scene.finalize();
    if (animation) scene.animation = animation->finish(scene);
    return scene;
  }

  Camera read_camera(const JsonValue& v) {
    v.expect_object(camera_keys());
    Camera c;
    c.eye = v["eye"].vec3();
    c.target = v["target"].vec3();
    if (!(length_squared(c.target - c.eye) > 1e-12f)) v["target"].fail("must differ from camera.eye");
    if (v.has("up")) c.up = v["up"].direction();
    if (length_squared(cross(normalize(c.up), normalize(c.target - c.eye))) < 1e-10f) {
      if (v.has("up")) v["up"].fail("must not be parallel to the view direction (target - eye)");
      v.fail("the view direction is vertical: give an \"up\" that is not parallel to it");
    }
    if (v.has("fov_y")) c.fov_y = read_fov_y(v["fov_y"]);
    if (v.has("resolution")) {
      JsonValue r = v["resolution"];
      const char* what = "two integers in [1, 16384]";
      if (!r.raw().is_array() || r.raw().size() != 2) r.fail_expected(what);
      for (size_t i = 0; i < 2; ++i)
        if (!r.raw()[i].is_number()) r.fail_expected(what);
      c.width = r.at(0).integer(1, 16384);
      c.height = r.at(1).integer(1, 16384);
    }
    if (v.has("samples_per_pixel")) c.samples_per_pixel = v["samples_per_pixel"].integer(1, 65536);
    return c;
  }

  std::vector<AreaLight> read_lights(const JsonValue& lights) {
    if (lights.size() == 0) lights.fail("expected at least one light");
    std::vector<AreaLight> out;
    for (size_t i = 0; i < lights.size(); ++i) out.push_back(read_light(lights.at(i)));
    return out;
  }

 private:
  AreaLight read_light(const JsonValue& v) {
    v.expect_object();
    std::string type = v["type"].one_of({"rect", "disk", "sphere", "ellipsoid"});
    AreaLight l;
    if (type != "rect" && v.has("radiance_texture"))
      v["radiance_texture"].fail(fmt::format("only a rect light carries a texture, not a {}", type));
    l.shape = type == "rect" ? LightShape::Rect : type == "disk" ? LightShape::Disk
              : type == "ellipsoid" ? LightShape::Ellipsoid : LightShape::Sphere;
    v.expect_object(light_keys(l.shape));
    if (type == "rect") {
      l.size = v["size"].positive_vec2();
      // Issue 20 part 3: an emission image over the rect (linear RGB: PNG and JPEG sRGB-decoded).
      if (v.has("radiance_texture")) {
        std::shared_ptr<const Texture> image = read_texture(v["radiance_texture"], Texture::Encoding::Srgb);
        try {
          l.texture = std::make_shared<const LightTexture>(std::move(image));
        } catch (const Error& e) {
          v["radiance_texture"].fail(e.what());
        }
      }
    } else if (type == "ellipsoid") {
      // Semi-axes along u, normal x u and normal; light-space methods look along normal.
      l.radii = v["radii"].positive_vec3();
    } else {  // disk, sphere
      l.radius = v["radius"].positive();
    }
    l.center = v["center"].vec3();
    if (v.has("radiance")) l.radiance = v["radiance"].color();  // default: AreaLight's (1,1,1)
    std::optional<Vec3f> u;
    if (type != "sphere") {
      Vec3f n = v["normal"].direction();
      if (v.has("u")) {
        u = v["u"].direction();
        if (!light_frame_defined(n, *u)) v["u"].fail("must not be parallel to normal");
      }
      l.frame = light_frame(l.shape, n, u);
    }
    light_u_.push_back(u);
    return l;
  }

  // Object transform: scale, then rotate about x, y, z (degrees), then translate.
  ObjectTransform read_transform(const JsonValue& v) {
    ObjectTransform t;
    if (v.has("scale")) t.scale = read_scale(v["scale"]);
    if (v.has("rotate")) t.rotate = v["rotate"].vec3();
    if (v.has("translate")) t.translate = v["translate"].vec3();
    return t;
  }

  // The fields given in "material": they override the defaults (generators set their own
  // colours per part, and only the given fields replace them).
  struct MaterialOverride {
    std::optional<Vec3f> albedo;
    std::optional<float> opacity;
    std::optional<bool> two_sided;
    std::shared_ptr<const Texture> albedo_texture, alpha_texture;
    std::optional<AlphaMode> alpha_mode;
    std::optional<float> alpha_cutoff;
    void apply(Material* m) const {
      if (albedo_texture) {
        m->albedo_texture = albedo_texture;
        if (!albedo) m->albedo = Vec3f(1.0f);  // the texture as it is, unless tinted
      }
      if (albedo) m->albedo = *albedo;
      if (opacity) m->opacity = *opacity;
      if (two_sided) m->two_sided = *two_sided;
      if (alpha_texture) m->alpha.texture = alpha_texture;
      if (alpha_mode) m->alpha.mode = *alpha_mode;
      if (alpha_cutoff) m->alpha.cutoff = *alpha_cutoff;
      // glTF's convention: without an alpha texture of its own, the alpha of the base colour.
      if (m->alpha.mode != AlphaMode::Opaque && !m->alpha.texture && m->albedo_texture && m->albedo_texture->has_alpha())
        m->alpha.texture = m->albedo_texture;
    }
  };
  std::shared_ptr<const Texture> read_texture(const JsonValue& v, Texture::Encoding encoding) {
    std::string rel = v.string();
    if (rel.empty()) v.fail("expected an image file name, got an empty string");
    fs::path p = fs::path(rel).is_absolute() ? fs::path(rel) : (folder_ / rel).lexically_normal();
    try {
      return Texture::load(p, encoding);
    } catch (const Interrupted&) {
      throw;
    } catch (const Error& e) {
      v.fail(e.what());
    }
  }
  MaterialOverride read_material(const JsonValue& v) {
    v.expect_object({"albedo", "opacity", "two_sided", "albedo_texture", "alpha_texture", "alpha_mode", "alpha_cutoff"});
    MaterialOverride m;
    if (v.has("albedo")) {
      JsonValue a = v["albedo"];
      m.albedo = a.color();
      if (max_component(*m.albedo) > 1) a.fail_expected("three numbers in [0, 1]");
    }
    if (v.has("opacity")) m.opacity = v["opacity"].in_range(0, 1);
    if (v.has("two_sided")) m.two_sided = v["two_sided"].boolean();
    if (v.has("alpha_mode")) {
      const std::string mode = v["alpha_mode"].one_of({"opaque", "mask", "blend"});
      m.alpha_mode = mode == "mask" ? AlphaMode::Mask : mode == "blend" ? AlphaMode::Blend : AlphaMode::Opaque;
    }
    if (v.has("alpha_cutoff")) m.alpha_cutoff = v["alpha_cutoff"].in_range(0, 1);
    if (v.has("albedo_texture")) m.albedo_texture = read_texture(v["albedo_texture"], Texture::Encoding::Srgb);
    if (v.has("alpha_texture")) {
      m.alpha_texture = read_texture(v["alpha_texture"], Texture::Encoding::Linear);
      if (!m.alpha_mode) m.alpha_mode = AlphaMode::Mask;  // an alpha texture alone: a cut-out
    }
    return m;
  }

  void read_object(const JsonValue& v, std::vector<SceneObject>* out) {
    v.expect_object();
    int kinds = int(v.has("mesh")) + int(v.has("shape")) + int(v.has("generator"));
    if (kinds != 1) v.fail("expected exactly one of \"mesh\", \"shape\" or \"generator\"");
    std::vector<std::string_view> allowed = {"name", "translate", "rotate", "scale", "material"};
    // The cheap keys first, so their errors come before a long import or generation.
    std::string name = v.has("name") ? v["name"].string() : "";
    ObjectTransform t = read_transform(v);
    MaterialOverride material = v.has("material") ? read_material(v["material"]) : MaterialOverride{};
    std::vector<SceneObject> parts;
    std::string base_name;
    fs::path mesh_file;  // for a mesh object

    if (v.has("mesh")) {
      allowed.push_back("mesh");
      v.expect_object(allowed);
      JsonValue mv = v["mesh"];
      std::string rel = mv.string();
      if (rel.empty()) mv.fail("expected a file name, got an empty string");
      fs::path p = fs::path(rel).is_absolute() ? fs::path(rel) : (folder_ / rel).lexically_normal();
      mesh_file = p;
      parts = mesh_file_parts(p, mv);
      base_name = fs::path(rel).stem().string();
    } else if (v.has("shape")) {
      JsonValue sv = v["shape"];
      std::string shape = sv.one_of({"plane", "box", "sphere"});
      SceneObject o;
      if (shape == "plane") {
        allowed.insert(allowed.end(), {"shape", "size"});
        v.expect_object(allowed);
        o.mesh = make_plane(v["size"].positive_vec2());
      } else if (shape == "box") {
        allowed.insert(allowed.end(), {"shape", "size"});
        v.expect_object(allowed);
        JsonValue size = v["size"];
        Vec3f s = size.vec3();
        if (!(min_component(s) > 0)) size.fail_expected("three positive numbers");
        o.mesh = make_box(s);
      } else {
        allowed.insert(allowed.end(), {"shape", "radius", "segments"});
        v.expect_object(allowed);
        float radius = v["radius"].positive();
        int segments = v.has("segments") ? v["segments"].integer(3, 4096) : 32;
        o.mesh = make_uv_sphere(radius, segments);
        o.sphere = SphereShape{Vec3f(0), radius};
      }
      base_name = shape;
      parts.push_back(std::move(o));
    } else {
      allowed.insert(allowed.end(), {"generator", "params"});
      v.expect_object(allowed);
      JsonValue gv = v["generator"];
      const GeneratorInfo* g = nullptr;
      try {
        g = &find_generator(gv.string());
      } catch (const Interrupted&) {
        throw;  // Ctrl-C ends the run, whatever this step would do with an error
      } catch (const Error& e) {
        gv.fail(e.what());
      }
      static const json kEmpty = json::object();
      JsonValue pv = v.has("params") ? v["params"] : JsonValue(kEmpty, file_, v.path() + ".params");
      json params = resolve_generator_params(*g, pv);
      try {
        parts = g->generate(params);
      } catch (const Interrupted&) {
        throw;  // Ctrl-C ends the run, whatever this step would do with an error
      } catch (const Error& e) {
        pv.fail(e.what());
      }
      base_name = g->name;
    }

    if (name.empty()) name = base_name;
    for (auto& o : parts) {
      if (o.mesh.triangle_count() == 0) continue;  // e.g. a plant with leaves = 0
      o.name = parts.size() > 1 && !o.name.empty() ? name + "." + o.name : name;
      material.apply(&o.material);
      // An alpha mode needs an alpha: the object's own (a mesh file's material) or the scene's.
      if (o.material.alpha.mode != AlphaMode::Opaque && !o.material.alpha.texture)
        v["material"]["alpha_mode"].fail(
            fmt::format("\"{}\" needs an \"alpha_texture\" or an \"albedo_texture\" with an alpha channel{}",
                        to_string(o.material.alpha.mode), parts.size() > 1 ? fmt::format(" (part {})", o.name) : ""));
      // A texture is looked up at the surface's texture coordinates: the mesh must have them.
      if ((o.material.albedo_texture || o.material.alpha_textured()) && o.mesh.uvs.size() != o.mesh.positions.size()) {
        const char* texture = o.material.albedo_texture ? "albedo_texture" : "alpha_texture";
        if (!mesh_file.empty())
          v["mesh"].fail(fmt::format("{}: has no texture coordinates{}, which the material's {} needs (an OBJ gives "
                                     "them with vt lines, a PLY with s,t or u,v, a glTF with TEXCOORD_0; OFF and "
                                     "STL files have none)",
                                     mesh_file.string(), parts.size() > 1 ? fmt::format(" in part {}", o.name) : "",
                                     texture));
        v.fail(fmt::format("{} has a texture in its material but no texture coordinates{}", o.name,
                           v.has("shape") ? " (planes and boxes have them; spheres do not)" : ""));
      }
      // An animated object keeps its parts as built, in its own space: each frame places
      // them anew from the keyed transform (animation.h).
      if (animation_ && animation_->animates(name)) animation_->add_part(name, v, t, out->size(), o);
      place_object(o, t);
      for (Vec3f p : o.mesh.positions)
        if (!is_finite(p)) v.fail("vertex positions are not finite after the transform");
      out->push_back(std::move(o));
    }
  }

  // A mesh file's parts, read once per scene load whatever the number of objects placing it:
  // each part's mesh in the file's own space as a shared mesh (SceneObject::shared_mesh), the
  // part itself without a mesh of its own. Keyed by the file's canonical path (import takes
  // no options: the path alone decides what is read).
  std::vector<SceneObject> mesh_file_parts(const fs::path& path, const JsonValue& where) {
    std::error_code ec;
    fs::path key = fs::weakly_canonical(path, ec);
    if (ec) key = path;
    auto it = mesh_files_.find(key);
    if (it == mesh_files_.end()) {
      std::vector<SceneObject> parts;
      try {
        MeshImportReport report;
        parts = import_mesh_parts(path, &report);
        if (report.degenerate_triangles > 0)
          std::fprintf(stderr, "penumbra: warning: %s: %zu triangle(s) of zero area dropped\n", path.string().c_str(),
                       report.degenerate_triangles);
      } catch (const Interrupted&) {
        throw;  // Ctrl-C ends the run, whatever this step would do with an error
      } catch (const Error& e) {
        where.fail(e.what());
      }
      for (SceneObject& part : parts) part.shared_mesh = std::make_shared<const TriangleMesh>(std::move(part.mesh));
      it = mesh_files_.emplace(key, std::move(parts)).first;
    }
    // Each object gets the parts with a mesh to place (place_object transforms a copy of the
    // shared one); objects placing a file once are unshared at the end of the load.
    std::vector<SceneObject> parts = it->second;
    for (SceneObject& part : parts) part.mesh = *part.shared_mesh;
    return parts;
  }

  std::string file_;
  fs::path folder_;
  std::map<fs::path, std::vector<SceneObject>> mesh_files_;  // mesh_file_parts' cache, during parse()
  std::vector<std::optional<Vec3f>> light_u_;  // each light's "u", where given (animated normals need it)
  AnimationReader* animation_ = nullptr;       // while the objects of an animated scene are read
};

}  // namespace

Scene parse_scene(const json& doc, const fs::path& origin) {
  SceneParser parser(origin.string(), origin.parent_path());
  Scene scene = parser.parse(doc);
  scene.source = origin;
  return scene;
}

Scene load_scene(const fs::path& path) { return parse_scene(read_json_file(path), path); }

Camera parse_camera(const json& camera, const std::string& context) {
  SceneParser parser(context, fs::path());
  return parser.read_camera(JsonValue(camera, context, "camera"));
}

std::vector<AreaLight> parse_lights(const json& lights, const std::string& context, const fs::path& folder) {
  SceneParser parser(context, folder);
  return parser.read_lights(JsonValue(lights, context, "lights"));
}

const std::vector<std::string_view>& camera_keys() {
  static const std::vector<std::string_view> keys = {"eye", "target", "up", "fov_y", "resolution", "samples_per_pixel"};
  return keys;
}

const std::vector<std::string_view>& light_keys(LightShape shape) {
  static const std::vector<std::string_view> rect = {"type", "center", "normal", "u", "size", "radiance",
                                                     "radiance_texture"};
  static const std::vector<std::string_view> disk = {"type", "center", "normal", "u", "radius", "radiance"};
  static const std::vector<std::string_view> ellipsoid = {"type", "center", "radii", "u", "normal", "radiance"};
  static const std::vector<std::string_view> sphere = {"type", "center", "radius", "radiance"};
  switch (shape) {
    case LightShape::Rect: return rect;
    case LightShape::Disk: return disk;
    case LightShape::Ellipsoid: return ellipsoid;
    case LightShape::Sphere: break;
  }
  return sphere;
}

namespace {
json vec_json(Vec3f v) { return json::array({v.x, v.y, v.z}); }
// Adds `key` = `value` unless the document has the key.
void default_key(json& doc, const char* key, json value) {
  if (!doc.contains(key)) doc[key] = std::move(value);
}
}  // namespace

json resolved_camera_json(const json& camera, const Camera& c) {
  json out = camera;
  default_key(out, "up", vec_json(c.up));
  default_key(out, "fov_y", c.fov_y);
  default_key(out, "resolution", json::array({c.width, c.height}));
  default_key(out, "samples_per_pixel", c.samples_per_pixel);
  return out;
}

json resolved_lights_json(const json& lights, const std::vector<AreaLight>& parsed) {
  json out = lights;
  for (size_t i = 0; i < out.size() && i < parsed.size(); ++i) {
    json& l = out[i];
    const AreaLight& a = parsed[i];
    default_key(l, "radiance", vec_json(a.radiance));
    // The u that gives the light's frame: the default rule's vector itself for a rect (so the
    // frame is the same bit for bit), the frame's first axis for a disk or an ellipsoid.
    if (a.shape == LightShape::Rect) default_key(l, "u", vec_json(default_rect_u(a.frame.n)));
    else if (a.shape != LightShape::Sphere) default_key(l, "u", vec_json(a.frame.s));
  }
  return out;
}

}  // namespace penumbra
