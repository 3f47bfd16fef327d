// Floating-point-aware geometry for the oracle's shadow rays.
//
// Embree intersects float triangles. The oracle keeps every vertex in double as well and uses
// it to (1) push shadow-ray origins off their surface by a bound on the float error, as
// pbrt-v4's OffsetRayOrigin does (Pharr, Jakob, Humphreys, PBR 4th ed., section 6.8.6;
// Wächter & Binder, Ray Tracing Gems ch. 6), and (2) re-judge in double any hit that lies
// within float error of the ray origin, so a surface never shadows itself or a coplanar
// neighbour, whatever its size or distance from the origin.
#pragma once

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <limits>

namespace penumbra::robust {

// Unit roundoff of IEEE single precision.
inline constexpr double kFloatEps = 0x1p-24;

// Per-component bound on the distance between the float rounding of a point on a triangle
// and the plane of the triangle's float-rounded vertices: both the point and each vertex carry
// at most half an ulp. `weighted_vertex_abs` is sum_i b_i |v_i| (or max_i |v_i| when the
// barycentrics are unknown). An 8x margin covers the interpolation and subtraction roundings.
inline glm::dvec3 surface_error_bound(const glm::dvec3& p, const glm::dvec3& weighted_vertex_abs) {
    return 4.0 * kFloatEps * (glm::abs(p) + weighted_vertex_abs);
}

// The next float above (up) or below v: std::nextafter without the library call, and
// without a data-dependent branch (the sign of v and the direction vary pixel by pixel).
// v must be finite.
inline float next_float(float v, bool up) {
    if (v == 0.0f) return up ? std::numeric_limits<float>::denorm_min() : -std::numeric_limits<float>::denorm_min();
    const auto bits = std::bit_cast<std::uint32_t>(v);
    const std::uint32_t away = (v > 0.0f) == up;  // sign-magnitude: a step away from 0 adds 1
    return std::bit_cast<float>(bits + 2 * away - 1);
}

// Moves p off its surface along n by the error bound and rounds the float result away from p
// (pbrt-v4 OffsetRayOrigin), so that the origin is strictly on n's side of the float triangle.
inline glm::vec3 offset_ray_origin(const glm::dvec3& p, const glm::dvec3& n, const glm::dvec3& error) {
    double d = glm::dot(glm::abs(n), error);
    glm::dvec3 offset = d * n;
    glm::dvec3 moved = p + offset;
    glm::vec3 po(static_cast<float>(moved.x), static_cast<float>(moved.y), static_cast<float>(moved.z));
    for (int c = 0; c < 3; ++c) {
        if (offset[c] != 0) po[c] = next_float(po[c], offset[c] > 0);
    }
    return po;
}

enum class HitVerdict {
    real,      // the segment from p along dir enters the triangle's interior at t > 0
    spurious,  // no intersection in exact arithmetic (self, coplanar neighbour, behind)
    edge,      // passes within double error of an edge: counted as a hit, pixel flagged ambiguous
    in_plane,  // the ray lies in the triangle's plane: counted as a miss, pixel flagged ambiguous
};

// Judges in double whether the ray from the true surface point p (unit dir) meets triangle
// (v0, v1, v2). A point lying on the triangle's plane cannot be occluded by it: touching is
// not occluding (a contact point is lit or shadowed by what lies beyond it).
inline HitVerdict verify_hit(const glm::dvec3& p, const glm::dvec3& dir, const glm::dvec3& v0, const glm::dvec3& v1,
                             const glm::dvec3& v2, double* t_out = nullptr) {
    glm::dvec3 n = glm::cross(v1 - v0, v2 - v0);
    double n_len = glm::length(n);
    if (!(n_len > 0)) return HitVerdict::spurious;
    n /= n_len;
    double scale = std::max(
        {glm::length(v0), glm::length(v1), glm::length(v2), glm::length(p), std::numeric_limits<double>::min()});
    // Double rounding of p and of the normal is ~1e-16 * scale; 1e-13 leaves three decades of
    // margin yet stays five decades below float error, the thing being corrected.
    double tol_plane = 1e-13 * scale;
    double s = glm::dot(n, p - v0);
    double cos_dir = glm::dot(n, dir);
    if (std::abs(s) <= tol_plane) return std::abs(cos_dir) <= 1e-12 ? HitVerdict::in_plane : HitVerdict::spurious;
    if (cos_dir == 0.0 || (s > 0) == (cos_dir > 0)) return HitVerdict::spurious;  // plane is behind
    double t = -s / cos_dir;
    glm::dvec3 q = p + t * dir;
    // Barycentrics from sub-triangle areas, relative to the triangle's own area.
    double b0 = glm::dot(n, glm::cross(v2 - v1, q - v1)) / n_len;
    double b1 = glm::dot(n, glm::cross(v0 - v2, q - v2)) / n_len;
    double b2 = 1.0 - b0 - b1;
    double lo = std::min({b0, b1, b2});
    if (t_out) *t_out = t;
    constexpr double kBaryTol = 1e-9;
    if (lo > kBaryTol) return HitVerdict::real;
    if (lo < -kBaryTol) return HitVerdict::spurious;
    return HitVerdict::edge;
}

}  // namespace penumbra::robust
