// Animated scenes: a scene file's optional "animation" block (docs/scene-format.md,
// "Animation"): a frame count and rate, and keyframed tracks for the camera, the lights (by
// index) and the objects' transforms (by name). The scene as loaded is the scene as written;
// scene_at_frame() gives it at a frame.
#pragma once

#include <array>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "penumbra/scene/json_reader.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

enum class Interpolation { Linear, CatmullRom };

// One keyed quantity of one to three components, evaluated at any frame:
// - linear: straight lines between keys;
// - Catmull-Rom: the cubic Hermite curve through the keys whose tangent at a key is the slope
//   between its two neighbours, (p[i+1] - p[i-1]) / (f[i+1] - f[i-1]) (keys may be unevenly
//   spaced); at the first and last key, the slope to its one neighbour (clamped end tangents:
//   what a phantom key mirrored beyond the end would give). With two keys it is the line.
// Before the first key and after the last, the value is held (clamped); one key is constant.
// Values are interpolated in double and give the key's value exactly at a key's frame.
class Track {
 public:
  using Value = std::array<double, 3>;  // unused components stay 0
  struct Key {
    double frame;
    Value value;
  };

  Track() = default;  // empty: the quantity is not animated
  // `keys`: at least one, in strictly increasing frame order.
  Track(Interpolation interpolation, std::vector<Key> keys);
  bool empty() const { return keys_.empty(); }
  Interpolation interpolation() const { return interpolation_; }
  const std::vector<Key>& keys() const { return keys_; }

  Value at(double frame) const;
  float scalar_at(double frame) const;
  Vec2f vec2_at(double frame) const;
  Vec3f vec3_at(double frame) const;

 private:
  Interpolation interpolation_ = Interpolation::Linear;
  std::vector<Key> keys_;
};

// The tracks of one scene. Each animated quantity replaces the scene's own value at every
// frame; what has no track keeps the value the scene file gives.
class Animation {
 public:
  struct CameraTracks {
    Track eye, target, up, fov_y;
    bool empty() const { return eye.empty() && target.empty() && up.empty() && fov_y.empty(); }
  };
  struct LightTracks {
    size_t light = 0;  // index into Scene::lights
    Track center, normal, size, radius, radii, radiance;
    // The light's own "u", where the file gives one: an animated normal keeps it, as the
    // loader would (light_frame in scene_values.h).
    std::optional<Vec3f> u;
  };
  struct ObjectTracks {
    std::string name;  // the object's name in the scene file
    Track translate, rotate, scale;
    // The object's own transform keys: the parts of the transform that have no track.
    ObjectTransform base;
    // The object's parts (one, or a generator's several) as built, before any transform:
    // each frame places them anew (place_object), so the animated transform applies to the
    // object exactly as a static one would. A part of a shared mesh (SceneObject::shared_mesh)
    // keeps the sharing and its placement in the generator's space, not a mesh of its own.
    struct Part {
      size_t index;  // into Scene::objects
      SceneObject unplaced;
    };
    std::vector<Part> parts;
  };

  int frames = 1;
  float fps = 24;
  CameraTracks camera;
  std::vector<LightTracks> lights;
  std::vector<ObjectTracks> objects;

  ObjectTransform transform_at(const ObjectTracks& object, int frame) const;
  // Whether some object is placed differently at frame `a` than at frame `b` (the geometry
  // changed: an Embree scene built for one does not hold the other).
  bool objects_differ(int a, int b) const;
  // The objects (indices into Scene::objects: every part of each object whose transform
  // differs) placed differently at frame `a` than at frame `b`, ascending.
  std::vector<uint32_t> moved_objects(int a, int b) const;
  // Every object some track moves (the parts of every animated object), ascending.
  std::vector<uint32_t> movable_objects() const;
  // Places the animated objects of `scene` as they are at `frame` (the other objects stay).
  void place_objects(int frame, Scene& scene) const;
  // Sets the animated values of `camera` (eye, target, up, fov_y) to those of `frame`.
  void set_camera(int frame, Camera& camera) const;
  // Sets the animated camera and light values of `scene` to those of `frame`, and orients
  // sphere lights toward the objects as they are now (Scene::orient_sphere_lights).
  void set_camera_and_lights(int frame, Scene& scene) const;
};

// `base` (a scene loaded with an "animation" block) at `frame`, in [0, animation.frames):
// its animated objects placed, its camera and lights set. The result keeps the animation, so
// it may be the base of another call (every frame is computed from the scene as written).
// Throws an Error naming the scene when it has no animation or the frame is outside it.
Scene scene_at_frame(const Scene& base, int frame);

// Reads the "animation" block of a scene file for the loader (scene.cpp), in two steps around
// the objects: the constructor reads and checks the tracks (before any long mesh import),
// the loader hands over the parts of each object that animates() names as it builds them,
// and finish() checks the names and every frame's values and gives the Animation.
class AnimationReader {
 public:
  AnimationReader(const JsonValue& block, const std::vector<AreaLight>& lights,
                  const std::vector<std::optional<Vec3f>>& light_u);
  bool animates(const std::string& object_name) const;
  // One part of the object `object` (the scene file's objects[i]) named `name`, before `base`
  // placed it, which will be `index` in Scene::objects.
  void add_part(const std::string& name, const JsonValue& object, const ObjectTransform& base, size_t index,
                const SceneObject& unplaced);
  // Throws naming the key path where an animated object has no object of its name, or some
  // frame's value is out of range (a Catmull-Rom overshoot, a normal through zero).
  std::shared_ptr<const Animation> finish(const Scene& scene);

 private:
  void check_frames(const Scene& scene) const;

  JsonValue block_;
  Animation animation_;
  // Where each track was read, for messages about its values between keys.
  std::map<const Track*, JsonValue> track_json_;
  std::map<std::string, JsonValue> object_json_;    // animation.objects.NAME
  std::map<std::string, std::string> object_entry_;  // the objects[i] path that has the name
};

}  // namespace penumbra
