// Cut-outs (alphaMode MASK) in the oracle against closed forms: a checkerboard card over a plane,
// under a sun straight down and at 30 degrees and under a point light, seen through by the
// camera, with NEAREST and LINEAR sampling (whose 0.5 contour on a checkerboard is the texel
// grid itself), near the origin and 10^6 m from it. Every pixel's verdict is the analytic one
// but within 1e-3 texel of a texel boundary, and a pixel flagged U lies that close to one.
#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <optional>

#include "common/alpha_coverage.h"
#include "oracle/oracle.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

constexpr int kTexels = 6;  // the checkerboard's texels a side
constexpr double kNearTexels = 1e-3;

struct Card {
    glm::dvec3 corner, u, v;  // uv (0, 0) at corner, u and v the full edges (perpendicular)
    std::uint32_t first = 0;  // its two triangles
};

// Where the line o + s d meets the card's plane: the card's (s, t) there, or none.
std::optional<glm::dvec2> card_coords(const Card& c, const glm::dvec3& o, const glm::dvec3& d) {
    const glm::dvec3 n = glm::cross(c.u, c.v);
    const double dn = glm::dot(d, n);
    if (std::abs(dn) < 1e-12) return std::nullopt;
    const double s = glm::dot(c.corner - o, n) / dn;
    if (!(s > 1e-9)) return std::nullopt;
    const glm::dvec3 q = o + s * d - c.corner;
    return glm::dvec2(glm::dot(q, c.u) / glm::dot(c.u, c.u), glm::dot(q, c.v) / glm::dot(c.v, c.v));
}

bool inside(glm::dvec2 st) {
    return st.x >= 0 && st.x < 1 && st.y >= 0 && st.y < 1;
}
bool opaque_at(glm::dvec2 st) {
    if (!inside(st)) return false;
    const int i = static_cast<int>(std::floor(st.x * kTexels)), j = static_cast<int>(std::floor(st.y * kTexels));
    return (i + j) % 2 == 0;
}
// Texels from st to the nearest texel boundary line (the card's outline among them).
double texels_to_boundary(glm::dvec2 st) {
    const glm::dvec2 x = st * double(kTexels);
    return std::min(std::abs(x.x - std::round(x.x)), std::abs(x.y - std::round(x.y)));
}
// Near a boundary that matters: inside the card (or on its outline) and within kNearTexels of a line.
bool near_boundary(const std::optional<glm::dvec2>& st) {
    if (!st) return false;
    const double margin = kNearTexels / kTexels;
    const bool in_reach = st->x > -margin && st->x < 1 + margin && st->y > -margin && st->y < 1 + margin;
    return in_reach && texels_to_boundary(*st) < kNearTexels;
}

struct CutoutCase {
    const char* name;
    int light;  // 0: sun straight down, 1: sun at 30 degrees, 2: point light
    bool nearest;
    double offset_m;  // the whole scenario moved this far along x and z
};

class CutoutCard : public ::testing::TestWithParam<CutoutCase> {};

TEST_P(CutoutCard, MatchesTheCheckerboardsClosedForm) {
    const CutoutCase cc = GetParam();
    const glm::dvec3 offset(cc.offset_m, 0, -cc.offset_m);
    test::SceneBuilder b;
    const std::uint32_t ground = b.quad(offset + glm::dvec3(-12, 0, 12), offset + glm::dvec3(12, 0, 12),
                                        offset + glm::dvec3(12, 0, -12), offset + glm::dvec3(-12, 0, -12));
    Scene scene = b.build();
    const Card card{offset + glm::dvec3(-1.5, 1.2, 1.5),
                    {3, 0, 0},
                    {0, 0, -3},
                    test::add_cutout_card(scene, offset + glm::dvec3(-1.5, 1.2, 1.5), {3, 0, 0}, {0, 0, -3},
                                          test::checkerboard_alpha(kTexels), cc.nearest)};
    const glm::dvec3 point_light = offset + glm::dvec3(0.4, 5.0, -0.3);
    const glm::dvec3 sun =
        cc.light == 0 ? glm::dvec3(0, -1, 0) : glm::dvec3(std::sin(M_PI / 6), -std::cos(M_PI / 6), 0);
    const Light light = cc.light == 2 ? test::point(point_light) : test::directional(sun);
    const glm::dvec3 eye = offset + glm::dvec3(0.3, 6.5, 4.5);
    Scenario sc = test::make_scenario(scene, test::look_at(eye, offset, 55), {light}, 320, 240);
    const OracleResult res = run_oracle(sc);
    const OracleFrame& f = res.frame;
    const OracleLightImage& img = f.lights[0];

    std::size_t card_seen = 0, seen_through = 0, hole_lit = 0, texel_shadowed = 0, ambiguous = 0, wrong = 0;
    for (std::size_t i = 0; i < f.pixel_count(); ++i) {
        if (f.prim[i] == kNoPrimitive) continue;
        const glm::dvec3 p = f.frame_origin + glm::dvec3(f.P[i]);
        // The camera's ray through the pixel meets the card's plane here.
        const std::optional<glm::dvec2> seen = card_coords(card, eye, p - eye);
        const bool on_card = f.prim[i] == card.first || f.prim[i] == card.first + 1;
        std::optional<glm::dvec2> shadow;
        if (!on_card) {
            const glm::dvec3 to_light = cc.light == 2 ? glm::normalize(point_light - p) : -sun;
            shadow = card_coords(card, p, to_light);
        }
        if (img.U[i] != 0) {
            ++ambiguous;
            EXPECT_TRUE(near_boundary(seen) || near_boundary(shadow))
                << cc.name << ": pixel " << i % f.width << "," << i / f.width << " is U away from every texel boundary";
            continue;
        }
        if (near_boundary(seen)) continue;  // either answer is right within the frame's float error
        const bool see_card = seen && opaque_at(*seen);
        if (on_card != see_card) {
            ++wrong;
            ADD_FAILURE() << cc.name << ": pixel " << i % f.width << "," << i / f.width << " sees "
                          << (on_card ? "the card" : "past the card") << " where the closed form says otherwise";
            continue;
        }
        if (on_card) {
            ++card_seen;
            continue;
        }
        EXPECT_EQ(f.prim[i] == ground || f.prim[i] == ground + 1, true);
        seen_through += seen && inside(*seen);
        if (near_boundary(shadow)) continue;
        const bool expect_shadow = shadow && opaque_at(*shadow);
        if ((img.V[i] == 0.0f) != expect_shadow) {
            ++wrong;
            ADD_FAILURE() << cc.name << ": pixel " << i % f.width << "," << i / f.width << " V=" << img.V[i]
                          << " where the closed form says " << (expect_shadow ? 0 : 1);
            if (wrong > 8) return;
        }
        if (shadow && inside(*shadow)) (expect_shadow ? texel_shadowed : hole_lit) += 1;
    }
    EXPECT_EQ(wrong, 0u);
    EXPECT_GT(card_seen, 2000u);
    EXPECT_GT(seen_through, 2000u) << "the camera must see the ground through the card's holes";
    EXPECT_GT(hole_lit, 1000u) << "light must pass the holes";
    EXPECT_GT(texel_shadowed, 1000u);
    EXPECT_LT(ambiguous, f.pixel_count() / 200);
}

INSTANTIATE_TEST_SUITE_P(
    Oracle, CutoutCard,
    ::testing::Values(CutoutCase{"sun_down_nearest", 0, true, 0}, CutoutCase{"sun_down_linear", 0, false, 0},
                      CutoutCase{"sun_30_nearest", 1, true, 0}, CutoutCase{"sun_30_linear", 1, false, 0},
                      CutoutCase{"point_nearest", 2, true, 0}, CutoutCase{"point_linear", 2, false, 0},
                      CutoutCase{"sun_30_far_from_origin", 1, true, 1e6},
                      CutoutCase{"point_far_from_origin", 2, false, 1e6}),
    [](const auto& param_info) { return std::string(param_info.param.name); });

// glTF's coverage rule itself: factor x texture x COLOR_0, >= cutoff, wrap modes and the
// KHR_texture_transform matrix (offset, rotation, scale in that product).
TEST(AlphaCoverage, FollowsGltfsRuleAndVulkansAddressing) {
    AlphaTexture t;
    t.width = 4;
    t.height = 1;
    t.alpha = {0, 21845, 43690, 65535};  // 0, 1/3, 2/3, 1
    CutoutMaterial m;
    m.texture = 0;
    m.nearest = true;
    EXPECT_DOUBLE_EQ(sample_alpha(t, m, {0.30, 0.5}), 1.0 / 3);
    m.wrap_s = TextureWrap::repeat;
    EXPECT_DOUBLE_EQ(sample_alpha(t, m, {1.30, 0.5}), 1.0 / 3);
    EXPECT_DOUBLE_EQ(sample_alpha(t, m, {-0.10, 0.5}), 1.0);  // texel -1 wraps to 3
    m.wrap_s = TextureWrap::mirrored_repeat;
    EXPECT_DOUBLE_EQ(sample_alpha(t, m, {-0.10, 0.5}), 0.0);  // texel -1 mirrors to 0
    EXPECT_DOUBLE_EQ(sample_alpha(t, m, {1.10, 0.5}), 1.0);   // texel 4 mirrors to 3
    m.wrap_s = TextureWrap::clamp_to_edge;
    EXPECT_DOUBLE_EQ(sample_alpha(t, m, {7.0, 0.5}), 1.0);
    m.nearest = false;  // halfway between texel centres 1 and 2
    EXPECT_NEAR(sample_alpha(t, m, {0.5, 0.5}), 0.5, 1e-12);
    m.factor_alpha = 0.5;
    EXPECT_NEAR(coverage_at(m, &t, {0.5, 0.5}, 0.8), 0.2, 1e-12);
    EXPECT_FALSE(judge_coverage(m, &t, {0.5, 0.5}, 0.8, 1e-6).opaque);
    m.cutoff = 0.2;
    EXPECT_TRUE(judge_coverage(m, &t, {0.5, 0.5}, 0.8, 1e-6).ambiguous);  // on the contour itself
    // A coverage exactly at the cutoff is opaque (glTF 2.0, 3.9.4: alpha >= alphaCutoff), and
    // said to lie on the contour.
    CutoutMaterial flat;
    flat.factor_alpha = 0.5;
    flat.cutoff = 0.5;
    const CoverageAnswer on_cutoff = judge_coverage(flat, nullptr, {0.3, 0.3}, 1.0, 1e-6);
    EXPECT_TRUE(on_cutoff.opaque);
    EXPECT_TRUE(on_cutoff.ambiguous);
    flat.factor_alpha = std::nextafter(0.5, 0.0);
    EXPECT_FALSE(judge_coverage(flat, nullptr, {0.3, 0.3}, 1.0, 1e-6).opaque);
    // offset (0.25, 0), rotation 90 degrees, scale (2, 1): uv (0.1, 0) -> scale (0.2, 0) -> rotate
    // (0, 0.2) -> offset (0.25, 0.2).
    m = CutoutMaterial{};
    m.texture = 0;
    m.nearest = true;
    const glm::dmat3 translation(1, 0, 0, 0, 1, 0, 0.25, 0, 1), rotation(0, 1, 0, -1, 0, 0, 0, 0, 1),
        scale(2, 0, 0, 0, 1, 0, 0, 0, 1);
    m.uv_transform = translation * rotation * scale;
    EXPECT_DOUBLE_EQ(sample_alpha(t, m, {0.1, 0.0}), 1.0 / 3);  // u 0.25 -> texel 1
}

}  // namespace
}  // namespace penumbra
