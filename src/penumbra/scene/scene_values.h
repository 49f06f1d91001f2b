// Single values of a scene file, read and checked the same way wherever they appear: as a
// key of the camera, a light or an object (scene.cpp) and as a keyframe of the "animation"
// block that animates that key (animation.cpp), so both accept the same values with the same
// messages (docs/scene-format.md).
#pragma once

#include <optional>

#include "penumbra/core/math.h"
#include "penumbra/scene/json_reader.h"
#include "penumbra/scene/light.h"

namespace penumbra {

// camera.fov_y: an angle in degrees in (0, 180).
float read_fov_y(const JsonValue& v);
// An object's "scale": one non-zero number (the same on all axes) or three.
Vec3f read_scale(const JsonValue& v);
// Whether every component of a scale is non-zero (the object does not collapse).
bool scale_defined(Vec3f scale);

// The frame of a rect, disk or ellipsoid light from its "normal" and its "u" where given
// (docs/scene-format.md, "lights"); sphere lights are oriented by orient_sphere_lights.
Frame light_frame(LightShape shape, Vec3f normal, const std::optional<Vec3f>& u);
// Whether `u` gives a frame with `normal`: not parallel to it.
bool light_frame_defined(Vec3f normal, Vec3f u);

}  // namespace penumbra
