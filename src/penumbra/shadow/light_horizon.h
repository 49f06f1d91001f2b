// The light as the horizon test sees it (light_horizon_shared.h): a rectangle, and the part of it
// above a receiver's tangent plane.
#pragma once

#include "penumbra/core/math.h"
#include "penumbra/scene/light.h"
#include "penumbra/shadow/light_horizon_shared.h"

namespace penumbra {

// Half the sides of the light's rectangle along frame.s and frame.t: a rect's own; a disk, a
// sphere's disk or an ellipsoid's central ellipse as the rectangle of equal area along its axes
// (side r sqrt(pi) for a disk of radius r).
Vec2f light_half_axes(const AreaLight& light);

// The record of that rectangle (centre, normal, axes, half sides).
shader::HorizonLight horizon_light(const AreaLight& light);

// The fraction of the light's rectangle above p's tangent plane (normal ng).
float light_fraction_above(const AreaLight& light, Vec3f p, Vec3f ng);

}  // namespace penumbra
