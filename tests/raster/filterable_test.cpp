// The filterable families (issue #35): their keys, their refusals, and the Chebyshev math of
// the lookup shader against hand-computed values.
#include "raster/filterable.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <glm/glm.hpp>
#include <memory>

#include "common/camera.h"
#include "common/errors.h"
#include "raster/raster.h"
#include "raster/raster_output.h"
#include "raster/technique_family.h"
#include "tests/raster/technique_errors.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

using raster::parse_technique;
using ::testing::HasSubstr;

std::string error_of(const nlohmann::json& j) {
    return test::technique_error(j);
}

TEST(Filterable, VsmKeysHaveTheirDefaultsAndNestUnderTheFamilysName) {
    const raster::Technique t = parse_technique({{"family", "vsm"}}, "s.json: technique");
    const raster::MomentParameters* p = raster::moment_parameters(t);
    ASSERT_NE(p, nullptr);
    EXPECT_EQ(p->kind, raster::MomentKind::vsm);
    EXPECT_EQ(p->blur, 0);
    EXPECT_DOUBLE_EQ(p->light_bleed, 0.15);  // Filament's lightBleedReduction
    EXPECT_EQ(t.bias.constant, 0.0);         // no hardware bias: the variance floor stands in for it
    const nlohmann::json j = t.to_json();
    EXPECT_EQ(j.at("vsm").at("light_bleed"), 0.15);
    EXPECT_EQ(j.at("blur"), 0);
    EXPECT_EQ(j.at("mipmaps"), false);

    nlohmann::json tech = {{"family", "vsm"}, {"vsm", {{"light_bleed", 0.3}}}, {"blur", 4}};
    raster::apply_override(tech, "vsm.min_variance=0.0001");
    const raster::Technique u = parse_technique(tech, "t");
    EXPECT_DOUBLE_EQ(raster::moment_parameters(u)->min_variance, 1e-4);
    EXPECT_DOUBLE_EQ(raster::moment_parameters(u)->light_bleed, 0.3);
    // The filter reaches the blur radius plus the bilinear tap's texel.
    EXPECT_DOUBLE_EQ(raster::family_of(u).hints(u).filter_reach_texels, 5.0);
    EXPECT_TRUE(raster::family_of(u).hints(u).light_bleeding);
    EXPECT_FALSE(raster::family_of(parse_technique(nlohmann::json::object(), "t"))
                     .hints(parse_technique(nlohmann::json::object(), "t"))
                     .light_bleeding);
}

TEST(Filterable, MsmKeysHaveThePapersDefaultsAndVariantIsSettable) {
    const raster::Technique t = parse_technique({{"family", "msm"}}, "t");
    const raster::MomentParameters* p = raster::moment_parameters(t);
    ASSERT_NE(p, nullptr);
    EXPECT_EQ(p->kind, raster::MomentKind::msm);
    EXPECT_EQ(p->variant, raster::MsmVariant::hamburger);
    EXPECT_EQ(p->storage_bits, 32);
    EXPECT_DOUBLE_EQ(p->moment_bias, 3e-5);
    EXPECT_DOUBLE_EQ(
        raster::moment_parameters(parse_technique({{"family", "msm"}, {"msm", {{"storage", 16}}}}, "t"))->moment_bias,
        6e-5);  // 16-bit storage rounds more: the larger bias
    EXPECT_TRUE(raster::family_of(t).hints(t).light_bleeding);
    EXPECT_EQ(t.to_json().at("msm"),
              nlohmann::json({{"variant", "hamburger"}, {"storage", 32}, {"moment_bias", 3e-5}}));

    nlohmann::json tech = {{"family", "msm"}, {"blur", 2}};
    raster::apply_override(tech, "msm.variant=hausdorff");
    raster::apply_override(tech, "msm.storage=16");
    const raster::Technique u = parse_technique(tech, "t");
    EXPECT_EQ(raster::moment_parameters(u)->variant, raster::MsmVariant::hausdorff);
    EXPECT_EQ(raster::moment_parameters(u)->storage_bits, 16);
    EXPECT_DOUBLE_EQ(raster::family_of(u).hints(u).filter_reach_texels, 3.0);

    EXPECT_THAT(error_of({{"family", "msm"}, {"msm", {{"variant", "stieltjes"}}}}),
                AllOf(HasSubstr("technique.msm.variant"), HasSubstr("hausdorff")));
    EXPECT_THAT(error_of({{"family", "msm"}, {"msm", {{"storage", 24}}}}), HasSubstr("technique.msm.storage"));
    EXPECT_THAT(error_of({{"family", "msm"}, {"msm", {{"moment_bias", -1}}}}), HasSubstr("technique.msm.moment_bias"));
    EXPECT_THAT(error_of({{"family", "msm"}, {"vsm", {{"light_bleed", 0.1}}}}), HasSubstr("vsm"));
}

TEST(Filterable, EveryFamilyWritesWhatItParses) {
    const std::vector<nlohmann::json> cases = {
        {{"family", "vsm"}, {"blur", 3}, {"vsm", {{"min_variance", 1e-5}, {"light_bleed", 0.2}}}},
        {{"family", "esm"}, {"esm", {{"exponent", 50}}}},
        {{"family", "evsm2"}, {"evsm", {{"exponents", {30, 4}}}}},
        {{"family", "evsm4"}, {"blur", 2}},
        {{"family", "msm"}, {"msm", {{"variant", "hausdorff"}, {"storage", 16}, {"moment_bias", 1e-4}}}},
    };
    for (const auto& j : cases) {
        const raster::Technique t = parse_technique(j, "t");
        const nlohmann::json written = t.to_json();
        EXPECT_EQ(parse_technique(written, "t").to_json(), written) << j.dump();
    }
    EXPECT_EQ(parse_technique({{"family", "evsm4"}}, "t").to_json().at("evsm").at("exponents"),
              nlohmann::json({40.0, 5.0}));  // TheRealMJP/Shadows' +40 / -5
}

TEST(Filterable, BadKeysAreInputErrorsNamingTheKeyPathAndTheReason) {
    EXPECT_THAT(error_of({{"family", "vsm"}, {"vsm", {{"light_bleed", 1.5}}}}),
                HasSubstr("s.json: technique.vsm.light_bleed"));
    EXPECT_THAT(error_of({{"family", "vsm"}, {"vsm", {{"bleed", 0.1}}}}), HasSubstr("bleed"));
    EXPECT_THAT(error_of({{"family", "vsm"}, {"esm", {{"exponent", 10}}}}), HasSubstr("esm"));
    EXPECT_THAT(error_of({{"family", "esm"}, {"esm", {{"exponent", 100}}}}),
                AllOf(HasSubstr("technique.esm.exponent"), HasSubstr("float32")));
    EXPECT_THAT(error_of({{"family", "evsm4"}, {"evsm", {{"exponents", {50, 5}}}}}),
                AllOf(HasSubstr("technique.evsm.exponents"), HasSubstr("42")));
    EXPECT_THAT(error_of({{"family", "evsm2"}, {"evsm", {{"exponents", {40}}}}}), HasSubstr("[positive, negative]"));
    EXPECT_THAT(error_of({{"family", "vsm"}, {"filter", {{"type", "pcf"}}}}),
                AllOf(HasSubstr("technique.filter"), HasSubstr("moments")));
    EXPECT_THAT(error_of({{"family", "vsm"}, {"blur", -1}}), HasSubstr("technique.blur"));
    EXPECT_THAT(error_of({{"family", "vsm"}, {"mipmaps", 1}}), HasSubstr("technique.mipmaps"));
    EXPECT_THAT(error_of({{"blur", 2}}), HasSubstr("blur"));  // not a depth-map key
}

// Two occluders in one filter footprint, half at each depth: the moments are their mean and
// mean square, and Chebyshev's bound for a receiver behind both is worked out by hand.
TEST(Filterable, ChebyshevBoundOfTwoDepthsMatchesTheHandComputedValue) {
    const double d1 = 0.2, d2 = 0.6, t = 0.7;
    const double m1 = 0.5 * (d1 + d2), m2 = 0.5 * (d1 * d1 + d2 * d2);  // mean 0.4, variance 0.04
    EXPECT_NEAR(raster::chebyshev_upper_bound(m1, m2, t, 0.0), 0.04 / (0.04 + 0.09), 1e-12);
    // A receiver at or in front of the mean is lit; the bound falls as it recedes.
    EXPECT_EQ(raster::chebyshev_upper_bound(m1, m2, 0.4, 0.0), 1.0);
    EXPECT_LT(raster::chebyshev_upper_bound(m1, m2, 0.9, 0.0), raster::chebyshev_upper_bound(m1, m2, t, 0.0));
    // That 0.31 is light bleeding: the receiver lies behind both occluders, truly in shadow.
    // The reduction linstep(0.35, 1, p) removes it, and keeps a fully lit receiver lit.
    EXPECT_EQ(raster::reduce_light_bleeding(0.04 / 0.13, 0.35), 0.0);
    EXPECT_EQ(raster::reduce_light_bleeding(1.0, 0.35), 1.0);
    EXPECT_NEAR(raster::reduce_light_bleeding(0.675, 0.35), 0.5, 1e-12);
    // One depth: zero variance, the floor decides how fast the receiver darkens behind it.
    EXPECT_NEAR(raster::chebyshev_upper_bound(0.5, 0.25, 0.51, 1e-4), 1e-4 / (1e-4 + 1e-4), 1e-9);
}

// A plate's straight edge over a flat ground, the sun straight down: in the light's view the
// ground and the plate are two constant depths, and for a receiver on the ground with a
// fraction a of plate texels in the filter footprint, Chebyshev's bound is exactly
// a(1-a) / (a(1-a) + a^2) = 1 - a: VSM's shadow across the blurred edge is the filtered lit
// fraction. a is worked out here from the texel centres on the plate's side of its projected
// edge, weighted by the separable Gaussian (sigma = radius / 2) convolved with the bilinear tap.
TEST(FilterableOnDevice, VsmAcrossABlurredEdgeIsTheFilteredLitFraction) {
    raster::ContextOptions co;
    co.validation = true;
    raster::VulkanContext ctx(co);
    test::SceneBuilder b;
    b.quad({-4, 0, -4}, {-4, 0, 4}, {4, 0, 4}, {4, 0, -4});        // the ground: triangles 0, 1
    b.quad({-4, 1, -4}, {-4, 1, 4}, {0.37, 1, 4}, {0.37, 1, -4});  // the plate, its edge at x = 0.37
    // Seen from the side, below the plate: the ground under its edge is in view.
    const Scenario sc = test::make_scenario(b.build(), test::look_at({3, 0.6, 0.3}, {0, 0, 0}, 50),
                                            {test::directional({0, -1, 0})}, 320, 240);
    const int blur = 3;
    const raster::Technique t =
        parse_technique({{"family", "vsm"}, {"resolution", 128}, {"blur", blur}, {"vsm", {{"light_bleed", 0.0}}}}, "t");
    const raster::RasterResult r = raster::run_raster(sc, t, ctx);
    const glm::dmat4 vp = r.stats.lights[0].projection.view_proj[0];
    const glm::dvec3 eye = sc.camera.eye;
    auto to_map = [&](glm::dvec3 world) {
        const glm::dvec4 c = vp * glm::dvec4(world - eye, 1.0);
        return (glm::dvec2(c) / c.w * 0.5 + 0.5) * 128.0;
    };
    // The plate's side of its edge, in the map: the sign of a 2D cross product.
    const glm::dvec2 e0 = to_map({0.37, 1, -4}), e1 = to_map({0.37, 1, 4});
    auto side = [&](glm::dvec2 q) { return (e1.x - e0.x) * (q.y - e0.y) - (e1.y - e0.y) * (q.x - e0.x); };
    const double plate_side = side(to_map({-1, 1, 0}));
    const double sigma = 0.5 * blur;
    auto g = [&](int k) { return std::abs(k) > blur ? 0.0 : std::exp(-0.5 * k * k / (sigma * sigma)); };
    double norm = 0;
    for (int k = -blur; k <= blur; ++k) norm += g(k);

    const glm::dvec2 plane = ndc_to_image_plane(sc.camera, sc.width, sc.height);
    int tested = 0, in_transition = 0, off = 0;
    double worst = 0;
    for (int y = 0; y < sc.height; ++y)
        for (int x = 0; x < sc.width; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * sc.width + x;
            if (r.frame.A[i] == 0 || r.frame.prim[i] > 1) continue;  // the ground only
            const glm::dvec2 ndc((x + 0.5) * 2.0 / sc.width - 1.0, 1.0 - (y + 0.5) * 2.0 / sc.height);
            const glm::dvec3 d = sc.camera.forward + ndc.x * plane.x * sc.camera.right + ndc.y * plane.y * sc.camera.up;
            const glm::dvec3 P = eye + d * (-eye.y / d.y);
            if (std::abs(P.z) > 2 || std::abs(P.x - 0.37) > 1) continue;
            const glm::dvec2 m = to_map(P);
            const glm::dvec2 st = m - 0.5, base = glm::floor(st), f = st - base;
            double a = 0;
            for (int j = -blur; j <= blur + 1; ++j)
                for (int k = -blur; k <= blur + 1; ++k) {
                    const double w =
                        ((1 - f.x) * g(k) + f.x * g(k - 1)) * ((1 - f.y) * g(j) + f.y * g(j - 1)) / (norm * norm);
                    const glm::dvec2 centre = base + glm::dvec2(k, j) + 0.5;
                    if (side(centre) * plate_side > 0) a += w;
                }
            const double err = std::abs(r.frame.lights[0].V[i] - (1.0 - a));
            ++tested;
            if (a > 0.05 && a < 0.95) ++in_transition;
            if (err > 0.01) ++off;
            worst = std::max(worst, err);
        }
    EXPECT_GT(tested, 2000);
    EXPECT_GT(in_transition, 200);  // the blurred edge is in view
    // Texel centres that fall on the edge line itself may go either way in the rasteriser.
    EXPECT_LE(off, tested / 50) << "worst " << worst << ", tested " << tested << ", in the transition "
                                << in_transition;
    EXPECT_TRUE(ctx.validation_messages().empty()) << ctx.validation_messages()[0];
}
// The moment families draw what an engine draws (docs/raster.md, "Filterable shadow maps"): a
// moments pass over the map, a separable blur of two passes when `blur` > 0, the mip chain with
// `mipmaps`, each timed under its name in gpu_ms (raster.json) and so counted in a production
// render's time (sweep's production_ms is gpu_ms.total()). A point light's moments cover the
// cube faces some receiver samples, as its depth passes do.
TEST(FilterableOnDevice, MomentBlurAndMipPassesAreTimedAndCountedInProductionTime) {
    raster::ContextOptions co;
    co.validation = true;
    raster::VulkanContext ctx(co);
    test::SceneBuilder b;
    b.quad({-4, 0, -4}, {-4, 0, 4}, {4, 0, 4}, {4, 0, -4});
    b.box({-0.5, 0, -0.5}, {0.5, 1, 0.5});
    const Scenario sc = test::make_scenario(b.build(), test::look_at({4, 4, 4}, {0, 0, 0}, 50),
                                            {test::directional({0.3, -1, 0.2}), test::point({1.5, 2.5, 1})}, 160, 120);
    raster::RasterSession session(sc, ctx);
    raster::RenderOptions production;
    production.lookups = false;
    production.reuse_maps = false;
    auto has = [](const raster::PassTimes& t, const char* name) {
        return std::any_of(t.entries.begin(), t.entries.end(), [&](const auto& e) { return e.first == name; });
    };
    for (const char* family : {"vsm", "esm", "evsm4", "msm"}) {
        const nlohmann::json tj = {{"family", family}, {"resolution", 256}, {"blur", 2}};
        const raster::Technique t = parse_technique(tj, "t");
        const raster::RasterResult r = session.render(t, production);
        for (const raster::RasterLightStats& ls : r.stats.lights) {
            EXPECT_GT(ls.gpu_ms["moments"], 0.0) << family;
            EXPECT_GT(ls.gpu_ms["blur"], 0.0) << family;
            EXPECT_FALSE(has(ls.gpu_ms, "mipmaps")) << family;
        }
        const raster::PassTimes& all = r.stats.gpu_ms;
        // The per-pass times of docs/raster.md's table ("Filterable shadow maps").
        std::printf("%s on %s: shadow %.3f moments %.3f blur %.3f lookup %.3f ms\n", family, ctx.info().name.c_str(),
                    all["shadow"], all["moments"], all["blur"], all["lookup"]);
        EXPECT_THAT(std::string(all.what("blur")), HasSubstr("separable Gaussian"));
        EXPECT_NEAR(all.total(), all["shadow"] + all["moments"] + all["blur"] + all["lookup"] + all["layer_mask"], 1e-9)
            << family;
        const nlohmann::json j = raster::raster_json(sc, t, session.render(t), {});
        EXPECT_TRUE(j.at("gpu_ms").contains("moments") && j.at("gpu_ms").contains("blur")) << family;
        EXPECT_EQ(j.at("lights")[0].at("moments").at("gathered_in_lookup"), false);
    }
    // No blur: no blur pass. Mip-mapped: the chain is a pass of its own.
    const raster::RasterResult sharp =
        session.render(parse_technique({{"family", "vsm"}, {"resolution", 256}}, "t"), production);
    EXPECT_GT(sharp.stats.gpu_ms["moments"], 0.0);
    EXPECT_FALSE(has(sharp.stats.gpu_ms, "blur"));
    const raster::RasterResult mipped = session.render(
        parse_technique({{"family", "msm"}, {"resolution", 256}, {"blur", 1}, {"mipmaps", true}}, "t"), production);
    EXPECT_GT(mipped.stats.gpu_ms["mipmaps"], 0.0);
    EXPECT_THAT(std::string(mipped.stats.gpu_ms.what("mipmaps")), HasSubstr("blit"));
    EXPECT_TRUE(ctx.validation_messages().empty()) << ctx.validation_messages()[0];
}

// Mip-mapped moments (docs/raster.md, "Filterable shadow maps"): the sun straight down through a
// grating of slats (0.125 m wide, 0.25 m apart, about three texels of the 256² map the fit
// gives) onto a long ground,
// seen from under the slats. Far away a pixel covers many slats: sampled bilinearly the shadow
// is a 0-or-1 moire; with the mip chain its LOD (the pixel's step across the map, from the
// camera geometry) averages the slats, and V comes close to the open fraction, 0.5, the
// pixel-averaged truth. Near the camera a pixel is smaller than a texel: LOD 0, the same V.
TEST(FilterableOnDevice, MipmappedMomentsSmoothAFarGratingAndLeaveNearReceiversAlone) {
    raster::ContextOptions co;
    co.validation = true;
    raster::VulkanContext ctx(co);
    test::SceneBuilder b;
    b.quad({-3, 0, 2}, {3, 0, 2}, {3, 0, -60}, {-3, 0, -60});  // the ground: triangles 0, 1
    for (double z = 2; z > -60; z -= 0.25) b.quad({-3, 1, z}, {-3, 1, z - 0.125}, {3, 1, z - 0.125}, {3, 1, z});
    const Scenario sc = test::make_scenario(b.build(), test::look_at({0, 0.9, 2}, {0, 0, -6}, 50),
                                            {test::directional({0, -1, 0})}, 160, 120);
    raster::RasterSession session(sc, ctx);
    auto render = [&](bool mipmaps) {
        // No culling: the slats face down, away from the sun.
        return session.render(parse_technique({{"family", "vsm"},
                                               {"resolution", 256},
                                               {"cull", "none"},
                                               {"mipmaps", mipmaps},
                                               {"vsm", {{"light_bleed", 0.0}}}},
                                              "t"));
    };
    const raster::RasterResult plain = render(false), mipped = render(true);
    double far_plain = 0, far_mipped = 0, near_change = 0;
    std::size_t far = 0, near = 0;
    const glm::dvec2 plane = ndc_to_image_plane(sc.camera, sc.width, sc.height);
    for (std::size_t i = 0; i < plain.frame.pixel_count(); ++i) {
        if (plain.frame.prim[i] > 1) continue;  // the ground only
        // The view depth of the ground seen through the pixel's centre.
        const int x = static_cast<int>(i % sc.width), y = static_cast<int>(i / sc.width);
        const glm::dvec2 ndc((x + 0.5) * 2.0 / sc.width - 1.0, 1.0 - (y + 0.5) * 2.0 / sc.height);
        const glm::dvec3 d = sc.camera.forward + ndc.x * plane.x * sc.camera.right + ndc.y * plane.y * sc.camera.up;
        const double depth = -sc.camera.eye.y / d.y;  // d's forward component is 1
        const double vp = plain.frame.lights[0].V[i], vm = mipped.frame.lights[0].V[i];
        if (depth > 12) {
            ++far;
            far_plain += std::abs(vp - 0.5);
            far_mipped += std::abs(vm - 0.5);
        } else if (depth < 1.8) {
            ++near;
            near_change = std::max(near_change, std::abs(vm - vp));
        }
    }
    ASSERT_GT(far, 250u);
    ASSERT_GT(near, 500u);
    far_plain /= static_cast<double>(far);
    far_mipped /= static_cast<double>(far);
    std::printf(
        "beyond 12 m (%zu pixels): mean |V - 0.5| %.3f bilinear, %.3f trilinear; within 1.8 m (%zu) the "
        "largest change %.2g\n",
        far, far_plain, far_mipped, near, near_change);
    EXPECT_GT(far_plain, 0.3) << "bilinear moments alias far away";
    EXPECT_LT(far_mipped, far_plain / 2) << "trilinear moments average the slats there: " << far_mipped << " against "
                                         << far_plain;
    EXPECT_LT(near_change, 1e-6) << "a near receiver samples level 0";
    EXPECT_TRUE(ctx.validation_messages().empty()) << ctx.validation_messages()[0];
}

// The four moments of a distribution of depths (depth, weight).
std::array<double, 4> moments_of(std::initializer_list<std::pair<double, double>> depths) {
    std::array<double, 4> b{};
    for (const auto& [d, w] : depths)
        for (int k = 0; k < 4; ++k) b[k] += w * std::pow(d, k + 1);
    return b;
}

// Two occluders at 0.2 and 0.6, half each: the receiver behind both is in full shadow, where
// Chebyshev's bound leaks 0.31 (the test above). Four moments pin both depths, so MSM's bound is
// sharp up to the moment bias; between them, the canonical three-point representation
// {0.2, z, 0.6} puts no weight on z, and the Hamburger bound there is worked out by hand:
// (z z3 - b1 (z + z3) + b2) / ((z3 - z2)(z - z2)) = (0.24 - 0.4 + 0.2) / (0.4 * 0.2) = 0.5.
TEST(Filterable, MsmBoundOfTwoDepthsMatchesTheHandComputedValues) {
    const std::array<double, 4> b = moments_of({{0.2, 0.5}, {0.6, 0.5}});
    for (raster::MsmVariant v : {raster::MsmVariant::hamburger, raster::MsmVariant::hausdorff}) {
        EXPECT_EQ(raster::msm_visibility(b, 0.1, raster::kMsmMomentBias32, v), 1.0) << to_string(v);
        EXPECT_NEAR(raster::msm_visibility(b, 0.4, raster::kMsmMomentBias32, v), 0.5, 1e-3) << to_string(v);
        EXPECT_LT(raster::msm_visibility(b, 0.7, raster::kMsmMomentBias32, v), 2e-3) << to_string(v);
    }
    // Half the footprint at 0.745, half at the far plane 1: a receiver at 0.76 sees half the
    // light. Hausdorff knows no depth lies beyond 1 and says so; Hamburger's bound leaks more.
    const std::array<double, 4> far = moments_of({{0.745, 0.5}, {1.0, 0.5}});
    EXPECT_NEAR(raster::msm_visibility(far, 0.76, raster::kMsmMomentBias32, raster::MsmVariant::hausdorff), 0.5, 1e-3);
    EXPECT_GT(raster::msm_visibility(far, 0.76, raster::kMsmMomentBias32, raster::MsmVariant::hamburger), 0.7);
    // At an exact tie with the four-point solution's free point the formula is 0/0: a number
    // in [0, 1] comes out, never NaN.
    const double tie = raster::msm_visibility(moments_of({{0.745, 0.75}, {1.0, 0.25}}), 0.745, raster::kMsmMomentBias32,
                                              raster::MsmVariant::hausdorff);
    EXPECT_TRUE(tie >= 0.0 && tie <= 1.0) << tie;
}

// Peters & Klein 2015's optimised quantisation: the matrix and its inverse as printed agree,
// and a depth's moments land in [0, 1]^4 (what 16-bit UNORM holds).
TEST(Filterable, MsmOptimisedQuantisationIsInvertibleAndFitsUnorm) {
    const std::array<double, 4> b = moments_of({{0.2, 0.3}, {0.6, 0.7}});
    const std::array<double, 4> back = raster::msm_unoptimise(raster::msm_optimise(b));
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(back[k], b[k], 1e-8) << k;
    for (double d = 0; d <= 1.0; d += 1.0 / 64) {
        const std::array<double, 4> q = raster::msm_optimise(moments_of({{d, 1.0}}));
        for (int k = 0; k < 4; ++k) {
            EXPECT_GE(q[k], -1e-6) << d;
            EXPECT_LE(q[k], 1 + 1e-6) << d;
        }
    }
    // 16 bits and back keeps the bound usable at the 16-bit moment bias.
    const std::array<double, 4> rounded = raster::msm_unoptimise(raster::round_to_unorm16(raster::msm_optimise(b)));
    EXPECT_LT(raster::msm_visibility(rounded, 0.7, raster::kMsmMomentBias16, raster::MsmVariant::hamburger), 0.02);
    EXPECT_EQ(raster::msm_visibility(rounded, 0.1, raster::kMsmMomentBias16, raster::MsmVariant::hamburger), 1.0);
}

// A plane under a 35 degree sun, nothing over it: every receiver is lit. Its depths spread over
// the filter's footprint, and without the moment bias four moments of a (nearly) single depth
// make a singular Hankel matrix, so float rounding darkens the plane: MSM's acne. The paper's
// bias lights it again (docs/raster.md, "Filterable shadow maps"); VSM needs none (t <= mean).
TEST(FilterableOnDevice, MsmOnAPlaneIsAcneWithoutItsMomentBiasAndLitWithIt) {
    raster::ContextOptions co;
    co.validation = true;
    raster::VulkanContext ctx(co);
    test::SceneBuilder b;
    b.quad({-10, 0, -10}, {-10, 0, 10}, {10, 0, 10}, {10, 0, -10});
    const double elev = 35.0 * M_PI / 180.0;
    const Scenario sc = test::make_scenario(b.build(), test::look_at({0, 8, 8}, {0, 0, 0}, 50),
                                            {test::directional({std::cos(elev), -std::sin(elev), 0.3})}, 320, 240);
    auto dark_fraction = [&](nlohmann::json technique) {
        technique["resolution"] = 256;
        technique["blur"] = 2;
        const raster::RasterResult r = raster::run_raster(sc, parse_technique(technique, "t"), ctx);
        std::size_t surface = 0, dark = 0;
        for (std::size_t i = 0; i < r.frame.pixel_count(); ++i) {
            if (r.frame.prim[i] == kNoPrimitive) continue;
            ++surface;
            dark += r.frame.lights[0].V[i] < 0.99f;
        }
        EXPECT_GT(surface, 50000u);
        return static_cast<double>(dark) / static_cast<double>(surface);
    };
    const nlohmann::json msm = {{"family", "msm"}};
    EXPECT_LT(dark_fraction(msm), 1e-3);  // 2e-4 on lavapipe
    EXPECT_LT(dark_fraction({{"family", "msm"}, {"msm", {{"storage", 16}}}}), 1e-3);
    EXPECT_GT(dark_fraction({{"family", "msm"}, {"msm", {{"moment_bias", 0.0}}}}), 0.05);  // 0.19 on lavapipe
    EXPECT_EQ(dark_fraction({{"family", "vsm"}}), 0.0);
    // The 16-bit path rounds: at a bias of 1e-5, plenty for float moments, it darkens far more
    // of the plane (0.0030 against 0.0006 on lavapipe): hence its larger default.
    auto at_1e5 = [&](int storage) {
        return dark_fraction({{"family", "msm"}, {"msm", {{"storage", storage}, {"moment_bias", 1e-5}}}});
    };
    EXPECT_GT(at_1e5(16), 2.5 * at_1e5(32));
    EXPECT_TRUE(ctx.validation_messages().empty()) << ctx.validation_messages()[0];
}

}  // namespace
}  // namespace penumbra
