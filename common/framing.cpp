#include "common/framing.h"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include <glm/geometric.hpp>

namespace penumbra {
namespace {
constexpr double kDeg = M_PI / 180.0;
// A lean of the area-weighted normals this strong is an open, up-facing surface, not noise;
// past kSiteLean, most of the model is one open sheet (a heightfield).
constexpr double kZUpLean = 0.25, kSiteLean = 0.5;
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

bool is_flat(const glm::dvec3& size) {
    const double largest = std::max({size.x, size.y, size.z}), smallest = std::min({size.x, size.y, size.z});
    return largest > 0 && smallest < kFlatShare * largest;
}

std::optional<UnitHint> unit_hint(const glm::dvec3& size, bool site) {
    struct Candidate {
        double scale;
        const char* unit;
    };
    static constexpr Candidate kTooBig[] = {{0.01, "centimetres"}, {0.001, "millimetres"}};
    static constexpr Candidate kTooSmall[] = {
        {100.0, "a model in metres shrunk 100 times (a centimetre conversion applied once too often)"},
        {1000.0, "kilometres"}};
    const double size_m = std::max({size.x, size.y, size.z});
    const bool flat = site || is_flat(size);
    const Candidate* begin = nullptr;
    if (size_m > (flat ? kFlatUnitHintAboveM : kUnitHintAboveM))
        begin = kTooBig;
    else if (size_m < kUnitHintBelowM && size_m > 0)
        begin = kTooSmall;
    else
        return std::nullopt;
    const double typical_m = flat && begin == kTooBig ? 1000.0 : 1.0;
    const auto miss = [&](const Candidate* c) { return std::abs(std::log10(size_m * c->scale / typical_m)); };
    const Candidate* best = begin;
    for (const Candidate* c = begin; c != begin + 2; ++c)
        if (miss(c) < miss(best)) best = c;
    return UnitHint{best->scale, best->unit};
}

glm::dvec3 facing_lean(const Scene& scene) {
    glm::dvec3 lean{0.0};
    double area = 0;
    for (const glm::u32vec3& t : scene.triangles) {
        const glm::dvec3 n =
            0.5 * glm::cross(scene.positions[t.y] - scene.positions[t.x], scene.positions[t.z] - scene.positions[t.x]);
        lean += n;
        area += glm::length(n);
    }
    return area > 0 ? lean / area : glm::dvec3(0.0);
}

bool looks_like_site(const Scene& scene) {
    const glm::dvec3 lean = glm::abs(facing_lean(scene));
    return is_flat(scene.bounds.hi - scene.bounds.lo) || std::max({lean.x, lean.y, lean.z}) > kSiteLean;
}

std::optional<std::string> z_up_evidence(const Scene& scene) {
    if (scene.bounds.empty()) return std::nullopt;
    const glm::dvec3 lean = facing_lean(scene);
    if (std::abs(lean.z) > kZUpLean && std::abs(lean.z) > 2.0 * std::abs(lean.y))
        return fmt::format("{:.0f}% of its area faces {}Z beyond the opposite way, against {:.0f}% along Y: open "
                           "surfaces such as ground and roofs face up{}",
                           100 * std::abs(lean.z), lean.z > 0 ? "+" : "-", 100 * std::abs(lean.y),
                           lean.z < 0 ? " (here down: its winding may be inverted, the camera then sees back faces)"
                                      : "");
    if (std::abs(lean.y) > kZUpLean) return std::nullopt;  // faces up (or down) along +Y: Y-up
    const Bounds& b = scene.bounds;
    const glm::dvec3 size = b.hi - b.lo;
    const double largest = std::max({size.x, size.y, size.z});
    const bool on_z0 = std::abs(b.lo.z) < 0.01 * largest && size.z > 0.1 * largest;
    const bool on_y0 = std::abs(b.lo.y) < 0.01 * largest;
    const bool centred_y = std::abs(b.center().y) < 0.05 * largest && size.y > 0.1 * largest;
    if (on_z0 && centred_y && !on_y0)
        return fmt::format("it stands on z = 0 (from z = {:.4g} to {:.4g}) and is centred on y (from {:.4g} to {:.4g})",
                           b.lo.z, b.hi.z, b.lo.y, b.hi.y);
    return std::nullopt;
}

}  // namespace penumbra
