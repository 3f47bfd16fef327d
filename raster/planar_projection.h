// Planar projection shadows (docs/raster.md, "Planar projection shadows"; Blinn, "Me and My
// (Fake) Shadow", IEEE CG&A 1988): every caster flattened onto one receiver plane by the light's
// projection matrix and drawn from the camera through a stencil, so that a pixel of the plane
// is darkened once however many casters cover it. Only that plane receives shadow.
#pragma once

#include <glm/mat4x4.hpp>
#include <glm/vec4.hpp>
#include <optional>

#include "common/scene.h"
#include "raster/technique.h"

namespace penumbra::raster {

// The "planar" object of a technique whose family is "planar_projection".
struct PlanarProjection final : FamilyParameters {
    // n.x + d = 0 with n a unit vector towards the casters (world space); unset: the scene's
    // largest upward-facing plane (largest_upward_plane).
    std::optional<glm::dvec4> plane;
};

// The planar parameters of `t`, or null when its family is not "planar_projection".
const PlanarProjection* planar_of(const Technique& t);

// The plane (unit n, d) holding the most triangle area among triangles whose front face points
// up (n.y >= 0.9, within 26 degrees of +Y): coplanar triangles, to 1e-6 of the normal and
// `1e-6 * (1 + the scene's radius)` of d, add their areas. Null when no triangle faces up.
std::optional<glm::dvec4> largest_upward_plane(const Scene& scene);

// Blinn's shadow matrix: M p lies on `plane` on the line through p and the light, `light` in
// homogeneous coordinates ((position, 1) for a point light, (-direction, 0) for a directional
// one): M = (plane . light) I - light plane^T.
glm::dmat4 planar_shadow_matrix(const glm::dvec4& plane, const glm::dvec4& light);

}  // namespace penumbra::raster
