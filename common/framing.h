// What `penumbra init` decides about a model it has never seen (docs/quickstart.md): where a
// camera sees all of it, where a default sun stands, the ground under it, and whether its size
// suggests it was modelled in other units than metres.
#pragma once

#include <optional>
#include <string>

#include "common/receivers.h"
#include "common/scene.h"

namespace penumbra {

// The unit vector towards a point `elevation_deg` above the horizon (+Y up) at `azimuth_deg`,
// measured about +Y from +Z towards +X (glTF's front, then its right).
glm::dvec3 direction_from_angles(double elevation_deg, double azimuth_deg);

// A look-at perspective view of `bounds` from a 3/4 view above it: it looks at the bounds'
// centre from `elevation_deg`, `azimuth_deg` (as above), at the distance where the bounding
// sphere (bounds.center(), bounds.radius()) lies inside both the vertical and the horizontal
// field of view of a width x height image, with `margin` (>= 1) to spare.
struct ModelView {
    glm::dvec3 eye{0.0}, target{0.0};
    double yfov_deg = 45;
    double znear = 0.1;  // half the distance to the sphere: nothing of the model is clipped
    double distance = 0;
};
inline constexpr double kInitYfovDeg = 45, kInitElevationDeg = 30, kInitAzimuthDeg = 45;
inline constexpr double kInitSunElevationDeg = 45, kInitSunAzimuthDeg = -30;  // over the camera's left shoulder
ModelView frame_bounds(const Bounds& bounds, int width, int height, double yfov_deg = kInitYfovDeg,
                       double elevation_deg = kInitElevationDeg, double azimuth_deg = kInitAzimuthDeg,
                       double margin = 1.02);

// A square ground plane under the model: at the bounds' lowest y, centred below the bounds'
// centre, facing +Y, 6 bounding radii across (room for the shadows of a sun above 30 degrees).
Receiver ground_plane(const Bounds& bounds);

// Models are often exported in other units than glTF's metres: a "745 m" engine block is in
// millimetres, a "0.002 m" house in kilometres. A guess from the extents alone: a compact model
// (no extent under kFlatShare of the largest) beyond kUnitHintAboveM, a flat one or a site (a
// terrain, a floor: large in metres is common) beyond kFlatUnitHintAboveM, or either below
// kUnitHintBelowM; the hint is the scale that brings the largest extent closest to a metre
// (a compact model) or to a kilometre (a flat one) among the usual unit mistakes.
inline constexpr double kUnitHintAboveM = 100.0, kFlatUnitHintAboveM = 100e3, kUnitHintBelowM = 0.01;
inline constexpr double kFlatShare = 0.1;
struct UnitHint {
    double scale;      // the scenario's "scale" to add
    std::string unit;  // what the size suggests: "millimetres", ...
};
bool is_flat(const glm::dvec3& size);
// `site`: a terrain, floor or site (looks_like_site), judged by the flat model's sizes.
std::optional<UnitHint> unit_hint(const glm::dvec3& size, bool site = false);

// (area facing +a − area facing −a) / all area, per axis a: 0 for a closed model, near ±1 for
// one open sheet.
glm::dvec3 facing_lean(const Scene& scene);
// Flat (is_flat), or mostly one open sheet facing one way (a heightfield).
bool looks_like_site(const Scene& scene);

// Whether a model looks modelled with +Z up (many CAD, COLLADA and 3ds Max exports) rather than
// glTF's +Y: what it saw, for a warning, or nothing. Two signs, both guesses: open surfaces
// (terrains, floors, roofs) face up, so area-weighted normals lean towards +Z far more than
// towards +Y; a closed model with no such lean that stands on z = 0 and is centred on y.
std::optional<std::string> z_up_evidence(const Scene& scene);

}  // namespace penumbra
