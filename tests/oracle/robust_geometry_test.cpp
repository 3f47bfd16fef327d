// The two primitives the oracle's robustness rests on, tested against exact arithmetic in double.
#include "oracle/robust_geometry.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <glm/geometric.hpp>
#include <limits>
#include <random>

namespace penumbra {
namespace {

using robust::HitVerdict;

glm::dvec3 rounded(const glm::dvec3& v) {
    return glm::dvec3(glm::vec3(static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z)));
}

// After the offset, the float origin lies strictly on the normal's side of the *float* triangle
// (the one Embree intersects), for triangles of every size far from and near to the origin.
TEST(RobustGeometry, OffsetOriginLeavesTheFloatTriangle) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-1, 1), b(0, 1);
    int trials = 0, turned = 0;
    // (distance from the origin, triangle size): from 1 mm triangles at the origin to 1 km
    // triangles a million metres out; pairs where float rounding alone exceeds 1% of the size
    // are meaningless for a float tracer and left out.
    const std::pair<double, double> cases[] = {{0, 1e-3}, {0, 1},     {0, 1e3},   {1e3, 0.1},
                                               {1e3, 1},  {1e3, 1e3}, {1e6, 1e3}, {1e6, 10}};
    for (auto [offset, size] : cases) {
        {
            for (int i = 0; i < 20000; ++i, ++trials) {
                glm::dvec3 c(offset * u(rng), offset * u(rng), offset * u(rng));
                glm::dvec3 v0 = c + size * glm::dvec3(u(rng), u(rng), u(rng));
                glm::dvec3 v1 = c + size * glm::dvec3(u(rng), u(rng), u(rng));
                glm::dvec3 v2 = c + size * glm::dvec3(u(rng), u(rng), u(rng));
                glm::dvec3 n = glm::cross(v1 - v0, v2 - v0);
                if (glm::length(n) < 1e-3 * size * size) continue;  // skip slivers: their plane is ill-defined
                n = glm::normalize(n);
                double b1 = b(rng), b2 = b(rng) * (1 - b1), b0 = 1 - b1 - b2;
                glm::dvec3 p = b0 * v0 + b1 * v1 + b2 * v2;
                glm::dvec3 err =
                    robust::surface_error_bound(p, b0 * glm::abs(v0) + b1 * glm::abs(v1) + b2 * glm::abs(v2));
                glm::dvec3 o(robust::offset_ray_origin(p, n, err));
                glm::dvec3 f0 = rounded(v0), f1 = rounded(v1), f2 = rounded(v2);
                glm::dvec3 fn = glm::normalize(glm::cross(f1 - f0, f2 - f0));
                // Where float rounding turns the triangle (a 1 mm triangle 1 km out has 60 um
                // ulps), "its side" is meaningless; verify_hit in double handles those.
                if (!(glm::dot(fn, n) > 0.99)) {
                    ++turned;
                    continue;
                }
                ASSERT_GT(glm::dot(fn, o - f0), 0.0) << "offset " << offset << " size " << size << " trial " << i;
            }
        }
    }
    EXPECT_GT(trials, 100000);
    EXPECT_LT(turned, trials / 100);
}

TEST(RobustGeometry, VerifyHitJudgesInDouble) {
    const glm::dvec3 v0(0, 0, 0), v1(1, 0, 0), v2(0, 0, -1);  // faces +y
    double t = 0;
    // A point of the plane never hits the plane's triangles again (coplanar neighbour).
    EXPECT_EQ(robust::verify_hit({0.5, 0, 0.5}, glm::normalize(glm::dvec3(0.1, 0.001, -1)), v0, v1, v2),
              HitVerdict::spurious);
    // From above, going down through the interior: a real hit at the right distance.
    EXPECT_EQ(robust::verify_hit({0.2, 2, -0.2}, {0, -1, 0}, v0, v1, v2, &t), HitVerdict::real);
    EXPECT_DOUBLE_EQ(t, 2.0);
    // The plane behind the ray.
    EXPECT_EQ(robust::verify_hit({0.2, 2, -0.2}, {0, 1, 0}, v0, v1, v2), HitVerdict::spurious);
    // Outside the triangle.
    EXPECT_EQ(robust::verify_hit({0.9, 2, -0.9}, {0, -1, 0}, v0, v1, v2), HitVerdict::spurious);
    // Exactly through an edge: counted, and flagged.
    EXPECT_EQ(robust::verify_hit({0.5, 2, 0}, {0, -1, 0}, v0, v1, v2), HitVerdict::edge);
    // A ray lying in the plane.
    EXPECT_EQ(robust::verify_hit({-1, 0, -0.2}, {1, 0, 0}, v0, v1, v2), HitVerdict::in_plane);
    // 10 um above a plane 1e7 m from the origin is still above it in double.
    const glm::dvec3 w0(1e7, 0, 1e7), w1(1e7 + 1, 0, 1e7), w2(1e7, 0, 1e7 - 1);
    EXPECT_EQ(robust::verify_hit({1e7 + 0.2, 1e-5, 1e7 - 0.2}, {0, -1, 0}, w0, w1, w2), HitVerdict::real);
}

TEST(RobustGeometry, NextFloatMatchesNextafter) {
    const float inf = std::numeric_limits<float>::infinity();
    for (float v : {0.0f, -0.0f, 1.0f, -1.0f, 1e-40f, -1e-40f, 3.4e38f, -3.4e38f, 0.1f, -123.456f,
                    std::numeric_limits<float>::denorm_min(), std::numeric_limits<float>::min()}) {
        EXPECT_EQ(std::bit_cast<std::uint32_t>(robust::next_float(v, true)),
                  std::bit_cast<std::uint32_t>(std::nextafter(v, inf)))
            << v;
        EXPECT_EQ(std::bit_cast<std::uint32_t>(robust::next_float(v, false)),
                  std::bit_cast<std::uint32_t>(std::nextafter(v, -inf)))
            << v;
    }
}

}  // namespace
}  // namespace penumbra
