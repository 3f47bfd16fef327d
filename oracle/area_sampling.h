// Area lights in the oracle: points spread uniformly (in area) over a light's emitting surface,
// the low-discrepancy patterns that place them, and the confidence interval of the estimate.
//
// V of an area light is the visible fraction of its emitting area (docs/design.md). Each pixel
// estimates it in rounds of kRoundRays shadow rays; a round is the first 16 points of the
// Sobol (0,2)-sequence (a (0,4,2)-net: one point in every elementary interval of area 1/16)
// under its own random digital shift. Rounds are therefore independent and each is an
// unbiased estimate, so the spread between rounds gives an honest interval (randomized QMC,
// Owen 1997; L'Ecuyer & Lemieux 2002) while each round keeps QMC's stratification.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>

#include "common/light_sampling.h"
#include "common/scene.h"

namespace penumbra::oracle_detail {

inline constexpr int kRoundRays = 16;

// A 64-bit mix (splitmix64's finaliser) for per-pixel, per-round scrambles.
inline std::uint64_t mix64(std::uint64_t z) {
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}
inline std::uint64_t round_scramble(std::uint64_t seed, std::uint64_t light, std::uint64_t pixel, std::uint64_t round) {
    return mix64(mix64(mix64(mix64(seed) ^ light) ^ pixel) ^ round);
}

// One area light in the camera-centred frame, or a sun with a size: a disk of directions, the
// cone of half-angle alpha around the direction towards the sun (docs/oracle.md, section 8b).
struct AreaLight {
    LightType type = LightType::rect;
    glm::dvec3 center{0.0};
    glm::dvec3 u{0.0}, v{0.0};    // rect: full edges
    glm::dvec3 normal{0.0};       // rect, disk: unit emitting normal (u x v for a rect); sun: unit axis towards it
    glm::dvec3 e1{0.0}, e2{0.0};  // disk: orthonormal basis of its plane; sun: of the plane across its axis
    double radius = 0;            // disk, sphere
    double cone_one_minus_cos = 0, cone_sin = 0;  // sun: 1 - cos(alpha) and sin(alpha)
};
AreaLight make_area_light(const Light& light, const glm::dvec3& frame_origin);

// Where, seen from one receiver point, the light's emitting surface is.
struct AreaView {
    bool lightable = false;  // emits towards p and some of it lies above p's tangent plane
    bool inside = false;     // p inside a sphere light: V is undefined, the pixel is flagged U
    // Sphere: the cap visible from p, around axis w (from the centre towards p), cos of its rim.
    glm::dvec3 w{0.0}, e1{0.0}, e2{0.0};
    double cos_rim = 1;
};
AreaView view_area_light(const AreaLight& light, const glm::dvec3& p, const glm::dvec3& n);

// The point of the emitting surface at unit-square coordinates (s, t), uniform in area.
glm::dvec3 area_light_point(const AreaLight& light, const AreaView& view, double s, double t);
// A sun's: the unit direction towards it at unit-square coordinates (s, t), uniform in solid angle.
glm::dvec3 sun_direction(const AreaLight& sun, double s, double t);

// Two-sided 97.5% quantile of Student's t with `df` degrees of freedom.
double student_t975(int df);

}  // namespace penumbra::oracle_detail
