#include "oracle/area_sampling.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/geometric.hpp>
#include <limits>
#include <numbers>

namespace penumbra::oracle_detail {

AreaLight make_area_light(const Light& l, const glm::dvec3& frame_origin) {
    AreaLight a;
    a.type = l.type;
    a.center = l.position - frame_origin;
    a.radius = l.radius;
    if (l.type == LightType::rect) {
        a.u = l.u;
        a.v = l.v;
        a.normal = glm::normalize(glm::cross(l.u, l.v));
    } else if (l.type == LightType::disk) {
        a.normal = glm::normalize(l.normal);
        orthonormal_basis(a.normal, a.e1, a.e2);
    } else if (l.type == LightType::directional) {
        a.normal = -glm::normalize(l.direction);
        orthonormal_basis(a.normal, a.e1, a.e2);
        const double alpha = 0.5 * l.angular_diameter_rad;
        // 2 sin^2(alpha / 2): 1 - cos(alpha) would lose five digits of a 0.5-degree sun to cancellation.
        a.cone_one_minus_cos = 2 * std::sin(0.5 * alpha) * std::sin(0.5 * alpha);
        a.cone_sin = std::sin(alpha);
    }
    return a;
}

AreaView view_area_light(const AreaLight& light, const glm::dvec3& p, const glm::dvec3& n) {
    AreaView view;
    const glm::dvec3 to_center = light.center - p;
    switch (light.type) {
        case LightType::rect: {
            if (glm::dot(-to_center, light.normal) <= 0) return view;  // behind a one-sided light
            // A convex polygon lies under the tangent plane exactly when all its corners do.
            for (double su : {-0.5, 0.5})
                for (double sv : {-0.5, 0.5})
                    view.lightable |= glm::dot(n, to_center + su * light.u + sv * light.v) > 0;
            return view;
        }
        case LightType::disk: {
            if (glm::dot(-to_center, light.normal) <= 0) return view;
            glm::dvec3 in_plane = n - glm::dot(n, light.normal) * light.normal;
            view.lightable = glm::dot(n, to_center) + light.radius * glm::length(in_plane) > 0;
            return view;
        }
        case LightType::sphere: {
            double d = glm::length(to_center);
            if (!(d > light.radius)) {
                view.inside = true;
                return view;
            }
            view.w = -to_center / d;
            view.cos_rim = light.radius / d;
            orthonormal_basis(view.w, view.e1, view.e2);
            // If any of the sphere pokes above the tangent plane, so does the cap seen from p:
            // the first hit of a ray from p towards such a point is on the cap and above the plane.
            view.lightable = glm::dot(n, to_center) + light.radius > 0;
            return view;
        }
        case LightType::directional: {
            // The direction of the cone nearest n makes angle max(0, beta - alpha) with it, beta
            // the angle between n and the axis: some of the cone is above the tangent plane
            // exactly when beta < 90 + alpha, i.e. n . axis > -sin(alpha).
            view.lightable = glm::dot(n, light.normal) > -light.cone_sin;
            return view;
        }
        default: return view;
    }
}

glm::dvec3 sun_direction(const AreaLight& sun, double s, double t) {
    // Uniform in solid angle over the cone: 1 - cos(theta) uniform in [0, 1 - cos(alpha)]
    // (Archimedes; pbrt's UniformSampleCone, Pharr, Jakob & Humphreys, 3rd ed., 13.6.4), driven
    // through the concentric map (as the disk light) so that the net's equal-area strata stay
    // equal-solid-angle strata of the cone: r^2 of the disk point is 1 - cos(theta) scaled.
    const glm::dvec2 d = concentric_disk(s, t);
    const double r2 = d.x * d.x + d.y * d.y;
    const double one_minus_cos = r2 * sun.cone_one_minus_cos;
    const double sin_theta = std::sqrt(std::max(0.0, one_minus_cos * (2 - one_minus_cos)));
    const double r = std::sqrt(r2);
    const glm::dvec2 across = r > 0 ? d / r : glm::dvec2(0.0);  // (cos phi, sin phi)
    return (1 - one_minus_cos) * sun.normal + sin_theta * (across.x * sun.e1 + across.y * sun.e2);
}

glm::dvec3 area_light_point(const AreaLight& light, const AreaView& view, double s, double t) {
    switch (light.type) {
        case LightType::rect: return light.center + (s - 0.5) * light.u + (t - 0.5) * light.v;
        case LightType::disk: {
            glm::dvec2 d = concentric_disk(s, t);
            return light.center + light.radius * (d.x * light.e1 + d.y * light.e2);
        }
        case LightType::sphere: {
            // Area on a sphere is uniform in cos(theta) (Archimedes): the cap is cos in [cos_rim, 1].
            double one_minus_cos = s * (1 - view.cos_rim);
            double sin_theta = std::sqrt(std::max(0.0, one_minus_cos * (2 - one_minus_cos)));
            double phi = 2 * std::numbers::pi * t;
            return light.center + light.radius * (sin_theta * std::cos(phi) * view.e1 +
                                                  sin_theta * std::sin(phi) * view.e2 + (1 - one_minus_cos) * view.w);
        }
        default: return light.center;
    }
}

double student_t975(int df) {
    static constexpr std::array<double, 30> kTable = {
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160, 2.145, 2.131,
        2.120,  2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042};
    if (df < 1) return std::numeric_limits<double>::infinity();
    if (df <= 30) return kTable[static_cast<std::size_t>(df - 1)];
    // Cornish-Fisher expansion around the normal quantile; below 1e-4 off for df > 30.
    const double z = 1.959963984540054, v = df, z2 = z * z;
    return z + (z2 * z + z) / (4 * v) + (5 * z2 * z2 * z + 16 * z2 * z + 3 * z) / (96 * v * v) +
           (3 * z2 * z2 * z2 * z + 19 * z2 * z2 * z + 17 * z2 * z - 15 * z) / (384 * v * v * v);
}

}  // namespace penumbra::oracle_detail
