// Points spread over area lights, shared by the oracle (its sampling) and the raster path
// (averaged hard shadows): the first two Sobol dimensions and area-preserving maps.
#pragma once

#include <cmath>
#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <numbers>

namespace penumbra {

// The i-th point of the first two Sobol dimensions, as 32-bit fractions. Together they form a
// (0,2)-sequence: every 2^m consecutive points from a multiple of 2^m are a (0,m,2)-net.
inline std::uint32_t sobol_dim0(std::uint32_t i) {
    // van der Corput: the bits of i mirrored.
    i = (i << 16) | (i >> 16);
    i = ((i & 0x00ff00ffu) << 8) | ((i & 0xff00ff00u) >> 8);
    i = ((i & 0x0f0f0f0fu) << 4) | ((i & 0xf0f0f0f0u) >> 4);
    i = ((i & 0x33333333u) << 2) | ((i & 0xccccccccu) >> 2);
    i = ((i & 0x55555555u) << 1) | ((i & 0xaaaaaaaau) >> 1);
    return i;
}
inline std::uint32_t sobol_dim1(std::uint32_t i) {
    std::uint32_t x = 0;
    for (std::uint32_t v = 1u << 31; i != 0; i >>= 1, v ^= v >> 1)
        if (i & 1u) x ^= v;
    return x;
}

// Shirley-Chiu concentric map of the unit square onto the unit disk: area-preserving, so a
// net's equal-area strata stay equal-area on the disk.
inline glm::dvec2 concentric_disk(double s, double t) {
    double a = 2 * s - 1, b = 2 * t - 1;
    if (a == 0 && b == 0) return {0.0, 0.0};
    double r, phi;
    if (std::abs(a) > std::abs(b)) {
        r = a;
        phi = std::numbers::pi / 4 * (b / a);
    } else {
        r = b;
        phi = std::numbers::pi / 2 - std::numbers::pi / 4 * (a / b);
    }
    return {r * std::cos(phi), r * std::sin(phi)};
}

// An orthonormal pair perpendicular to unit n (Duff et al. 2017, "Building an orthonormal
// basis, revisited"): continuous and without a division by a small number.
inline void orthonormal_basis(const glm::dvec3& n, glm::dvec3& b1, glm::dvec3& b2) {
    double sign = std::copysign(1.0, n.z);
    double a = -1.0 / (sign + n.z);
    double b = n.x * n.y * a;
    b1 = glm::dvec3(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    b2 = glm::dvec3(b, sign + n.y * n.y * a, -n.y);
}

}  // namespace penumbra
