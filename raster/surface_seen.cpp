#include "raster/surface_seen.h"

#include <cmath>

namespace penumbra::raster {

glm::dvec3 drawn_world_position(const glm::dvec3& p, Precision precision) {
    return precision == Precision::world_float32 ? glm::dvec3(glm::vec3(p)) : p;
}

std::vector<glm::vec3> drawn_positions(const Scene& scene, const glm::dvec3& origin, Precision precision) {
    std::vector<glm::vec3> out(scene.positions.size());
    for (std::size_t i = 0; i < out.size(); ++i)
        out[i] = glm::vec3(drawn_world_position(scene.positions[i], precision) - origin);
    return out;
}

glm::dvec3 drawn_light_position(const Light& l, const glm::dvec3& origin, Precision precision) {
    return drawn_world_position(l.position, precision) - origin;
}

SurfaceSeen surface_seen(const PrimaryRay& ray, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
    SurfaceSeen s;
    s.normal = glm::cross(b - a, c - a);
    const double denom = glm::dot(ray.direction, s.normal);
    // A ray in the triangle's plane (a sliver seen edge-on) takes the triangle's centroid.
    s.point = std::abs(denom) > 1e-300 ? ray.origin + ray.direction * (glm::dot(a - ray.origin, s.normal) / denom)
                                       : (a + b + c) / 3.0;
    if (denom > 0) s.normal = -s.normal;  // the side the camera sees
    return s;
}

LightReach::LightReach(const Light& light, const glm::dvec3& position)
    : light_(light), position_(position), cos_outer_(std::cos(light.outer_cone_rad)) {}

bool LightReach::lightable(const SurfaceSeen& s) const {
    const glm::dvec3 to_light = light_.type == LightType::directional ? -light_.direction : position_ - s.point;
    if (glm::dot(s.normal, to_light) <= 0) return false;
    return light_.type != LightType::spot || glm::dot(-glm::normalize(to_light), light_.direction) >= cos_outer_;
}

}  // namespace penumbra::raster
