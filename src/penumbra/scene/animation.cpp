#include "penumbra/scene/animation.h"

#include <algorithm>
#include <cmath>
#include <string_view>

#include "penumbra/core/error.h"
#include "penumbra/scene/scene_values.h"

namespace penumbra {

using nlohmann::json;

// ---------------------------------------------------------------------------------------------
// Tracks

Track::Track(Interpolation interpolation, std::vector<Key> keys)
    : interpolation_(interpolation), keys_(std::move(keys)) {}

Track::Value Track::at(double frame) const {
  const size_t n = keys_.size();
  if (n == 0) return {};
  if (frame <= keys_.front().frame) return keys_.front().value;
  if (frame >= keys_.back().frame) return keys_.back().value;
  // The segment [keys_[i], keys_[i + 1]] holding the frame.
  const size_t i = std::upper_bound(keys_.begin(), keys_.end(), frame,
                                    [](double f, const Key& k) { return f < k.frame; }) -
                   keys_.begin() - 1;
  const Key &a = keys_[i], &b = keys_[i + 1];
  const double h = b.frame - a.frame, s = (frame - a.frame) / h;
  Value out{};
  if (interpolation_ == Interpolation::Linear) {
    for (int c = 0; c < 3; ++c) out[c] = a.value[c] + (b.value[c] - a.value[c]) * s;
    return out;
  }
  // The slope at key k: between its neighbours, or to its one neighbour at the ends.
  auto slope = [&](size_t k, int c) {
    const Key& lo = keys_[k == 0 ? 0 : k - 1];
    const Key& hi = keys_[k + 1 == n ? k : k + 1];
    return (hi.value[c] - lo.value[c]) / (hi.frame - lo.frame);
  };
  // Cubic Hermite basis on the segment.
  const double s2 = s * s, s3 = s2 * s;
  const double h00 = 2 * s3 - 3 * s2 + 1, h10 = s3 - 2 * s2 + s, h01 = -2 * s3 + 3 * s2, h11 = s3 - s2;
  for (int c = 0; c < 3; ++c)
    out[c] = h00 * a.value[c] + h10 * h * slope(i, c) + h01 * b.value[c] + h11 * h * slope(i + 1, c);
  return out;
}

float Track::scalar_at(double frame) const { return static_cast<float>(at(frame)[0]); }

Vec2f Track::vec2_at(double frame) const {
  const Value v = at(frame);
  return {static_cast<float>(v[0]), static_cast<float>(v[1])};
}

Vec3f Track::vec3_at(double frame) const {
  const Value v = at(frame);
  return {static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2])};
}

// ---------------------------------------------------------------------------------------------
// Evaluation

ObjectTransform Animation::transform_at(const ObjectTracks& object, int frame) const {
  ObjectTransform t = object.base;
  if (!object.translate.empty()) t.translate = object.translate.vec3_at(frame);
  if (!object.rotate.empty()) t.rotate = object.rotate.vec3_at(frame);
  if (!object.scale.empty()) t.scale = object.scale.vec3_at(frame);
  return t;
}

bool Animation::objects_differ(int a, int b) const {
  for (const ObjectTracks& o : objects)
    if (!(transform_at(o, a) == transform_at(o, b))) return true;
  return false;
}

std::vector<uint32_t> Animation::moved_objects(int a, int b) const {
  std::vector<uint32_t> moved;
  for (const ObjectTracks& o : objects)
    if (!(transform_at(o, a) == transform_at(o, b)))
      for (const ObjectTracks::Part& part : o.parts) moved.push_back(static_cast<uint32_t>(part.index));
  std::sort(moved.begin(), moved.end());
  return moved;
}

std::vector<uint32_t> Animation::movable_objects() const {
  std::vector<uint32_t> movable;
  for (const ObjectTracks& o : objects)
    for (const ObjectTracks::Part& part : o.parts) movable.push_back(static_cast<uint32_t>(part.index));
  std::sort(movable.begin(), movable.end());
  return movable;
}

void Animation::place_objects(int frame, Scene& scene) const {
  for (const ObjectTracks& o : objects) {
    const ObjectTransform t = transform_at(o, frame);
    for (const ObjectTracks::Part& part : o.parts) place_object(scene.objects[part.index], part.unplaced, t);
  }
}

void Animation::set_camera(int frame, Camera& c) const {
  if (!camera.eye.empty()) c.eye = camera.eye.vec3_at(frame);
  if (!camera.target.empty()) c.target = camera.target.vec3_at(frame);
  if (!camera.up.empty()) c.up = camera.up.vec3_at(frame);
  if (!camera.fov_y.empty()) c.fov_y = camera.fov_y.scalar_at(frame);
}

void Animation::set_camera_and_lights(int frame, Scene& scene) const {
  set_camera(frame, scene.camera);
  for (const LightTracks& lt : lights) {
    AreaLight& l = scene.lights[lt.light];
    if (!lt.center.empty()) l.center = lt.center.vec3_at(frame);
    if (!lt.normal.empty()) l.frame = light_frame(l.shape, lt.normal.vec3_at(frame), lt.u);
    if (!lt.size.empty()) l.size = lt.size.vec2_at(frame);
    if (!lt.radius.empty()) l.radius = lt.radius.scalar_at(frame);
    if (!lt.radii.empty()) l.radii = lt.radii.vec3_at(frame);
    if (!lt.radiance.empty()) l.radiance = lt.radiance.vec3_at(frame);
  }
  scene.orient_sphere_lights();
}

Scene scene_at_frame(const Scene& base, int frame) {
  if (!base.animation) throw Error("{}: the scene has no \"animation\" block", base.source.string());
  const Animation& a = *base.animation;
  if (frame < 0 || frame >= a.frames)
    throw Error("{}: frame {} is outside the animation's frames [0, {})", base.source.string(), frame, a.frames);
  Scene s = base;
  a.place_objects(frame, s);
  a.set_camera_and_lights(frame, s);
  return s;
}

// ---------------------------------------------------------------------------------------------
// Reading the block

namespace {

constexpr int kMaxFrames = 100000;

// How the keys of one animated key are read: the same reader, with the same messages, as the
// key itself in the camera, a light or an object (scene_values.h).
using ReadValue = Track::Value (*)(const JsonValue& v);

Track::Value value_of(Vec3f v) { return {v.x, v.y, v.z}; }
Track::Value value_of(Vec2f v) { return {v.x, v.y, 0}; }
Track::Value value_of(float v) { return {v, 0, 0}; }

const ReadValue kPoint = [](const JsonValue& v) { return value_of(v.vec3()); };
const ReadValue kDirection = [](const JsonValue& v) { return value_of(v.direction()); };
const ReadValue kFov = [](const JsonValue& v) { return value_of(read_fov_y(v)); };
const ReadValue kSize = [](const JsonValue& v) { return value_of(v.positive_vec2()); };
const ReadValue kPositive = [](const JsonValue& v) { return value_of(v.positive()); };
const ReadValue kRadii = [](const JsonValue& v) { return value_of(v.positive_vec3()); };
const ReadValue kColor = [](const JsonValue& v) { return value_of(v.color()); };
const ReadValue kScale = [](const JsonValue& v) { return value_of(read_scale(v)); };

// A track: a list of keys {"frame": f, "value": v} (linear), or
// {"interpolation": "linear" | "catmull-rom", "keys": [...]}.
Track read_track(const JsonValue& v, ReadValue read_value, int frames) {
  Interpolation interpolation = Interpolation::Linear;
  JsonValue keys = v;
  if (v.raw().is_object()) {
    v.expect_object({"interpolation", "keys"});
    if (v.has("interpolation"))
      interpolation = v["interpolation"].one_of({"linear", "catmull-rom"}) == "linear" ? Interpolation::Linear
                                                                                        : Interpolation::CatmullRom;
    keys = v["keys"];
  } else if (!v.raw().is_array()) {
    v.fail_expected("a list of keys {\"frame\": f, \"value\": ...} or {\"interpolation\": ..., \"keys\": [...]}");
  }
  if (keys.size() == 0) keys.fail("expected at least one key");
  std::vector<Track::Key> out;
  for (size_t i = 0; i < keys.size(); ++i) {
    JsonValue k = keys.at(i);
    k.expect_object({"frame", "value"});
    JsonValue f = k["frame"];
    const int frame = f.integer(0, frames - 1);
    if (!out.empty() && frame <= out.back().frame)
      f.fail(fmt::format("keys must be in increasing frame order (frame {} after frame {})", frame,
                         static_cast<int>(out.back().frame)));
    out.push_back({static_cast<double>(frame), read_value(k["value"])});
  }
  return Track(interpolation, std::move(out));
}

std::string format_value(const Track::Value& v, int components) {
  std::string s;
  for (int c = 0; c < components; ++c) s += fmt::format("{}{:g}", c ? "," : "", v[c]);
  return components == 1 ? s : "[" + s + "]";
}

}  // namespace

AnimationReader::AnimationReader(const JsonValue& block, const std::vector<AreaLight>& lights,
                                 const std::vector<std::optional<Vec3f>>& light_u)
    : block_(block) {
  block.expect_object({"frames", "fps", "camera", "lights", "objects"});
  Animation& a = animation_;
  a.frames = block["frames"].integer(1, kMaxFrames);
  if (block.has("fps")) a.fps = block["fps"].positive();
  // Each track with the JsonValue it came from (pointers into `a`: registered once the
  // vectors holding them are complete).
  std::vector<std::pair<Track*, JsonValue>> read;
  auto track = [&](const JsonValue& parent, std::string_view key, ReadValue read_value, Track* out) {
    if (!parent.has(key)) return;
    JsonValue v = parent[key];
    *out = read_track(v, read_value, a.frames);
    read.emplace_back(out, v);
  };

  if (block.has("camera")) {
    JsonValue c = block["camera"];
    c.expect_object({"eye", "target", "up", "fov_y"});
    track(c, "eye", kPoint, &a.camera.eye);
    track(c, "target", kPoint, &a.camera.target);
    track(c, "up", kDirection, &a.camera.up);
    track(c, "fov_y", kFov, &a.camera.fov_y);
  }

  if (block.has("lights")) {
    JsonValue ls = block["lights"];
    ls.expect_object();
    a.lights.reserve(ls.raw().size());
    for (const auto& [key, value] : ls.raw().items()) {
      // The light's index, in decimal without leading zeros, so no two keys name one light.
      const bool digits = !key.empty() && key.size() <= 9 && std::all_of(key.begin(), key.end(), ::isdigit) &&
                          (key == "0" || key[0] != '0');
      if (!digits) ls[key].fail(fmt::format("expected a light index in [0, {}] as the key", lights.size() - 1));
      const size_t index = std::stoul(key);
      JsonValue l(value, block.context(), fmt::format("{}[{}]", ls.path(), index));
      if (index >= lights.size())
        l.fail(fmt::format("no such light (the scene has {} light{})", lights.size(), lights.size() == 1 ? "" : "s"));
      const LightShape shape = lights[index].shape;
      std::vector<std::string_view> allowed = {"center", "radiance"};
      if (shape != LightShape::Sphere) allowed.push_back("normal");
      if (shape == LightShape::Rect) allowed.push_back("size");
      if (shape == LightShape::Disk || shape == LightShape::Sphere) allowed.push_back("radius");
      if (shape == LightShape::Ellipsoid) allowed.push_back("radii");
      l.expect_object(allowed);
      Animation::LightTracks& lt = a.lights.emplace_back();
      lt.light = index;
      lt.u = light_u[index];
      track(l, "center", kPoint, &lt.center);
      track(l, "normal", kDirection, &lt.normal);
      track(l, "size", kSize, &lt.size);
      track(l, "radius", kPositive, &lt.radius);
      track(l, "radii", kRadii, &lt.radii);
      track(l, "radiance", kColor, &lt.radiance);
    }
  }

  if (block.has("objects")) {
    JsonValue os = block["objects"];
    os.expect_object();
    a.objects.reserve(os.raw().size());
    for (const auto& [name, value] : os.raw().items()) {
      JsonValue o = os[name];
      o.expect_object({"translate", "rotate", "scale"});
      Animation::ObjectTracks& ot = a.objects.emplace_back();
      ot.name = name;
      track(o, "translate", kPoint, &ot.translate);
      track(o, "rotate", kPoint, &ot.rotate);
      track(o, "scale", kScale, &ot.scale);
      object_json_.emplace(name, o);
    }
  }
  for (auto& [t, v] : read) track_json_.emplace(t, v);
}

bool AnimationReader::animates(const std::string& object_name) const { return object_json_.count(object_name) > 0; }

void AnimationReader::add_part(const std::string& name, const JsonValue& object, const ObjectTransform& base,
                               size_t index, const SceneObject& unplaced) {
  auto it = std::find_if(animation_.objects.begin(), animation_.objects.end(),
                         [&](const Animation::ObjectTracks& o) { return o.name == name; });
  auto [entry, first] = object_entry_.emplace(name, object.path());
  if (!first && entry->second != object.path())
    object_json_.at(name).fail(fmt::format("two objects are named \"{}\" ({} and {}): give the animated one a name "
                                           "of its own",
                                           name, entry->second, object.path()));
  it->base = base;
  it->parts.push_back({index, unplaced});
}

std::shared_ptr<const Animation> AnimationReader::finish(const Scene& scene) {
  for (const Animation::ObjectTracks& o : animation_.objects) {
    if (!o.parts.empty()) continue;
    std::string names;
    for (const SceneObject& so : scene.objects) names += (names.empty() ? "" : ", ") + so.name;
    object_json_.at(o.name).fail(fmt::format("no object of that name (the objects: {})", names));
  }
  check_frames(scene);
  // The parts keep the scene's mesh sharing (the loader unshares a mesh placed once); a part
  // still shared is placed from its shared mesh, so it need not keep a copy of its own.
  for (Animation::ObjectTracks& o : animation_.objects)
    for (Animation::ObjectTracks::Part& part : o.parts) {
      if (!scene.objects[part.index].shared_mesh)
        part.unplaced.unshare();
      else
        part.unplaced.mesh = TriangleMesh{};
    }
  return std::make_shared<const Animation>(std::move(animation_));
}

// Keys are checked as the keys they animate are; between keys a value can still leave the
// range (a Catmull-Rom curve overshoots, a normal passes through zero), so every frame is.
void AnimationReader::check_frames(const Scene& scene) const {
  const Animation& a = animation_;
  auto fail = [&](const Track& t, int frame, int components, std::string_view what) {
    const std::string hint = t.interpolation() == Interpolation::CatmullRom && t.keys().size() > 2
                                 ? " (Catmull-Rom overshoots between keys; linear does not)"
                                 : "";
    track_json_.at(&t).fail(fmt::format("at frame {}: expected {}, got {}{}", frame, what,
                                        format_value(t.at(frame), components), hint));
  };
  const bool camera_moves = !a.camera.empty();
  for (int f = 0; f < a.frames; ++f) {
    if (camera_moves) {
      Camera c = scene.camera;
      a.set_camera(f, c);
      if (!(c.fov_y > 0 && c.fov_y < 180)) fail(a.camera.fov_y, f, 1, "an angle in degrees in (0, 180)");
      if (!(length_squared(c.target - c.eye) > 1e-12f))
        block_["camera"].fail(fmt::format("at frame {}: eye and target coincide", f));
      if (!(length_squared(c.up) > 1e-20f) ||
          length_squared(cross(normalize(c.up), normalize(c.target - c.eye))) < 1e-10f)
        block_["camera"].fail(fmt::format("at frame {}: up is zero or parallel to the view direction", f));
    }
    for (const Animation::LightTracks& lt : a.lights) {
      if (!lt.normal.empty()) {
        const Vec3f n = lt.normal.vec3_at(f);
        if (!(length_squared(n) > 1e-20f)) fail(lt.normal, f, 3, "three numbers, not all zero");
        if (lt.u && !light_frame_defined(n, *lt.u))
          fail(lt.normal, f, 3, "a normal not parallel to the light's u");
      }
      if (!lt.size.empty() && !(std::min(lt.size.vec2_at(f).x, lt.size.vec2_at(f).y) > 0))
        fail(lt.size, f, 2, "two positive numbers");
      if (!lt.radius.empty() && !(lt.radius.scalar_at(f) > 0)) fail(lt.radius, f, 1, "a positive number");
      if (!lt.radii.empty() && !(min_component(lt.radii.vec3_at(f)) > 0))
        fail(lt.radii, f, 3, "three positive numbers");
      if (!lt.radiance.empty() && !(min_component(lt.radiance.vec3_at(f)) >= 0))
        fail(lt.radiance, f, 3, "three non-negative numbers");
    }
    for (const Animation::ObjectTracks& o : a.objects) {
      const ObjectTransform t = a.transform_at(o, f);
      if (!o.scale.empty() && !scale_defined(t.scale)) fail(o.scale, f, 3, "a non-zero scale");
      // The corners of the unplaced parts' box bound the placed vertices.
      const Mat4 m = t.matrix();
      for (const Animation::ObjectTracks::Part& part : o.parts) {
        const Bounds3f b = part.unplaced.mesh.bounds();
        for (int corner = 0; corner < 8; ++corner) {
          const Vec3f p((corner & 1) ? b.hi.x : b.lo.x, (corner & 2) ? b.hi.y : b.lo.y, (corner & 4) ? b.hi.z : b.lo.z);
          if (!is_finite(m.transform_point(p)))
            object_json_.at(o.name).fail(fmt::format("at frame {}: vertex positions are not finite after the transform", f));
        }
      }
    }
  }
}

}  // namespace penumbra
