#include "raster/area_lights.h"

#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>

#include "common/light_sampling.h"

namespace penumbra::raster {

namespace {

// Radius of the disk with the light's emitting area (a sphere: its own radius).
double equivalent_radius(const Light& l) {
    if (l.type == LightType::rect) return std::sqrt(glm::length(glm::cross(l.u, l.v)) / std::numbers::pi);
    return l.radius;
}

// Point j of n spread over the light: a centred (0,2)-sequence on a rect or disk, a spherical
// Fibonacci point set on a sphere (seen from afar, the points of the far half project like
// those of the near cap, so their shadows average to the cap's).
glm::dvec3 spread_point(const Light& l, int j, int n) {
    const auto i = static_cast<std::uint32_t>(j);
    const double s = std::fmod(sobol_dim0(i) * 0x1p-32 + 0.5 / n, 1.0);
    const double t = std::fmod(sobol_dim1(i) * 0x1p-32 + 0.5 / n, 1.0);
    switch (l.type) {
        case LightType::rect: return l.position + (s - 0.5) * l.u + (t - 0.5) * l.v;
        case LightType::disk: {
            glm::dvec3 e1, e2;
            orthonormal_basis(glm::normalize(l.normal), e1, e2);
            glm::dvec2 d = concentric_disk(s, t);
            return l.position + l.radius * (d.x * e1 + d.y * e2);
        }
        default: {
            const double z = 1.0 - (2.0 * j + 1.0) / n;
            const double phi = j * std::numbers::pi * (3.0 - std::sqrt(5.0));
            const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
            return l.position + l.radius * glm::dvec3(r * std::cos(phi), z, r * std::sin(phi));
        }
    }
}

}  // namespace

ExpandedLights expand_area_lights(const std::vector<Light>& lights, const Technique& technique) {
    ExpandedLights e;
    for (const Light& l : lights) {
        e.first.push_back(e.lights.size());
        if (!is_area_light(l.type)) {
            e.lights.push_back(l);
            e.count.push_back(1);
            continue;
        }
        Light point = l;
        point.type = LightType::point;
        point.radius = equivalent_radius(l);
        const int n = technique.area_samples;
        if (n == 0) {
            e.lights.push_back(point);
        } else {
            for (int j = 0; j < n; ++j) {
                point.position = spread_point(l, j, n);
                e.lights.push_back(point);
            }
        }
        e.count.push_back(static_cast<std::size_t>(std::max(n, 1)));
    }
    return e;
}

}  // namespace penumbra::raster
