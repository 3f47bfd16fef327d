// The ranges every camera and light must lie in, wherever it came from: the scenario's own
// keys and a glTF scene's cameras and KHR_lights_punctual lights pass the same checks, so a
// value refused in one place is refused in the other (the oracle is right only inside them).
#pragma once

#include <optional>
#include <string>

#include "common/scene.h"

namespace penumbra {

// Largest world-space coordinate accepted, in metres: beyond it float conversion of even
// camera-relative coordinates loses all meaning.
inline constexpr double kMaxCoordinate = 1e15;
// Lengths (xmag, ymag, znear, radii, rect edges), metres. Beyond 1e15 m the oracle's rays and
// light samples overflow float (an orthographic camera of xmag 1e19 makes Embree reject its
// rays; a rect edge of 1e100 m makes every pixel unlightable).
inline constexpr double kMinExtent = 1e-12;
inline constexpr double kMaxExtent = 1e15;
inline constexpr double kMinFovDeg = 1e-3, kMaxFovDeg = 179.0;   // perspective yfov
inline constexpr double kMinConeDeg = 1e-3, kMaxConeDeg = 90.0;  // spot outer half-angle
// A sun's angular_diameter_deg lies in [0, kMaxSunDiameterDeg): the real sun is 0.53 degrees;
// a source wider than 20 degrees is no sun (model it as an area light), and PCSS's small-angle
// estimate of its penumbra (docs/raster.md) would stop meaning anything.
inline constexpr double kMaxSunDiameterDeg = 20.0;

// One value out of range: the key as the scenario spells it ("xmag", "u") and what is wrong.
struct RangeProblem {
    std::string key;
    std::string what;
};

std::optional<RangeProblem> camera_problem(const Camera& camera);
std::optional<RangeProblem> light_problem(const Light& light);

// Throw InputError "WHERE: KEY: WHAT" for the first problem; `where` names the file and the
// element ("scene.gltf: cameras[0] (placed by nodes[2])").
void validate_camera(const Camera& camera, const std::string& where);
void validate_light(const Light& light, const std::string& where);

// Euclidean length without overflow or underflow in the squares (1e200 stays 1e200).
double safe_length(const glm::dvec3& v);

}  // namespace penumbra
