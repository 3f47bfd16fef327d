#include "common/framing.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>

namespace penumbra {
namespace {
constexpr double kDeg = M_PI / 180.0;
}

glm::dvec3 direction_from_angles(double elevation_deg, double azimuth_deg) {
    const double el = elevation_deg * kDeg, az = azimuth_deg * kDeg;
    return {std::cos(el) * std::sin(az), std::sin(el), std::cos(el) * std::cos(az)};
}

ModelView frame_bounds(const Bounds& bounds, int width, int height, double yfov_deg, double elevation_deg,
                       double azimuth_deg, double margin) {
    ModelView v;
    v.yfov_deg = yfov_deg;
    v.target = bounds.center();
    const double r = bounds.radius();
    const double half_y = 0.5 * yfov_deg * kDeg;
    const double half_x = std::atan(std::tan(half_y) * double(width) / double(height));
    // A sphere at distance d subtends a half-angle asin(r / d): it fits the narrower half-angle.
    v.distance = margin * r / std::sin(std::min(half_y, half_x));
    v.eye = v.target + v.distance * direction_from_angles(elevation_deg, azimuth_deg);
    v.znear = 0.5 * (v.distance - r);
    return v;
}

Receiver ground_plane(const Bounds& bounds) {
    Receiver g;
    g.type = ReceiverType::plane;
    const glm::dvec3 c = bounds.center();
    g.center = {c.x, bounds.lo.y, c.z};
    g.normal = {0, 1, 0};
    const double side = 6.0 * bounds.radius();
    g.size = {side, side, 0};
    return g;
}

std::optional<UnitHint> unit_hint(double size_m) {
    struct Candidate {
        double scale;
        const char* unit;
    };
    static constexpr Candidate kTooBig[] = {{0.01, "centimetres"}, {0.001, "millimetres"}};
    static constexpr Candidate kTooSmall[] = {
        {100.0, "a model in metres shrunk 100 times (a centimetre conversion applied once too often)"},
        {1000.0, "kilometres"}};
    const Candidate* begin = nullptr;
    if (size_m > kUnitHintAboveM)
        begin = kTooBig;
    else if (size_m < kUnitHintBelowM && size_m > 0)
        begin = kTooSmall;
    else
        return std::nullopt;
    const Candidate* best = begin;
    for (const Candidate* c = begin; c != begin + 2; ++c)
        if (std::abs(std::log10(size_m * c->scale)) < std::abs(std::log10(size_m * best->scale))) best = c;
    return UnitHint{best->scale, best->unit};
}

}  // namespace penumbra
