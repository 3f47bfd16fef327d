// The engine bias keys (issue 38; docs/raster.md, "Bias as engines apply it") on planes where
// the answer is analytic. A plane y = 0 under a sun at theta from its normal self-shadows
// without bias: within a texel of side h the receiver's depth along the ray strays from the
// depth stored at the texel's centre by up to h/2 (|n.u| + |n.v|) / cos(theta), u and v the
// map's axes, and |n.u| + |n.v| lies in [sin(theta), sqrt(2) sin(theta)] whatever the axes' turn
// about the ray (lookup_rules_test.cpp, TexelSlope). An offset that raises the receiver d above
// its plane, or lowers the stored plane by d, lifts the receiver d / cos(theta) along the ray:
// every acne pixel clears once d > h sin(theta) / sqrt(2), and some remain while d < h sin(theta) / 2.
#include <gtest/gtest.h>

#include <cmath>

#include "raster/raster.h"
#include "tests/raster/validated_render.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

using test::render;
using test::with_validation;

// A plane under a sun `theta_deg` from its normal, in the x-y plane, its z extent chosen so that
// its box in light space is square and so are the texels.
Scenario tilted_sun_plane(double theta_deg) {
    const double e = (90.0 - theta_deg) * M_PI / 180.0, half_z = 10.0 * std::sin(e);
    test::SceneBuilder b;
    b.quad({-10, 0, -half_z}, {-10, 0, half_z}, {10, 0, half_z}, {10, 0, -half_z});
    return test::make_scenario(b.build(), test::look_at({0, 8, 8}, {0, 0, 0}, 50),
                               {test::directional({std::cos(e), -std::sin(e), 0})}, 320, 240);
}

// The no-bias technique on a 1024 d32 map, single tap, with `bias` over it.
nlohmann::json no_bias(const nlohmann::json& bias, bool reversed_z = false) {
    return {{"preset", "no-bias"},          {"resolution", 1024},
            {"fit", "scene_bounds"},        {"depth_format", "d32"},
            {"filter", {{"type", "none"}}}, {"bias", bias.is_null() ? nlohmann::json::object() : bias},
            {"reversed_z", reversed_z}};
}

// Fraction of the lit-side surface pixels the technique darkens: all of it acne on a lone plane.
double dark_fraction(const raster::RasterResult& r) {
    const auto& lk = *r.frame.lights[0].lookups;
    std::size_t surface = 0, dark = 0;
    for (std::size_t i = 0; i < r.frame.pixel_count(); ++i) {
        if (lk.flags[i] != kRasterSurface) continue;
        ++surface;
        dark += r.frame.lights[0].V[i] < 1.0f;
    }
    return surface == 0 ? 1.0 : static_cast<double>(dark) / static_cast<double>(surface);
}

// The texel side h at the plane (every lookup has the same under a sun without cascades).
double texel_of(const raster::RasterResult& r) {
    const auto& lk = *r.frame.lights[0].lookups;
    for (std::size_t i = 0; i < r.frame.pixel_count(); ++i)
        if (lk.flags[i] == kRasterSurface) return lk.footprint_m[i];
    return 0.0;
}

constexpr double kClean = 1e-3;  // at most this fraction dark: acne gone
constexpr double kAcne = 0.01;   // at least this fraction dark: acne left

TEST(EngineBias, ReceiverNormalOffsetTimesItsFactorCuresAcneBeyondTheThreshold) {
    // theta = 30 degrees: acne clears for an effective d > 0.354 h and stays below 0.25 h.
    raster::VulkanContext ctx(with_validation());
    const Scenario sc = tilted_sun_plane(30.0);
    const raster::RasterResult bare = render(sc, no_bias(nullptr), ctx);
    ASSERT_GT(dark_fraction(bare), 0.2);  // the premise: raw acne
    const double h = texel_of(bare);
    ASSERT_GT(h, 0.0);
    auto dark = [&](const nlohmann::json& bias) { return dark_fraction(render(sc, no_bias(bias), ctx)); };
    // normal_offset_m alone: 0.45 h clears.
    EXPECT_LT(dark({{"normal_offset_m", 0.45 * h}}), kClean);
    // sin(theta) = 0.5 halves it to 0.225 h: acne; 0.75 h becomes 0.375 h: clean.
    EXPECT_GT(dark({{"normal_offset_m", 0.45 * h}, {"normal_factor", "sin"}}), kAcne);
    EXPECT_LT(dark({{"normal_offset_m", 0.75 * h}, {"normal_factor", "sin"}}), kClean);
    // 1 - cos(theta) = 0.134: 1.5 h becomes 0.20 h (acne), 3 h becomes 0.40 h (clean).
    EXPECT_GT(dark({{"normal_offset_m", 1.5 * h}, {"normal_factor", "one_minus_ndotl"}}), kAcne);
    EXPECT_LT(dark({{"normal_offset_m", 3.0 * h}, {"normal_factor", "one_minus_ndotl"}}), kClean);
    // The factor multiplies the texel normal offset too.
    EXPECT_LT(dark({{"normal_offset", 0.45}}), kClean);
    EXPECT_GT(dark({{"normal_offset", 0.45}, {"normal_factor", "sin"}}), kAcne);
    // normal_perpendicular drops the offset's part along L: n - L cos(theta) raises the receiver
    // by d sin^2(theta) = 0.1125 h for d = 0.45 h: acne again.
    EXPECT_GT(dark({{"normal_offset_m", 0.45 * h}, {"normal_perpendicular", true}}), kAcne);
    EXPECT_LT(dark({{"normal_offset_m", 2.0 * h}, {"normal_perpendicular", true}}), kClean);
    EXPECT_TRUE(ctx.validation_messages().empty()) << ctx.validation_messages().size() << " validation messages";
}

// At an oblique sun each factor has its exact value: the bias reach grows by the metres times
// sin(theta), 1 - cos(theta) or 1, on every pixel of the plane (theta = 60 degrees here).
TEST(EngineBias, NormalFactorsTakeTheirExactValueAtAnObliqueSun) {
    raster::VulkanContext ctx(with_validation());
    const double theta = 60.0 * M_PI / 180.0;
    const Scenario sc = tilted_sun_plane(60.0);
    const raster::RasterResult base = render(sc, no_bias(nullptr), ctx);
    const DepthMapLookups& b = *base.frame.lights[0].lookups;
    const std::vector<std::pair<const char*, double>> factors = {
        {"none", 1.0}, {"sin", std::sin(theta)}, {"one_minus_ndotl", 1.0 - std::cos(theta)}};
    for (const auto& [factor, value] : factors) {
        const raster::RasterResult r = render(sc, no_bias({{"normal_offset_m", 0.1}, {"normal_factor", factor}}), ctx);
        const DepthMapLookups& lk = *r.frame.lights[0].lookups;
        std::size_t checked = 0;
        for (std::size_t i = 0; i < r.frame.pixel_count(); ++i) {
            if (lk.flags[i] != kRasterSurface || b.flags[i] != kRasterSurface) continue;
            ASSERT_NEAR(lk.bias_m[i] - b.bias_m[i], 0.1 * value, 1e-5) << factor << ", pixel " << i;
            ++checked;
        }
        EXPECT_GT(checked, 10000u) << factor;
    }
    EXPECT_TRUE(ctx.validation_messages().empty()) << ctx.validation_messages().size() << " validation messages";
}

TEST(EngineBias, WorldDepthRangeMovesTheReceiverByAFractionOfTheMapsDepthRange) {
    raster::VulkanContext ctx(with_validation());
    const Scenario sc = tilted_sun_plane(30.0);
    const raster::RasterResult bare = render(sc, no_bias(nullptr), ctx);
    const auto& lk = *bare.frame.lights[0].lookups;
    double range = 0;  // metres along the ray per depth unit: the orthographic map's far - near
    for (std::size_t i = 0; i < bare.frame.pixel_count() && range == 0; ++i)
        if (lk.flags[i] == kRasterSurface) range = lk.depth_to_m[i];
    ASSERT_GT(range, 0.0);
    const double h = texel_of(bare), cos_t = std::cos(M_PI / 6);
    // Along the ray by w raises the receiver w cos(theta) above the plane.
    const double clears = 0.45 * h / cos_t / range, too_little = 0.2 * h / cos_t / range;
    EXPECT_LT(dark_fraction(render(sc, no_bias({{"world_depth_range", clears}}), ctx)), kClean);
    EXPECT_GT(dark_fraction(render(sc, no_bias({{"world_depth_range", too_little}}), ctx)), kAcne);
}

TEST(EngineBias, CasterOffsetsInTexelsMatchTheSameInMetresAndTheReceiversOffset) {
    raster::VulkanContext ctx(with_validation());
    const Scenario sc = tilted_sun_plane(30.0);
    const raster::RasterResult bare = render(sc, no_bias(nullptr), ctx);
    const double h = texel_of(bare), k = 0.6;  // k h cos(theta) = 0.52 h lowers the stored plane past 0.354 h
    auto v_of = [&](const nlohmann::json& bias) { return render(sc, no_bias(bias), ctx); };
    const raster::RasterResult texels = v_of({{"caster", {{"world_texels", k}}}});
    const raster::RasterResult metres = v_of({{"caster", {{"world", k * h}}}});
    const raster::RasterResult receiver = v_of({{"world", k * h}});
    EXPECT_LT(dark_fraction(texels), kClean);
    EXPECT_LT(dark_fraction(metres), kClean);
    // Half as much leaves acne: the texels are counted as texels, not ignored or doubled.
    EXPECT_GT(dark_fraction(v_of({{"caster", {{"world_texels", 0.2}}}})), kAcne);
    std::size_t differ = 0, differ_receiver = 0, surface = 0;
    for (std::size_t i = 0; i < bare.frame.pixel_count(); ++i) {
        if (bare.frame.lights[0].lookups->flags[i] != kRasterSurface) continue;
        ++surface;
        differ += texels.frame.lights[0].V[i] != metres.frame.lights[0].V[i];
        differ_receiver += texels.frame.lights[0].V[i] != receiver.frame.lights[0].V[i];
    }
    EXPECT_LT(static_cast<double>(differ), 1e-3 * static_cast<double>(surface));
    EXPECT_LT(static_cast<double>(differ_receiver), 1e-3 * static_cast<double>(surface));
    // Caster normal offsets (inward, -N) with their own factor: 0.45 texels clear, and sin(theta)
    // halves them to acne.
    EXPECT_LT(dark_fraction(v_of({{"caster", {{"normal_texels", 0.45}}}})), kClean);
    EXPECT_GT(dark_fraction(v_of({{"caster", {{"normal_texels", 0.45}, {"normal_factor", "sin"}}}})), kAcne);
    EXPECT_LT(dark_fraction(v_of({{"caster", {{"normal", 0.45 * h}}}})), kClean);
    // caster.depth: stored depth + depth units; half a texel's depth change (at most
    // h tan(theta) / sqrt(2) metres) over the metres per depth unit clears.
    const auto& lk = *bare.frame.lights[0].lookups;
    double range = 0;
    for (std::size_t i = 0; i < bare.frame.pixel_count() && range == 0; ++i)
        if (lk.flags[i] == kRasterSurface) range = lk.depth_to_m[i];
    const double half_texel = h * std::tan(M_PI / 6) / std::sqrt(2.0) / range;
    EXPECT_LT(dark_fraction(v_of({{"caster", {{"depth", 1.5 * half_texel}}}})), kClean);
    EXPECT_GT(dark_fraction(v_of({{"caster", {{"depth", 0.4 * half_texel}}}})), kAcne);
    EXPECT_TRUE(ctx.validation_messages().empty()) << ctx.validation_messages().size() << " validation messages";
}

// A plane under a sun straight down, with a box giving the map metres of depth.
Scenario plane_under_the_sun() {
    test::SceneBuilder b;
    b.quad({-10, 0, -10}, {-10, 0, 10}, {10, 0, 10}, {10, 0, -10});
    b.box({6, 0, -9}, {8, 5, -7});
    return test::make_scenario(b.build(), test::look_at({0, 8, 8}, {0, 0, 0}, 50), {test::directional({0, -1, 0})}, 320,
                               240);
}

TEST(EngineBias, BiasReachGrowsByExactlyTheConfiguredMetres) {
    // Normal incidence: N.L = 1, so sin(theta) = 0 and the normal offsets' factor "none" is 1.
    raster::VulkanContext ctx(with_validation());
    const Scenario sc = plane_under_the_sun();
    const raster::RasterResult base = render(sc, no_bias(nullptr), ctx);
    const DepthMapLookups& b = *base.frame.lights[0].lookups;
    struct Case {
        nlohmann::json bias;
        double metres, texels, depth_units;  // expected growth: metres + texels h + depth_units (m per depth unit)
    };
    const std::vector<Case> cases = {
        {{{"normal_offset_m", 0.03}}, 0.03, 0, 0},
        {{{"normal_offset_m", 0.5}, {"normal_factor", "sin"}}, 0, 0, 0},
        {{{"normal_offset", 2}, {"normal_offset_m", 0.01}, {"normal_factor", "one_minus_ndotl"}}, 0, 0, 0},
        {{{"world_depth_range", 0.001}}, 0, 0, 0.001},
        {{{"caster", {{"world", 0.02}}}}, 0.02, 0, 0},
        {{{"caster", {{"world_texels", 1.5}}}}, 0, 1.5, 0},
        {{{"caster", {{"normal", 0.01}}}}, 0.01, 0, 0},
        {{{"caster", {{"normal_texels", 2}}}}, 0, 2, 0},
        {{{"caster", {{"normal", 0.01}, {"normal_factor", "sin"}}}}, 0, 0, 0},
        {{{"caster", {{"depth", 1e-4}}}}, 0, 0, 1e-4},
    };
    for (const Case& c : cases) {
        const raster::RasterResult r = render(sc, no_bias(c.bias), ctx);
        const DepthMapLookups& lk = *r.frame.lights[0].lookups;
        std::size_t checked = 0;
        for (std::size_t i = 0; i < r.frame.pixel_count(); ++i) {
            if (lk.flags[i] != kRasterSurface || b.flags[i] != kRasterSurface) continue;
            if (!(b.ref_depth[i] > 0.5f)) continue;  // the plane, not the box's top
            const double expected = c.metres + c.texels * b.footprint_m[i] + c.depth_units * b.depth_to_m[i];
            ASSERT_NEAR(lk.bias_m[i] - b.bias_m[i], expected, 1e-5 * expected + 2e-6)
                << c.bias.dump() << ", pixel " << i;
            ++checked;
        }
        EXPECT_GT(checked, 50000u) << c.bias.dump();
    }
    // sin(theta) = 0 at normal incidence: the offset does nothing, verdicts included.
    const raster::RasterResult sin0 = render(sc, no_bias({{"normal_offset_m", 0.5}, {"normal_factor", "sin"}}), ctx);
    EXPECT_EQ(sin0.frame.lights[0].V, base.frame.lights[0].V);
    EXPECT_EQ(sin0.frame.lights[0].lookups->ref_depth, b.ref_depth);
    EXPECT_TRUE(ctx.validation_messages().empty()) << ctx.validation_messages().size() << " validation messages";
}

TEST(EngineBias, WorldDepthRangeUsesEachCascadesOwnDepthRange) {
    raster::VulkanContext ctx(with_validation());
    test::SceneBuilder b;
    b.quad({-40, 0, -40}, {-40, 0, 40}, {40, 0, 40}, {40, 0, -40});
    b.box({-1, 0, -1}, {1, 2, 1});
    const Scenario sc = test::make_scenario(b.build(), test::look_at({0, 3, 20}, {0, 0, -10}, 60),
                                            {test::directional({0.3, -1, 0.2})}, 320, 240);
    const nlohmann::json base_t = {
        {"family", "cascaded"}, {"cascades", {{"max_distance", 60}}}, {"bias", {{"constant", 0}, {"slope", 0}}}};
    nlohmann::json with_t = base_t;
    with_t["bias"]["world_depth_range"] = 0.002;
    const raster::RasterResult base = render(sc, base_t, ctx), with = render(sc, with_t, ctx);
    const DepthMapLookups &lb = *base.frame.lights[0].lookups, &lw = *with.frame.lights[0].lookups;
    std::vector<double> range_of_layer(8, 0.0);
    std::size_t checked = 0;
    for (std::size_t i = 0; i < base.frame.pixel_count(); ++i) {
        if (lb.flags[i] != kRasterSurface || lw.flags[i] != kRasterSurface || lb.layer[i] != lw.layer[i]) continue;
        // The layer the lookup used is the one its range came from (no pixel moves across a split
        // by millimetres often enough to matter; those that do are skipped above).
        const double expected = 0.002 * lb.depth_to_m[i];
        // depth_to_m is the lookup's finite-difference estimate of the range: 1e-3 of it.
        ASSERT_NEAR(lw.bias_m[i] - lb.bias_m[i], expected, 1e-3 * expected + 2e-6) << "pixel " << i;
        range_of_layer.at(lb.layer[i]) = lb.depth_to_m[i];
        ++checked;
    }
    EXPECT_GT(checked, 20000u);
    // The premise: cascades with different depth ranges were seen.
    double lo = 1e300, hi = 0;
    for (double r : range_of_layer) {
        if (r <= 0) continue;
        lo = std::min(lo, r);
        hi = std::max(hi, r);
    }
    // (29.5 m to 120 m on lavapipe.)
    EXPECT_GT(hi, 1.05 * lo) << "one depth range for every cascade seen: " << lo << " m";
}

TEST(EngineBias, ReversedZGivesTheForwardVerdictsAndDepthsOnANearOriginScene) {
    // Reversed Z stores 1 - z (clear 0, GREATER), compares greater-or-equal and flips the
    // hardware bias; the lookups report depths converted back. Near the origin a d32 map holds
    // both conventions to float precision, so the verdicts agree but for rounding.
    raster::VulkanContext ctx(with_validation());
    test::SceneBuilder b;
    b.quad({-10, 0, -10}, {-10, 0, 10}, {10, 0, 10}, {10, 0, -10});
    b.box({-2, 0, -2}, {2, 3, 2});
    const double e = 50.0 * M_PI / 180.0;
    const Scenario sc = test::make_scenario(b.build(), test::look_at({0, 8, 12}, {0, 0, 0}, 50),
                                            {test::directional({std::cos(e), -std::sin(e), 0.3})}, 320, 240);
    for (const char* filter : {"none", "hw2x2", "pcf"}) {
        nlohmann::json t = {{"resolution", 1024}, {"depth_format", "d32"}, {"filter", {{"type", filter}}}};
        const raster::RasterResult fwd = render(sc, t, ctx);
        t["reversed_z"] = true;
        const raster::RasterResult rev = render(sc, t, ctx);
        const DepthMapLookups &lf = *fwd.frame.lights[0].lookups, &lr = *rev.frame.lights[0].lookups;
        std::size_t surface = 0, differ = 0, shadowed = 0;
        for (std::size_t i = 0; i < fwd.frame.pixel_count(); ++i) {
            if (lf.flags[i] != kRasterSurface) continue;
            ++surface;
            shadowed += fwd.frame.lights[0].V[i] < 0.5f;
            differ += std::abs(fwd.frame.lights[0].V[i] - rev.frame.lights[0].V[i]) > 0.01f;
            ASSERT_NEAR(lr.ref_depth[i], lf.ref_depth[i], 1e-5f) << filter << ", pixel " << i;
            if (std::isfinite(lf.stored_depth[i])) {
                ASSERT_NEAR(lr.stored_depth[i], lf.stored_depth[i], 1e-5f) << filter << ", pixel " << i;
            }
        }
        ASSERT_GT(surface, 50000u);
        EXPECT_GT(shadowed, surface / 20) << "the premise: the box shadows the plane";
        EXPECT_LT(static_cast<double>(differ), 0.005 * static_cast<double>(surface)) << filter;
    }
    EXPECT_TRUE(ctx.validation_messages().empty()) << ctx.validation_messages().size() << " validation messages";
}

TEST(EngineBias, MomentFamiliesDrawTheirMapsWithTheCasterOffsets) {
    // The moment families gather their moments from the depth map the depth_map family draws,
    // so they draw it with the caster offsets: caster.depth -0.3 moves the stored plane 0.3
    // depth units towards the light (the plane lies at the map's far end: +0.3 would clamp).
    raster::VulkanContext ctx(with_validation());
    const Scenario sc = plane_under_the_sun();
    const nlohmann::json vsm = {{"family", "vsm"}, {"resolution", 512}};
    nlohmann::json moved = vsm;
    moved["bias"] = {{"caster", {{"depth", -0.3}}}};
    const raster::RasterResult a = render(sc, vsm, ctx), c = render(sc, moved, ctx);
    const DepthMapLookups &la = *a.frame.lights[0].lookups, &lc = *c.frame.lights[0].lookups;
    std::size_t moved_by_it = 0;
    for (std::size_t i = 0; i < a.frame.pixel_count(); ++i)
        moved_by_it += la.flags[i] == kRasterSurface && la.ref_depth[i] > 0.5f &&
                       std::abs(lc.stored_depth[i] - (la.stored_depth[i] - 0.3f)) < 1e-4f;
    EXPECT_GT(moved_by_it, 50000u);
}

}  // namespace
}  // namespace penumbra
