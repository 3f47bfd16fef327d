// Cascaded shadow maps (issue #34): split placement against closed forms, the "cascades" keys'
// errors, the fit's texel snapping, and the layer each pixel's lookup used.
#include "raster/cascades.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "common/errors.h"
#include "raster/light_projection.h"
#include "raster/raster.h"
#include "raster/raster_output.h"
#include "raster/technique_family.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

using raster::Cascades;
using raster::CascadeSplit;
using ::testing::HasSubstr;

Cascades with(CascadeSplit split, int count) {
    Cascades c;
    c.split = split;
    c.count = count;
    return c;
}

TEST(CascadeSplits, MatchTheirClosedForms) {
    const double n = 0.1, f = 300;
    const int c = 4;
    const std::vector<double> uniform = raster::cascade_far_bounds(with(CascadeSplit::uniform, c), n, f);
    const std::vector<double> log = raster::cascade_far_bounds(with(CascadeSplit::log, c), n, f);
    Cascades practical = with(CascadeSplit::practical, c);
    practical.lambda = 0.7;
    const std::vector<double> mixed = raster::cascade_far_bounds(practical, n, f);
    ASSERT_EQ(uniform.size(), 4u);
    const double r = std::pow(f / n, 1.0 / c);  // seed 001's z-partition ratio
    for (int i = 1; i <= c; ++i) {
        const double u = n + (f - n) * i / c, l = n * std::pow(r, i);
        EXPECT_NEAR(uniform[i - 1], u, 1e-9 * f) << i;
        EXPECT_NEAR(log[i - 1], l, 1e-9 * f) << i;
        EXPECT_NEAR(mixed[i - 1], 0.7 * l + 0.3 * u, 1e-9 * f) << i;
        if (i > 1) {
            EXPECT_NEAR(log[i - 1] / log[i - 2], r, 1e-9) << i;  // a constant ratio
        }
    }
    EXPECT_DOUBLE_EQ(log.back(), f);
    // Zhang's practical split lies between the two.
    for (int i = 0; i < c - 1; ++i) EXPECT_TRUE(log[i] < mixed[i] && mixed[i] < uniform[i]) << i;
}

TEST(CascadeSplits, GeometricStartsAtFirstFarAndFractionsScaleMaxDistance) {
    // bevy's default: 4 cascades, first far bound 10 m, 150 m in all.
    Cascades g = with(CascadeSplit::geometric, 4);
    g.first_far = 10;
    const std::vector<double> b = raster::cascade_far_bounds(g, 0.1, 150);
    const double r = std::pow(15.0, 1.0 / 3);
    ASSERT_EQ(b.size(), 4u);
    EXPECT_DOUBLE_EQ(b[0], 10);
    EXPECT_NEAR(b[1], 10 * r, 1e-9);
    EXPECT_NEAR(b[2], 10 * r * r, 1e-9);
    EXPECT_DOUBLE_EQ(b[3], 150);
    // Godot's 0.1/0.2/0.5 of 100 m.
    Cascades fr = with(CascadeSplit::fractions, 4);
    fr.fractions = {0.1, 0.2, 0.5};
    EXPECT_THAT(raster::cascade_far_bounds(fr, 0.05, 100), ::testing::ElementsAre(10, 20, 50, 100));
    EXPECT_THAT(raster::cascade_far_bounds(with(CascadeSplit::log, 1), 0.1, 80), ::testing::ElementsAre(80));
}

// SDSM: the scheme applied to the visible samples' depths [lo, hi] rather than [near, far].
TEST(CascadeSplits, SdsmAppliesTheSchemeBetweenTheVisibleDepths) {
    const double n = 0.1, f = 300, lo = 20, hi = 30;
    Cascades practical = with(CascadeSplit::practical, 4);
    practical.lambda = 0.6;
    const std::vector<double> p = raster::sdsm_far_bounds(practical, n, f, lo, hi);
    ASSERT_EQ(p.size(), 4u);
    for (int i = 1; i <= 4; ++i) {
        const double u = lo + (hi - lo) * i / 4, l = lo * std::pow(hi / lo, i / 4.0);
        EXPECT_NEAR(p[i - 1], 0.6 * l + 0.4 * u, 1e-9) << i;
    }
    EXPECT_THAT(raster::sdsm_far_bounds(with(CascadeSplit::uniform, 4), n, f, lo, hi),
                ::testing::ElementsAre(22.5, 25, 27.5, 30));
    // Fractions of the visible range; geometric's first_far keeps its place as a fraction of [n, f].
    Cascades fr = with(CascadeSplit::fractions, 3);
    fr.fractions = {0.1, 0.5};
    EXPECT_THAT(raster::sdsm_far_bounds(fr, n, f, lo, hi), ::testing::ElementsAre(21, 25, 30));
    Cascades g = with(CascadeSplit::geometric, 3);
    g.first_far = n + 0.1 * (f - n);
    const std::vector<double> gb = raster::sdsm_far_bounds(g, n, f, lo, hi);
    EXPECT_NEAR(gb[0], 21, 1e-9);
    EXPECT_NEAR(gb[1], std::sqrt(21.0 * 30), 1e-9);
    EXPECT_DOUBLE_EQ(gb[2], 30);
    // A range beyond the camera's is clamped to it; a single depth still gives increasing bounds.
    EXPECT_THAT(raster::sdsm_far_bounds(with(CascadeSplit::uniform, 2), n, f, 0.01, 500),
                ::testing::ElementsAre(n + (f - n) / 2, f));
    const std::vector<double> one = raster::sdsm_far_bounds(with(CascadeSplit::log, 2), n, f, 25, 25);
    EXPECT_GT(one[0], 25);
    EXPECT_GT(one[1], one[0]);
    EXPECT_LT(one[1], 25.001);
}

std::string error_of(const nlohmann::json& cascades) {
    try {
        raster::parse_technique({{"family", "cascaded"}, {"cascades", cascades}}, "s.json: technique");
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

TEST(CascadeKeys, ParseWithDefaultsAndWriteBack) {
    const raster::Technique t = raster::parse_technique({{"family", "cascaded"}}, "t");
    const Cascades* c = raster::cascades_of(t);
    ASSERT_NE(c, nullptr);
    EXPECT_EQ(c->count, 4);
    EXPECT_EQ(c->split, CascadeSplit::practical);
    EXPECT_EQ(c->lambda, 0.5);
    EXPECT_EQ(c->fit, raster::CascadeFit::sphere);
    EXPECT_TRUE(c->stabilize);
    EXPECT_FALSE(c->sdsm);
    EXPECT_FALSE(c->max_distance);
    EXPECT_EQ(raster::family_of(t).memory(t).directional_layers, 4);
    for (const nlohmann::json& j :
         {nlohmann::json{{"family", "cascaded"}},
          nlohmann::json{{"family", "cascaded"},
                         {"resolution", 1024},
                         {"cascades", {{"split", "geometric"}, {"first_far", 10}, {"max_distance", 150}}}},
          nlohmann::json{{"family", "cascaded"}, {"cascades", {{"fractions", {0.067, 0.2, 0.467}}}}},
          nlohmann::json{{"family", "cascaded"},
                         {"cascades", {{"count", 2}, {"split", "fractions"}, {"fractions", {0.3, 1}}}}}}) {
        const raster::Technique a = raster::parse_technique(j, "t");
        const nlohmann::json written = a.to_json();
        EXPECT_EQ(raster::parse_technique(written, "t").to_json(), written) << j.dump();
    }
    // Fractions imply the count and the split; a trailing 1 is the implied end.
    const raster::Technique u =
        raster::parse_technique({{"family", "cascaded"}, {"cascades", {{"fractions", {0.067, 0.2, 0.467}}}}}, "t");
    EXPECT_EQ(raster::cascades_of(u)->count, 4);
    EXPECT_EQ(raster::cascades_of(u)->split, CascadeSplit::fractions);
    EXPECT_EQ(raster::cascades_of(
                  raster::parse_technique({{"family", "cascaded"}, {"cascades", {{"fractions", {0.3, 1}}}}}, "t"))
                  ->count,
              2);
    // SDSM is a key like any other: read and written back.
    const raster::Technique sdsm =
        raster::parse_technique({{"family", "cascaded"}, {"cascades", {{"sdsm", true}}}}, "t");
    EXPECT_TRUE(raster::cascades_of(sdsm)->sdsm);
    EXPECT_EQ(sdsm.to_json().at("cascades").at("sdsm"), true);
    // [1] alone: one cascade to max_distance.
    const raster::Technique one =
        raster::parse_technique({{"family", "cascaded"}, {"cascades", {{"fractions", {1}}}}}, "t");
    EXPECT_EQ(raster::cascades_of(one)->count, 1);
    EXPECT_EQ(raster::parse_technique(one.to_json(), "t").to_json(), one.to_json());
}

TEST(CascadeKeys, BadValuesNameTheirKeyPath) {
    EXPECT_THAT(error_of({{"count", 0}}), HasSubstr("s.json: technique.cascades.count"));
    EXPECT_THAT(error_of({{"count", 9}}), HasSubstr("technique.cascades.count"));
    EXPECT_THAT(error_of({{"split", "pssm"}}), HasSubstr("technique.cascades.split: \"pssm\" is not one of"));
    EXPECT_THAT(error_of({{"lambda", 1.5}}), HasSubstr("technique.cascades.lambda"));
    EXPECT_THAT(error_of({{"fractions", {0.2, 0.1}}}),
                HasSubstr("technique.cascades.fractions: 0.1 is not increasing"));
    EXPECT_THAT(error_of({{"fractions", {0.2, 1.5}}}), HasSubstr("technique.cascades.fractions"));
    EXPECT_THAT(error_of({{"fractions", {0, 0.5}}}), HasSubstr("technique.cascades.fractions"));
    EXPECT_THAT(error_of({{"fractions", nlohmann::json::array()}}), HasSubstr("technique.cascades.fractions"));
    EXPECT_THAT(error_of({{"split", "fractions"}}), HasSubstr("technique.cascades.split: \"fractions\" needs"));
    EXPECT_THAT(error_of({{"count", 3}, {"fractions", {0.1, 0.2, 0.5}}}),
                HasSubstr("technique.cascades.fractions: 3 fractions end 4 cascades, but count is 3"));
    EXPECT_THAT(error_of({{"split", "log"}, {"fractions", {0.5}}}), HasSubstr("technique.cascades.fractions: only"));
    EXPECT_THAT(error_of({{"split", "log"}, {"fractions", {1}}}), HasSubstr("technique.cascades.fractions: only"));
    EXPECT_THAT(error_of({{"split", "geometric"}}),
                HasSubstr("technique.cascades.split: \"geometric\" needs first_far"));
    EXPECT_THAT(error_of({{"split", "geometric"}, {"first_far", 200}, {"max_distance", 150}}),
                HasSubstr("technique.cascades.first_far: 200 m is not less than max_distance 150 m"));
    EXPECT_THAT(error_of({{"first_far", 10}}), HasSubstr("technique.cascades.first_far: only"));
    EXPECT_THAT(error_of({{"max_distance", -1}}), HasSubstr("technique.cascades.max_distance"));
    EXPECT_THAT(error_of({{"overlap", 0.9}}), HasSubstr("technique.cascades.overlap"));
    EXPECT_THAT(error_of({{"fit", "box"}}), HasSubstr("technique.cascades.fit"));
    EXPECT_THAT(error_of({{"sdsm", 1}}), HasSubstr("technique.cascades.sdsm"));
    EXPECT_THAT(error_of({{"cascade", 4}}), HasSubstr("technique.cascades.cascade"));
    EXPECT_THAT(error_of(4), HasSubstr("technique.cascades"));
}

// A camera near the ground looking along it, a sun from the side and above.
Scenario long_view_scenario() {
    test::SceneBuilder b;
    b.grid({-40, 0, 0}, {80, 0, 0}, {0, 0, -300}, 4, 30);
    for (int k = 0; k < 14; ++k) {
        const double z = -4.0 - 20.0 * k, x = (k % 2 ? -1.0 : 1.0) * (2 + k % 5);
        b.box({x - 1, 0, z - 1}, {x + 1, 1.5 + 0.1 * k, z + 1});
    }
    Camera cam = test::look_at({0, 1.7, 2}, {0, 1.2, -60}, 50);
    cam.znear = 0.1;
    cam.zfar = 320;
    return test::make_scenario(b.build(), cam, {test::directional({0.5, -0.6, -0.3})}, 320, 200);
}

TEST(CascadeFit, StabilizedOriginsStayOnTheTexelGridAsTheCameraSlides) {
    const Scenario sc = long_view_scenario();
    Cascades c;
    c.max_distance = 200;
    const auto fit = [&](const Camera& cam) {
        return raster::fit_cascades(sc.lights[0], sc.scene, cam, sc.width, sc.height, c, 1024, cam.eye);
    };
    const raster::LightProjection a = fit(sc.camera);
    ASSERT_EQ(a.cascade_texel.size(), 4u);
    for (double fraction : {0.1, 0.37, 0.5}) {
        Camera moved = sc.camera;
        moved.eye += moved.right * (fraction * a.cascade_texel[2]);
        const raster::LightProjection b = fit(moved);
        for (std::size_t k = 0; k < 4; ++k) {
            const double texel = a.cascade_texel[k];
            EXPECT_DOUBLE_EQ(b.cascade_texel[k], texel) << k;  // the sphere's size does not move
            for (int axis = 0; axis < 2; ++axis) {
                const double on_grid = b.cascade_origin[k][axis] / texel;
                EXPECT_NEAR(on_grid, std::round(on_grid), 1e-6) << k << " " << axis;
                // and a sub-texel slide moves it by whole texels (0 or 1)
                const double step = (b.cascade_origin[k][axis] - a.cascade_origin[k][axis]) / texel;
                EXPECT_NEAR(step, std::round(step), 1e-6) << k;
                EXPECT_LE(std::abs(step), 1.0 + 1e-6) << k;
            }
        }
    }
    // Unstabilized, the same slide moves the origin by a fraction of a texel.
    c.stabilize = false;
    const raster::LightProjection loose = fit(sc.camera);
    Camera moved = sc.camera;
    moved.eye += moved.right * (0.37 * a.cascade_texel[2]);
    const raster::LightProjection loose_moved = fit(moved);
    const double step = (loose_moved.cascade_origin[2].x - loose.cascade_origin[2].x) / loose.cascade_texel[2];
    EXPECT_GT(std::abs(step - std::round(step)), 0.01);
}

TEST(CascadeFit, SlicesFollowTheSplitsAndTexelsGrowWithDepth) {
    const Scenario sc = long_view_scenario();
    Cascades c;
    c.split = CascadeSplit::fractions;
    c.fractions = {0.1, 0.2, 0.5};
    c.max_distance = 100;
    c.overlap = 0.2;
    const raster::LightProjection lp =
        raster::fit_cascades(sc.lights[0], sc.scene, sc.camera, sc.width, sc.height, c, 1024, sc.camera.eye);
    EXPECT_THAT(lp.cascade_far, ::testing::ElementsAre(10, 20, 50, 100));
    // bevy's overlap: each slice starts 20% before the previous one ends.
    EXPECT_THAT(lp.cascade_near, ::testing::ElementsAre(0.1, 8, 16, 40));
    for (std::size_t k = 1; k < 4; ++k) EXPECT_GT(lp.cascade_texel[k], lp.cascade_texel[k - 1]);
    const std::vector<raster::ShadowView> views = raster::shadow_views(lp);
    ASSERT_EQ(views.size(), 4u);
    EXPECT_EQ(views[3].kind, raster::ViewKind::cascade);
    EXPECT_DOUBLE_EQ(views[3].split_far, 100);
    EXPECT_DOUBLE_EQ(views[3].metres_per_texel, lp.cascade_texel[3]);
}

TEST(CascadeFit, AnInfiniteCameraNeedsMaxDistance) {
    Scenario sc = long_view_scenario();
    sc.camera.zfar = std::numeric_limits<double>::infinity();
    const Cascades c;
    try {
        raster::fit_cascades(sc.lights[0], sc.scene, sc.camera, sc.width, sc.height, c, 1024, sc.camera.eye);
        FAIL() << "no error";
    } catch (const InputError& e) {
        EXPECT_THAT(e.what(), HasSubstr("technique.cascades.max_distance: the camera's zfar is infinite"));
    }
}

// On the device: each pixel's layer is the cascade whose slice holds its view depth, so layers
// rise with depth, and the footprint the lookup records is that cascade's texel.
TEST(CascadeRender, TheLayerChannelNamesTheCascadeByViewDepth) {
    raster::ContextOptions o;
    o.validation = true;
    raster::VulkanContext ctx(o);
    const Scenario sc = long_view_scenario();
    const raster::RasterResult r =
        raster::run_raster(sc,
                           raster::parse_technique({{"family", "cascaded"},
                                                    {"resolution", 512},
                                                    {"cascades", {{"split", "practical"}, {"max_distance", 200}}}},
                                                   "t"),
                           ctx);
    EXPECT_TRUE(ctx.validation_messages().empty()) << ctx.validation_messages().front();
    ASSERT_EQ(r.stats.lights.size(), 1u);
    const raster::RasterLightStats& ls = r.stats.lights[0];
    ASSERT_EQ(ls.views.size(), 4u);
    EXPECT_EQ(ls.layers_rendered, 4);
    const DepthMapLookups& lk = *r.frame.lights[0].lookups;
    std::array<std::size_t, 5> per_layer{};
    for (std::size_t i = 0; i < r.frame.pixel_count(); ++i) {
        if (r.frame.A[i] == 0 || (lk.flags[i] & kRasterBackFacing)) continue;
        const std::uint32_t layer = lk.layer[i];
        ASSERT_LE(layer, 4u);
        ++per_layer[layer];
        if (layer == 4) continue;  // beyond max_distance
        EXPECT_FLOAT_EQ(lk.footprint_m[i], static_cast<float>(ls.views[layer].metres_per_texel)) << i;
    }
    for (std::size_t k = 0; k < 4; ++k) EXPECT_GT(per_layer[k], 0u) << k;
    // Down the image's centre column the ground recedes: the cascade never goes back.
    const int x = sc.width / 2;
    std::uint32_t previous = 0;
    int seen = 0;
    for (int y = sc.height - 1; y >= 0; --y) {
        const std::size_t i = static_cast<std::size_t>(y) * sc.width + x;
        if (r.frame.A[i] == 0 || r.frame.prim[i] >= 30u * 4 * 2) continue;  // the ground grid only
        EXPECT_GE(lk.layer[i], previous) << "row " << y;
        previous = lk.layer[i];
        ++seen;
    }
    EXPECT_GT(seen, 50);
    EXPECT_GE(previous, 3u);

    // world_float32 fits the cascades in world space and rounds their matrices: same cascades.
    const raster::RasterResult w = raster::run_raster(sc,
                                                      raster::parse_technique({{"family", "cascaded"},
                                                                               {"resolution", 512},
                                                                               {"precision", "world_float32"},
                                                                               {"cascades", {{"max_distance", 200}}}},
                                                                              "t"),
                                                      ctx);
    const DepthMapLookups& wl = *w.frame.lights[0].lookups;
    std::size_t same = 0, surface = 0;
    for (std::size_t i = 0; i < r.frame.pixel_count(); ++i) {
        if (r.frame.A[i] == 0) continue;
        ++surface;
        same += wl.layer[i] == lk.layer[i];
    }
    EXPECT_GE(same, surface * 995 / 1000);
}

// A wall tilted away from a camera whose range is [0.1, 300] m: the camera sees depths of about
// 21 to 29 m alone. Boxes stand out of it towards the camera, under a sun from behind the camera.
Scenario wall_scenario() {
    test::SceneBuilder b;
    // The plane z = -20 - (y + 15) 10/33: its bottom edge 20 m away, its top 30 m.
    const auto wall_z = [](double y) { return -20 - (y + 15) * 10.0 / 33; };
    b.quad({-30, -15, wall_z(-15)}, {30, -15, wall_z(-15)}, {30, 18, wall_z(18)}, {-30, 18, wall_z(18)});
    for (double y : {-8.0, -3.0, 2.0, 7.0})
        for (double x : {-6.0, 0.0, 6.0}) b.box({x - 0.5, y - 0.5, wall_z(y)}, {x + 0.5, y + 0.5, wall_z(y) + 1.5});
    Camera cam = test::look_at({0, 0, 0}, {0, 0, -25}, 50);
    cam.znear = 0.1;
    cam.zfar = 300;
    return test::make_scenario(b.build(), cam, {test::directional({0.4, -0.3, -0.87})}, 320, 200);
}

// SDSM on the device: the reduction finds the wall's depths, the splits lie between them (not
// between the camera's 0.1 and 300 m), raster.json says so, and the reduction pass is timed.
TEST(CascadeRender, SdsmSplitsLieWithinTheDepthsTheCameraSees) {
    raster::ContextOptions o;
    o.validation = true;
    raster::VulkanContext ctx(o);
    const Scenario sc = wall_scenario();
    raster::RasterSession session(sc, ctx);
    const auto technique = [](bool sdsm) {
        return raster::parse_technique(
            {{"family", "cascaded"}, {"resolution", 512}, {"cascades", {{"split", "practical"}, {"sdsm", sdsm}}}}, "t");
    };
    const raster::RasterResult r = session.render(technique(true));
    EXPECT_TRUE(ctx.validation_messages().empty()) << ctx.validation_messages().front();
    const raster::RasterLightStats& ls = r.stats.lights[0];
    ASSERT_TRUE(ls.projection.sdsm_range.has_value());
    const glm::dvec2 range = *ls.projection.sdsm_range;
    // The visible depths, on the CPU: every surface pixel's view depth lies in the range.
    EXPECT_GT(range.x, 20.0);
    EXPECT_LT(range.x, 23.0);
    EXPECT_GT(range.y, 27.0);
    EXPECT_LT(range.y, 30.0);
    ASSERT_EQ(ls.views.size(), 4u);
    EXPECT_DOUBLE_EQ(ls.views[0].split_near, range.x);
    EXPECT_DOUBLE_EQ(ls.views[3].split_far, range.y);
    for (const raster::ShadowView& v : ls.views) {
        EXPECT_GE(v.split_near, 20.0);
        EXPECT_LE(v.split_far, 30.0);
    }
    // Every surface pixel is judged by one of the cascades (none fell beyond the last).
    const DepthMapLookups& lk = *r.frame.lights[0].lookups;
    std::array<std::size_t, 5> per_layer{};
    for (std::size_t i = 0; i < r.frame.pixel_count(); ++i)
        if (r.frame.A[i] != 0 && !(lk.flags[i] & kRasterBackFacing)) ++per_layer[std::min(lk.layer[i], 4u)];
    for (std::size_t k = 0; k < 4; ++k) EXPECT_GT(per_layer[k], 500u) << k;
    EXPECT_EQ(per_layer[4], 0u);
    // The reduction is a timed pass of its own, in raster.json with what it includes.
    EXPECT_TRUE(std::any_of(r.stats.gpu_ms.entries.begin(), r.stats.gpu_ms.entries.end(),
                            [](const auto& e) { return e.first == "sdsm_reduce"; }));
    EXPECT_THAT(std::string(r.stats.gpu_ms.what("sdsm_reduce")), HasSubstr("Lauritzen"));
    const nlohmann::json j = raster::raster_json(sc, technique(true), r, {});
    EXPECT_TRUE(j.at("gpu_ms").contains("sdsm_reduce"));
    EXPECT_DOUBLE_EQ(j.at("lights")[0].at("sdsm").at("near_m").get<double>(), range.x);
    EXPECT_DOUBLE_EQ(j.at("lights")[0].at("sdsm").at("far_m").get<double>(), range.y);

    // Without SDSM: the camera's range, no reduction pass, no sdsm key.
    const raster::RasterResult plain = session.render(technique(false));
    const raster::RasterLightStats& pl = plain.stats.lights[0];
    EXPECT_FALSE(pl.projection.sdsm_range.has_value());
    EXPECT_DOUBLE_EQ(pl.views[0].split_near, 0.1);
    EXPECT_DOUBLE_EQ(pl.views[3].split_far, 300);
    EXPECT_TRUE(std::none_of(plain.stats.gpu_ms.entries.begin(), plain.stats.gpu_ms.entries.end(),
                             [](const auto& e) { return e.first == "sdsm_reduce"; }));
    EXPECT_FALSE(raster::raster_json(sc, technique(false), plain, {}).at("lights")[0].contains("sdsm"));
    // The texel of the cascade nearest the camera is finer with SDSM.
    EXPECT_LT(ls.views[0].metres_per_texel, pl.views[0].metres_per_texel);
}

// cascades.texel_scaled_bias (engines' per-cascade bias): the world and constant biases are the
// first cascade's, scaled by each cascade's texel; without it every cascade gets the same.
// bias_m, the lookups' bias as metres along the light ray, shows which each pixel got.
TEST(CascadeRender, TexelScaledBiasGrowsWithEachCascadesTexel) {
    raster::ContextOptions o;
    o.validation = true;
    raster::VulkanContext ctx(o);
    const Scenario sc = long_view_scenario();
    raster::RasterSession session(sc, ctx);
    const auto median_bias_per_layer = [&](const nlohmann::json& bias, bool scaled) {
        const raster::RasterResult r = session.render(
            raster::parse_technique({{"family", "cascaded"},
                                     {"resolution", 512},
                                     {"depth_format", "d16"},
                                     {"bias", bias},
                                     {"cascades", {{"max_distance", 200}, {"texel_scaled_bias", scaled}}}},
                                    "t"));
        EXPECT_TRUE(ctx.validation_messages().empty()) << ctx.validation_messages().front();
        const DepthMapLookups& lk = *r.frame.lights[0].lookups;
        std::array<std::vector<float>, 4> per_layer;
        for (std::size_t i = 0; i < r.frame.pixel_count(); ++i)
            if (r.frame.A[i] != 0 && !(lk.flags[i] & (kRasterBackFacing | kRasterOutsideMap)) && lk.layer[i] < 4)
                per_layer[lk.layer[i]].push_back(lk.bias_m[i]);
        std::array<double, 4> median{};
        for (std::size_t k = 0; k < 4; ++k) {
            EXPECT_GT(per_layer[k].size(), 100u) << k;
            std::nth_element(per_layer[k].begin(), per_layer[k].begin() + per_layer[k].size() / 2, per_layer[k].end());
            median[k] = per_layer[k][per_layer[k].size() / 2];
        }
        return std::make_pair(median, r.stats.lights[0].projection);
    };
    const nlohmann::json world = {{"constant", 0}, {"slope", 0}, {"world", 0.05}};
    const auto [scaled, lp] = median_bias_per_layer(world, true);
    const auto [same, unused] = median_bias_per_layer(world, false);
    for (std::size_t k = 0; k < 4; ++k) {
        const double ratio = lp.cascade_texel[k] / lp.cascade_texel[0];
        EXPECT_NEAR(scaled[k], 0.05 * ratio, 1e-4 * ratio) << k;
        EXPECT_NEAR(same[k], 0.05, 1e-4) << k;
    }
    EXPECT_GT(lp.cascade_texel[3], 2 * lp.cascade_texel[0]);
    // The hardware constant (d16: r = 2^-16 everywhere) in metres, per texel: the same in every
    // cascade when scaled; without, it follows each cascade's depth range instead.
    const nlohmann::json constant = {{"constant", 8}, {"slope", 0}};
    const auto [c_scaled, c_lp] = median_bias_per_layer(constant, true);
    const double per_texel = c_scaled[0] / c_lp.cascade_texel[0];
    const auto [c_same, c_same_lp] = median_bias_per_layer(constant, false);
    for (std::size_t k = 1; k < 4; ++k) {
        EXPECT_NEAR(c_scaled[k] / c_lp.cascade_texel[k], per_texel, 0.02 * per_texel) << k;
        const double range = c_same_lp.cascade_depth_range[k] / c_same_lp.cascade_depth_range[0];
        EXPECT_NEAR(c_same[k], c_same[0] * range, 0.02 * c_same[k]) << k;
    }
    EXPECT_STREQ(raster::cascade_bias_scaling(raster::parse_technique({{"family", "cascaded"}}, "t"), "bias.world"),
                 "same");
    EXPECT_STREQ(raster::cascade_bias_scaling(raster::parse_technique({{"family", "cascaded"}}, "t"), "bias.slope"),
                 "texel_scaled");
    EXPECT_STREQ(raster::cascade_bias_scaling(raster::parse_technique(nlohmann::json::object(), "t"), "bias.world"),
                 "");
}

}  // namespace
}  // namespace penumbra
