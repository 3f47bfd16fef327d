#include "common/ranges.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>

#include "common/errors.h"

namespace penumbra {

namespace {

constexpr double kDeg = M_PI / 180.0;

// Angles arrive in degrees (scenario) or radians (glTF): allow the conversion's rounding.
bool in_degrees(double v, double lo, double hi) {
    return v >= lo * (1 - 1e-9) && v <= hi * (1 + 1e-9);
}

bool finite3(const glm::dvec3& v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

std::optional<RangeProblem> position_problem(const glm::dvec3& p, const char* key) {
    for (int c = 0; c < 3; ++c)
        if (!(std::abs(p[c]) <= kMaxCoordinate))
            return RangeProblem{key, fmt::format("coordinate {:g} exceeds the {:g} m limit", p[c], kMaxCoordinate)};
    return std::nullopt;
}

std::optional<RangeProblem> extent_problem(double v, const char* key, const char* what, double lo = kMinExtent) {
    if (!(v >= lo && v <= kMaxExtent))
        return RangeProblem{key, fmt::format("{} {:g} m is outside [{:g}, {:g}] m", what, v, lo, kMaxExtent)};
    return std::nullopt;
}

std::optional<RangeProblem> unit_problem(const glm::dvec3& d, const char* key) {
    if (!finite3(d) || !(std::abs(glm::length(d) - 1.0) < 1e-6)) return RangeProblem{key, "not a unit direction"};
    return std::nullopt;
}

}  // namespace

double safe_length(const glm::dvec3& v) {
    const double m = std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)});
    if (!(m > 0) || !std::isfinite(m)) return m;
    return m * glm::length(v / m);
}

std::optional<RangeProblem> camera_problem(const Camera& c) {
    if (auto p = position_problem(c.eye, "eye")) return p;
    if (!finite3(c.forward) || !finite3(c.right) || !finite3(c.up))
        return RangeProblem{"up", "the camera's orientation is not finite"};
    if (c.type == ProjectionType::perspective) {
        const double deg = c.yfov_rad / kDeg;
        if (!in_degrees(deg, kMinFovDeg, kMaxFovDeg))
            return RangeProblem{
                "yfov_deg", fmt::format("field of view {:g} degrees ({:g} rad) is outside [{:g}, {:g}] degrees", deg,
                                        c.yfov_rad, kMinFovDeg, kMaxFovDeg)};
        if (auto p = extent_problem(c.znear, "znear", "znear")) return p;
    } else {
        if (auto p = extent_problem(c.xmag, "xmag", "half-width xmag")) return p;
        if (auto p = extent_problem(c.ymag, "ymag", "half-height ymag")) return p;
        if (auto p = extent_problem(c.znear, "znear", "znear", 0.0)) return p;
    }
    if (!(c.zfar > c.znear))  // +inf is fine: no far plane
        return RangeProblem{"zfar", fmt::format("must exceed znear ({:g} <= {:g})", c.zfar, c.znear)};
    return std::nullopt;
}

std::optional<RangeProblem> light_problem(const Light& l) {
    switch (l.type) {
        case LightType::directional: {
            if (auto p = unit_problem(l.direction, "direction")) return p;
            const double diameter = l.angular_diameter_rad / kDeg;
            if (!(diameter >= 0 && diameter < kMaxSunDiameterDeg))
                return RangeProblem{
                    "angular_diameter_deg",
                    fmt::format("{:g} degrees is outside [0, {:g}) (0: a punctual sun)", diameter, kMaxSunDiameterDeg)};
            return std::nullopt;
        }
        case LightType::point: return position_problem(l.position, "position");
        case LightType::spot: {
            if (auto p = position_problem(l.position, "position")) return p;
            if (auto p = unit_problem(l.direction, "direction")) return p;
            const double outer = l.outer_cone_rad / kDeg, inner = l.inner_cone_rad / kDeg;
            if (!in_degrees(outer, kMinConeDeg, kMaxConeDeg))
                return RangeProblem{"outer_cone_deg", fmt::format("half-angle {:g} degrees is outside [{:g}, {:g}]",
                                                                  outer, kMinConeDeg, kMaxConeDeg)};
            if (!(inner >= 0 && inner <= outer * (1 + 1e-12)))
                return RangeProblem{"inner_cone_deg",
                                    fmt::format("{:g} degrees must lie in [0, outer_cone_deg = {:g}]", inner, outer)};
            return std::nullopt;
        }
        case LightType::rect: {
            if (auto p = position_problem(l.position, "center")) return p;
            if (auto p = extent_problem(safe_length(l.u), "u", "edge length")) return p;
            return extent_problem(safe_length(l.v), "v", "edge length");
        }
        case LightType::disk:
            if (auto p = position_problem(l.position, "center")) return p;
            if (auto p = unit_problem(l.normal, "normal")) return p;
            return extent_problem(l.radius, "radius", "radius");
        case LightType::sphere:
            if (auto p = position_problem(l.position, "center")) return p;
            return extent_problem(l.radius, "radius", "radius");
    }
    return std::nullopt;
}

void validate_camera(const Camera& camera, const std::string& where) {
    if (auto p = camera_problem(camera)) throw InputError(fmt::format("{}: {}: {}", where, p->key, p->what));
}

void validate_light(const Light& light, const std::string& where) {
    if (auto p = light_problem(light)) throw InputError(fmt::format("{}: {}: {}", where, p->key, p->what));
}

}  // namespace penumbra
