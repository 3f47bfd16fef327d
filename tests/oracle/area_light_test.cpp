// The area-light oracle against exact answers: a rect light over a parallel rect occluder
// (1 - area(light ∩ projected occluder) / area(light)), a sphere light behind a sphere
// occluder (the visible-cap integral, one closed-form ring at a time), a disk light cut by its
// receivers' horizon (a circular segment). Over several seeds the mean error stays under 0.005
// and at least 90% of the penumbra pixels lie within their reported 95% half-width E.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <glm/geometric.hpp>
#include <numbers>

#include "oracle/area_sampling.h"
#include "oracle/oracle.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

using test::SceneBuilder;

// Ground y = 0 of ground_first .. ground_first + ground_count - 1, seen from straight above.
struct AreaScene {
    Scenario scenario;
    std::uint32_t ground_first = 0, ground_count = 0;
};

AreaScene ground_scene(SceneBuilder b, double half, Light light, int w = 128, int h = 96) {
    AreaScene s;
    s.ground_first = static_cast<std::uint32_t>(b.triangle_count());
    b.grid({-half, 0, half}, {2 * half, 0, 0}, {0, 0, -2 * half}, 4, 4);
    s.ground_count = static_cast<std::uint32_t>(b.triangle_count()) - s.ground_first;
    Camera cam = test::look_at_ortho({0, 20, 0}, {0, 0, 0}, half, half * h / w, {0, 0, -1});
    s.scenario = test::make_scenario(b.build(), cam, {light}, w, h);
    return s;
}

struct Agreement {
    std::size_t pixels = 0, penumbra = 0, penumbra_within_e = 0;
    double abs_error_sum = 0, max_error = 0;
    double mae() const { return pixels ? abs_error_sum / pixels : 0; }
    double coverage() const { return penumbra ? double(penumbra_within_e) / penumbra : 1; }
};

// The exact V of every ground pixel (NaN elsewhere); the pixels' points are the same whatever the seed.
std::vector<double> exact_image(const AreaScene& s, const OracleFrame& f,
                                const std::function<double(glm::dvec3)>& exact) {
    std::vector<double> truth(f.pixel_count(), std::nan(""));
    for (std::size_t i = 0; i < f.pixel_count(); ++i) {
        if (f.prim[i] < s.ground_first || f.prim[i] >= s.ground_first + s.ground_count) continue;
        glm::dvec3 p = f.frame_origin + glm::dvec3(f.P[i]);
        truth[i] = exact(glm::dvec3(p.x, 0.0, p.z));
    }
    return truth;
}

Agreement compare(const std::vector<double>& truth, const OracleLightImage& img) {
    Agreement a;
    for (std::size_t i = 0; i < truth.size(); ++i) {
        if (std::isnan(truth[i])) continue;
        double err = std::abs(img.V[i] - truth[i]);
        ++a.pixels;
        a.abs_error_sum += err;
        a.max_error = std::max(a.max_error, err);
        if (truth[i] > 1e-9 && truth[i] < 1 - 1e-9) {
            ++a.penumbra;
            a.penumbra_within_e += err <= img.E[i];
        }
    }
    return a;
}

// Overlap length of [a0, a1] and [b0, b1].
double overlap(double a0, double a1, double b0, double b1) {
    return std::max(0.0, std::min(a1, b1) - std::max(a0, b0));
}

void expect_honest(const AreaScene& s, const std::function<double(glm::dvec3)>& exact, std::size_t min_penumbra) {
    std::vector<double> truth;
    for (std::uint64_t seed : {1u, 2u, 3u, 4u}) {
        OracleSettings settings;
        settings.seed = seed;
        OracleResult r = run_oracle(s.scenario, settings);
        if (truth.empty()) truth = exact_image(s, r.frame, exact);
        Agreement a = compare(truth, r.frame.lights[0]);
        SCOPED_TRACE(testing::Message() << "seed " << seed);
        testing::Test::RecordProperty("seed" + std::to_string(seed),
                                      testing::PrintToString(a.mae()) + " mae, " +
                                          testing::PrintToString(a.coverage()) + " coverage of " +
                                          std::to_string(a.penumbra) + " penumbra px, rays/px " +
                                          testing::PrintToString(r.stats.lights[0].sampling.rays_per_pixel_mean));
        EXPECT_GT(a.pixels, s.scenario.width * s.scenario.height / 2u);
        EXPECT_GE(a.penumbra, min_penumbra);
        EXPECT_LT(a.mae(), 0.005);
        EXPECT_GE(a.coverage(), 0.90) << a.penumbra_within_e << " of " << a.penumbra << " penumbra pixels";
        EXPECT_LT(a.max_error, 0.1);
    }
}

TEST(AreaLight, RectOverAParallelRectOccluderMatchesTheProjectedOverlap) {
    // Light: 1.2 x 0.8 at y = 3, emitting down (u x v = -y). Occluder: 1.0 x 0.6 at y = 1.
    const glm::dvec3 lc(0.2, 3.0, 0.1), lu(1.2, 0, 0), lv(0, 0, 0.8);
    const double oy = 1.0, ox0 = -0.5, ox1 = 0.5, oz0 = -0.3, oz1 = 0.3;
    SceneBuilder b;
    b.quad({ox0, oy, oz1}, {ox1, oy, oz1}, {ox1, oy, oz0}, {ox0, oy, oz0});
    AreaScene s = ground_scene(b, 2.0, test::rect(lc, lu, lv));
    auto exact = [&](glm::dvec3 p) {
        // The occluder seen from p, projected onto the light's plane: scaled by H / h about p.
        const double k = lc.y / oy;
        double x0 = p.x + (ox0 - p.x) * k, x1 = p.x + (ox1 - p.x) * k;
        double z0 = p.z + (oz0 - p.z) * k, z1 = p.z + (oz1 - p.z) * k;
        double lx0 = lc.x - 0.6, lx1 = lc.x + 0.6, lz0 = lc.z - 0.4, lz1 = lc.z + 0.4;
        return 1.0 - overlap(x0, x1, lx0, lx1) * overlap(z0, z1, lz0, lz1) / (1.2 * 0.8);
    };
    expect_honest(s, exact, 1000);
}

// Visible fraction of the cap of sphere light (cl, rl) seen from p, behind sphere (co, ro):
// on each ring of the cap (constant angle theta from the axis towards p) the blocked arc is
// closed-form; the rings are summed in cos(theta), the cap's area measure.
double sphere_behind_sphere(glm::dvec3 p, glm::dvec3 cl, double rl, glm::dvec3 co, double ro) {
    const double d = glm::length(p - cl);
    const glm::dvec3 w = (p - cl) / d;
    glm::dvec3 e1 = glm::normalize(glm::cross(w, std::abs(w.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0)));
    glm::dvec3 e2 = glm::cross(w, e1);
    const double d_o = glm::length(co - p);
    const glm::dvec3 a = (co - p) / d_o;
    const double cos_alpha = std::sqrt(1 - (ro / d_o) * (ro / d_o));
    const double a1 = glm::dot(a, e1), a2 = glm::dot(a, e2), aw = glm::dot(a, w);
    const double cos_rim = rl / d;
    const int steps = 4000;
    double blocked = 0;
    for (int k = 0; k < steps; ++k) {
        double c = cos_rim + (1 - cos_rim) * (k + 0.5) / steps, s = std::sqrt(1 - c * c);
        double A = rl * s * std::hypot(a1, a2), B = (rl * c - d) * aw;
        double D = std::sqrt(rl * rl + d * d - 2 * rl * d * c) * cos_alpha;
        double frac =
            A < 1e-300 ? (B >= D ? 1.0 : 0.0) : std::acos(std::clamp((D - B) / A, -1.0, 1.0)) / std::numbers::pi;
        blocked += frac;
    }
    return 1.0 - blocked / steps;
}

TEST(AreaLight, SphereBehindASphereOccluderMatchesTheCapIntegral) {
    const glm::dvec3 cl(0.3, 4.0, -0.2), co(0.0, 1.6, 0.0);
    const double rl = 0.6, ro = 0.35;
    SceneBuilder b;
    b.sphere(co, ro, 192, 96);  // vertices on the sphere: within 1.4e-4 ro of it
    AreaScene s = ground_scene(b, 2.0, test::sphere(cl, rl), 96, 72);
    expect_honest(
        s, [&](glm::dvec3 p) { return sphere_behind_sphere(p, cl, rl, co, ro); }, 1000);
}

TEST(AreaLight, DiskCutByTheReceiversHorizonMatchesTheCircularSegment) {
    // A vertical disk whose centre is 0.25 m above the ground: from every ground point in front
    // of it, the part below y = 0 is under the horizon.
    const double r = 0.6, h = 0.25;
    AreaScene s = ground_scene(SceneBuilder(), 2.0, test::disk({0, h, -2.5}, {0, 0, 1}, r), 48, 36);
    const double segment = r * r * std::acos(h / r) - h * std::sqrt(r * r - h * h);
    const double truth = 1 - segment / (std::numbers::pi * r * r);
    expect_honest(
        s, [&](glm::dvec3) { return truth; }, 1500);
}

TEST(AreaLight, OneSidedLightsDoNotLightWhatIsBehindThem) {
    // The rect emits up (u x v = +y): the ground below it faces it but is behind it.
    AreaScene s = ground_scene(SceneBuilder(), 2.0, test::rect({0, 2, 0}, {1, 0, 0}, {0, 0, -1}), 32, 24);
    OracleResult r = run_oracle(s.scenario);
    EXPECT_GT(r.stats.lights[0].surface, 500u);
    EXPECT_EQ(r.stats.lights[0].lightable, 0u);
    EXPECT_EQ(r.stats.shadow_rays, 0u);
}

TEST(AreaLight, PointsInsideASphereLightAreFlaggedAmbiguous) {
    AreaScene s = ground_scene(SceneBuilder(), 2.0, test::sphere({0, 0, 0}, 0.5), 32, 24);
    OracleResult r = run_oracle(s.scenario);
    const auto& img = r.frame.lights[0];
    std::size_t inside = 0;
    for (std::size_t i = 0; i < r.frame.pixel_count(); ++i) {
        glm::dvec3 p = r.frame.frame_origin + glm::dvec3(r.frame.P[i]);
        if (r.frame.A[i] == 0 || glm::length(p) >= 0.49) continue;
        ++inside;
        EXPECT_EQ(img.U[i], 1.0f);
        EXPECT_EQ(img.lightable[i], 0.0f);
    }
    EXPECT_GT(inside, 5u);
}

TEST(AreaLight, IsBitIdenticalWhateverTheThreadCountAndVariesWithTheSeed) {
    SceneBuilder b;
    b.box({-0.4, 0, -0.4}, {0.4, 0.8, 0.4});
    AreaScene s = ground_scene(b, 2.0, test::disk({0.5, 3, 0.5}, {-0.2, -1, 0}, 0.7), 96, 72);
    OracleSettings one, two, other_seed;
    one.threads = 1;
    two.threads = 2;
    other_seed.seed = 99;
    OracleResult a = run_oracle(s.scenario, one), b2 = run_oracle(s.scenario, two),
                 c = run_oracle(s.scenario, other_seed);
    const auto& va = a.frame.lights[0].V;
    EXPECT_EQ(std::memcmp(va.data(), b2.frame.lights[0].V.data(), va.size() * sizeof(float)), 0);
    EXPECT_EQ(std::memcmp(a.frame.lights[0].E.data(), b2.frame.lights[0].E.data(), va.size() * sizeof(float)), 0);
    EXPECT_NE(std::memcmp(va.data(), c.frame.lights[0].V.data(), va.size() * sizeof(float)), 0);
}

TEST(AreaLight, SamplesOnlyWhereThePenumbraIs) {
    SceneBuilder b;
    b.box({-0.4, 0, -0.4}, {0.4, 0.8, 0.4});
    AreaScene s = ground_scene(b, 2.0, test::rect({0, 3, 0}, {0.8, 0, 0}, {0, 0, 0.8}), 128, 96);
    OracleResult adaptive = run_oracle(s.scenario);
    const OracleAreaStats& st = adaptive.stats.lights[0].sampling;
    ASSERT_TRUE(adaptive.stats.lights[0].area);
    // Most pixels are fully lit or in the umbra: one round of 16 rays settles them.
    EXPECT_LT(st.refined, adaptive.stats.lights[0].lightable / 3);
    EXPECT_LT(st.rays_per_pixel_mean, 200.0);
    EXPECT_EQ(st.rays, adaptive.stats.shadow_rays);
    ASSERT_FALSE(st.convergence.empty());
    EXPECT_LE(st.convergence.back().max_e, 1.0);
    for (std::size_t k = 1; k < st.convergence.size(); ++k)
        EXPECT_LE(st.convergence[k].mean_e, st.convergence[k - 1].mean_e + 1e-12);
    // The bound everywhere is met or the pixel reached the cap.
    const auto& img = adaptive.frame.lights[0];
    auto over = std::count_if(img.E.begin(), img.E.end(), [&](float e) { return e > adaptive.settings.area_target; });
    EXPECT_EQ(static_cast<std::uint64_t>(over), st.capped);
}

TEST(AreaSampling, TheFirstSixteenSobolPointsAreAZeroFourTwoNet) {
    // Every elementary interval of area 1/16 (2^a x 2^b cells with a + b = 4) holds one point,
    // also under a digital shift.
    for (std::uint32_t shift : {0u, 0x9e3779b9u}) {
        for (int a = 0; a <= 4; ++a) {
            std::vector<int> cells(16, 0);
            for (std::uint32_t i = 0; i < 16; ++i) {
                auto top_bits = [](std::uint32_t v, int bits) { return bits == 0 ? 0u : v >> (32 - bits); };
                std::uint32_t x = top_bits(sobol_dim0(i) ^ shift, a);
                std::uint32_t y = top_bits(sobol_dim1(i) ^ (shift * 3u), 4 - a);
                ++cells[(x << (4 - a)) | y];
            }
            for (int c : cells) EXPECT_EQ(c, 1) << "a = " << a;
        }
    }
}

TEST(AreaSampling, StudentQuantilesMatchTheTable) {
    EXPECT_NEAR(oracle_detail::student_t975(7), 2.365, 1e-3);
    EXPECT_NEAR(oracle_detail::student_t975(31), 2.0395, 1e-3);
    EXPECT_NEAR(oracle_detail::student_t975(1000), 1.9623, 1e-3);
}

}  // namespace
}  // namespace penumbra
