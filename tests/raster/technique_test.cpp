// The technique contract and the light fits: pure code, no Vulkan.
#include "raster/technique.h"

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <glm/mat4x4.hpp>
#include <string>
#include <vector>

#include "common/errors.h"
#include "raster/light_projection.h"
#include "tests/raster/technique_errors.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

using raster::parse_technique;
using ::testing::HasSubstr;

std::string error_of(const nlohmann::json& j) {
    return test::technique_error(j);
}

TEST(Technique, DefaultsAreDocumented) {
    raster::Technique t = parse_technique(nlohmann::json::object(), "s.json: technique");
    EXPECT_EQ(t.resolution, 2048);
    EXPECT_EQ(t.depth_format, raster::DepthFormat::d32);
    EXPECT_EQ(t.fit, raster::Fit::scene_bounds);
    EXPECT_EQ(t.cull, raster::Cull::back);
    EXPECT_EQ(t.filter.type, raster::FilterType::none);
    // What a careful engine ships (Filament's polygon offset), not no bias (issue 31).
    EXPECT_EQ(t.bias.constant, 0.5);
    EXPECT_EQ(t.bias.slope, 2.0);
    EXPECT_EQ(t.bias.normal_offset, 0.0);
    // The bias-free setup stays available as a preset: every bias key zero.
    const raster::Bias none = parse_technique({{"preset", "no-bias"}}, "s.json: technique").bias;
    EXPECT_EQ(none.constant, 0.0);
    EXPECT_EQ(none.slope, 0.0);
    EXPECT_EQ(none.clamp, 0.0);
    EXPECT_EQ(none.world, 0.0);
    EXPECT_EQ(none.normal_offset, 0.0);
    EXPECT_EQ(none.shader_depth, 0.0);
    EXPECT_FALSE(none.receiver_plane);
}

TEST(Technique, ErrorsNameTheKeyPath) {
    EXPECT_THAT(error_of({{"bias", {{"slope", "x"}}}}), HasSubstr("s.json: technique.bias.slope"));
    EXPECT_THAT(error_of({{"filter", {{"type", "gaussian"}}}}), HasSubstr("technique.filter.type"));
    EXPECT_THAT(error_of({{"filter", {{"type", "gaussian"}}}}), HasSubstr("\"poisson\""));
    EXPECT_THAT(error_of({{"resolution", 100000}}), HasSubstr("technique.resolution"));
    EXPECT_THAT(error_of({{"bias", {{"wrold", 1}}}}), HasSubstr("technique.bias.wrold: unknown key"));
    // A family's key without its family names the family to add (#53).
    EXPECT_THAT(error_of({{"cascades", {{"count", 4}}}}),
                HasSubstr("technique.cascades: a key of the \"cascaded\" family, not of \"depth_map\": add \"family\": "
                          "\"cascaded\" (or --set family=cascaded)"));
    EXPECT_THAT(error_of({{"preset", "nope"}}), HasSubstr("d3d12-textbook"));
    EXPECT_EQ(error_of({{"filter", {{"type", "pcss"}}}}), "");
    EXPECT_THAT(error_of({{"filter", {{"type", "pcss"}, {"max_radius_texels", 0.5}}}}),
                HasSubstr("technique.filter.max_radius_texels"));
    EXPECT_THAT(error_of({{"area_samples", -1}}), HasSubstr("technique.area_samples"));
    EXPECT_THAT(error_of({{"shadow_distance", 20.0}}), HasSubstr("technique.shadow_distance: only the camera_frustum"));
    EXPECT_THAT(error_of({{"fit", "camera_frustum"}, {"shadow_distance", -1.0}}),
                HasSubstr("technique.shadow_distance"));
    // Culling by material: the side of single-sided materials only with it, back or front.
    EXPECT_EQ(error_of({{"cull", "material"}, {"single_sided_cull", "front"}}), "");
    // A preset's side outlives `--set cull=back` (sweeps vary cull over presets); it means nothing then.
    EXPECT_EQ(error_of({{"preset", "three"}, {"cull", "back"}}), "");
    EXPECT_THAT(error_of({{"cull", "material"}, {"single_sided_cull", "none"}}),
                HasSubstr("technique.single_sided_cull"));
    EXPECT_THAT(error_of({{"cull", "material"}, {"depth_layer", "second"}}), HasSubstr("technique.cull"));
}

TEST(Technique, BlendRulesParseAndRoundTrip) {
    using raster::Blend;
    using raster::Technique;
    EXPECT_EQ(parse_technique(nlohmann::json::object(), "t").blend, Blend::opaque);
    EXPECT_FALSE(parse_technique(nlohmann::json::object(), "t").to_json().contains("blend"));  // written only when set
    const Technique none = parse_technique({{"blend", "none"}}, "t");
    EXPECT_EQ(none.blend, Blend::none);
    EXPECT_EQ(parse_technique(none.to_json(), "t").blend, Blend::none);
    const Technique cutout = parse_technique({{"blend", "cutout(0.3)"}}, "t");
    EXPECT_EQ(cutout.blend, Blend::cutout);
    EXPECT_DOUBLE_EQ(cutout.blend_cutoff, 0.3);
    EXPECT_EQ(cutout.to_json()["blend"], "cutout(0.3)");
    EXPECT_DOUBLE_EQ(parse_technique({{"blend", "cutout"}}, "t").blend_cutoff, 0.5);
    for (const char* bad : {"cutout(1.5)", "cutout(x)", "cutout(0.3", "glass"}) {
        SCOPED_TRACE(bad);
        try {
            parse_technique({{"blend", bad}}, "t");
            ADD_FAILURE() << "accepted";
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find("blend"), std::string::npos) << e.what();
        }
    }
}

TEST(Technique, CullByMaterialRoundTripsWithItsSingleSidedSide) {
    const raster::Technique t = parse_technique({{"cull", "material"}}, "x");
    EXPECT_EQ(t.cull, raster::Cull::material);
    EXPECT_EQ(t.single_sided_cull, raster::Cull::back);
    const nlohmann::json j = t.to_json();
    EXPECT_EQ(j.at("cull"), "material");
    EXPECT_EQ(j.at("single_sided_cull"), "back");
    EXPECT_EQ(parse_technique(j, "raster.json: technique").to_json(), j);
    // Other cullings write no single_sided_cull (their raster.json stays as it was).
    EXPECT_FALSE(parse_technique({{"cull", "back"}}, "x").to_json().contains("single_sided_cull"));
    const raster::Technique over = parse_technique({{"preset", "three"}, {"cull", "front"}}, "x");
    EXPECT_EQ(over.cull, raster::Cull::front);
    EXPECT_FALSE(over.to_json().contains("single_sided_cull"));
}

// Engines set bias per light: `lights[i].bias` overrides the technique's `bias` for light i,
// key by key; bad entries are refused naming their path, and to_json gives the same technique.
TEST(Technique, PerLightBiasOverridesTheSharedOneKeyByKey) {
    const nlohmann::json j = {
        {"preset", "d3d12-textbook"},
        {"lights", {{{"bias", {{"constant", 5}, {"receiver_plane", true}}}}, nlohmann::json::object()}}};
    const raster::Technique t = parse_technique(j, "s.json: technique");
    ASSERT_EQ(t.lights.size(), 2u);
    EXPECT_EQ(t.bias_for(0).constant, 5);
    EXPECT_EQ(t.bias_for(0).slope, 1.0);  // the preset's, not overridden
    EXPECT_TRUE(t.bias_for(0).receiver_plane);
    EXPECT_EQ(t.bias_for(1).constant, 100000);  // {}: the shared bias
    EXPECT_EQ(t.bias_for(7).constant, 100000);  // beyond the entries: the shared bias
    EXPECT_EQ(t.for_light(0).bias.constant, 5);
    EXPECT_TRUE(t.for_light(0).lights.empty());
    const raster::Technique back = parse_technique(t.to_json(), "round trip");
    EXPECT_EQ(back.lights, t.lights);
    EXPECT_EQ(back.to_json(), t.to_json());
    EXPECT_FALSE(parse_technique({{"resolution", 512}}, "t").to_json().contains("lights"));

    EXPECT_THAT(error_of({{"lights", {{{"bias", {{"slop", 1}}}}}}}),
                HasSubstr("s.json: technique.lights[0].bias.slop: unknown key"));
    EXPECT_THAT(error_of({{"lights", {nlohmann::json::object(), {{"shadow", 1}}}}}),
                HasSubstr("s.json: technique.lights[1].shadow: unknown key"));
    EXPECT_THAT(error_of({{"lights", {{{"bias", {{"constant", "x"}}}}}}}),
                HasSubstr("technique.lights[0].bias.constant"));
    EXPECT_THAT(error_of({{"lights", 3}}), HasSubstr("technique.lights: expected an array"));
    try {
        parse_technique({{"lights", {nlohmann::json::object(), nlohmann::json::object()}}}, "s.json: technique",
                        {test::directional({0, -1, 0})});
        ADD_FAILURE() << "two entries for one light were accepted";
    } catch (const InputError& e) {
        EXPECT_THAT(e.what(), HasSubstr("s.json: technique.lights: 2 entries, but the scenario has 1 light"));
    }
}

// PCSS sizes the penumbra by the light; a light without a size would divide 0 by 0
// (directional) or shrink the filter to one texel (spot, point): refused, naming both.
TEST(Technique, PcssIsRefusedForLightsWithoutASize) {
    auto named = [](Light l, int i) {
        l.origin = fmt::format("lights[{}]", i);
        return l;
    };
    const std::vector<Light> area = {named(test::rect({0, 5, 0}, {1, 0, 0}, {0, 0, 1}), 0),
                                     named(test::disk({0, 5, 0}, {0, -1, 0}, 0.5), 1),
                                     named(test::sphere({0, 5, 0}, 0.5), 2)};
    auto error_with = [](const nlohmann::json& j, const std::vector<Light>& lights, const std::string& label) {
        try {
            parse_technique(j, label, lights);
        } catch (const InputError& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    const nlohmann::json pcss = {{"filter", {{"type", "pcss"}}}};
    EXPECT_EQ(error_with(pcss, area, "s.json: technique"), "");
    EXPECT_EQ(error_with({{"preset", "averaged-hard-shadows"}}, area, "s.json: technique"), "");

    std::vector<Light> mixed = area;
    mixed.push_back(named(test::directional({0, -1, 0}), 3));
    EXPECT_EQ(error_with(pcss, mixed, "s.json: technique"),
              "s.json: technique.filter.type: \"pcss\" needs a light with a size; lights[3] is directional (only "
              "rect, disk and sphere lights have one, and directional lights with angular_diameter_deg > 0)");
    // A sun with a size has one: its angular radius.
    std::vector<Light> soft_sun = area;
    soft_sun.push_back(named(test::directional({0, -1, 0}), 3));
    soft_sun.back().angular_diameter_rad = 0.53 * M_PI / 180;
    EXPECT_EQ(error_with(pcss, soft_sun, "s.json: technique"), "");
    EXPECT_THAT(
        error_with({{"preset", "pcss"}}, {named(test::spot({0, 5, 0}, {0, -1, 0}, 30), 0)}, "s.json: technique"),
        HasSubstr("technique.filter.type: \"pcss\" (from preset \"pcss\") needs a light with a size; "
                  "lights[0] is spot"));
    // A technique file is its own root: the key path starts at filter.
    EXPECT_THAT(error_with(pcss, {named(test::point({0, 5, 0}), 0)}, "t.json"),
                HasSubstr("t.json: filter.type: \"pcss\" needs a light with a size; lights[0] is point"));
    // Other filters draw every light.
    EXPECT_EQ(error_with({{"filter", {{"type", "poisson"}}}}, mixed, "s.json: technique"), "");
}

TEST(Technique, FilterReachAndDepthResolutionForTheMetrics) {
    auto reach = [](const nlohmann::json& filter) {
        return raster::filter_reach_texels(parse_technique({{"filter", filter}}, "s.json: technique").filter);
    };
    EXPECT_EQ(reach({{"type", "none"}}), 1.0);
    EXPECT_EQ(reach({{"type", "hw2x2"}}), 1.0);
    EXPECT_EQ(reach({{"type", "pcf"}, {"size", 5}}), 2.5);
    EXPECT_EQ(reach({{"type", "pcf"}, {"size", 3}, {"bilinear_taps", true}}), 2.0);
    EXPECT_EQ(reach({{"type", "poisson"}, {"radius_texels", 3.0}}), 3.0);
    EXPECT_EQ(reach({{"type", "poisson"}, {"radius_texels", 0.25}}), 1.0);
    EXPECT_EQ(reach({{"type", "vogel"}, {"radius_texels", 1.0}, {"bilinear_taps", true}}), 1.5);
    EXPECT_EQ(raster::depth_resolution(raster::DepthFormat::d16), std::ldexp(1.0, -16));
    EXPECT_EQ(raster::depth_resolution(raster::DepthFormat::d32), 0.0);
}

TEST(Fits, ShadowDistanceShrinksTheCameraFrustumFit) {
    test::SceneBuilder b;
    b.quad({-50, 0, -50}, {-50, 0, 50}, {50, 0, 50}, {50, 0, -50});
    Scenario sc = test::make_scenario(b.build(), test::look_at({0, 3, 40}, {0, 0, 0}, 50),
                                      {test::directional({-0.3, -1, -0.2})}, 64, 48);
    auto extent = [&](double distance) {
        auto lp = raster::fit_light(sc.lights[0], sc.scene, sc.camera, 64, 48, raster::Fit::camera_frustum, 1024,
                                    sc.camera.eye, distance);
        return lp.metres_per_texel;
    };
    EXPECT_LT(extent(10.0), 0.5 * extent(0.0));  // finer texels over the nearer 10 m
    EXPECT_EQ(extent(1e6), extent(0.0));         // beyond the scene: no change
}

TEST(Technique, PresetsReproduceTheReferenceConfigurations) {
    raster::Technique t = parse_technique({{"preset", "d3d12-textbook"}}, "x");
    EXPECT_EQ(t.depth_format, raster::DepthFormat::d24);
    EXPECT_EQ(t.fit, raster::Fit::scene_sphere);
    EXPECT_EQ(t.bias.constant, 100000.0);
    EXPECT_EQ(t.bias.slope, 1.0);
    EXPECT_EQ(t.filter.type, raster::FilterType::pcf);
    EXPECT_EQ(t.filter.size, 3);
    EXPECT_TRUE(t.filter.bilinear_taps);
    EXPECT_EQ(t.resolution, 2048);

    t = parse_technique({{"preset", "diligent-tutorial13"}}, "x");
    EXPECT_EQ(t.fit, raster::Fit::scene_bounds);
    EXPECT_EQ(t.filter.type, raster::FilterType::hw2x2);

    t = parse_technique({{"preset", "camera-frustum-article"}}, "x");
    EXPECT_EQ(t.fit, raster::Fit::camera_frustum);
    EXPECT_EQ(t.resolution, 4096);
    EXPECT_GT(t.bias.shader_depth, 0.0);
    EXPECT_EQ(t.filter.type, raster::FilterType::none);

    // The user's keys win over the preset's; the rest of the preset stays.
    t = parse_technique({{"preset", "d3d12-textbook"}, {"bias", {{"slope", 2.5}}}}, "x");
    EXPECT_EQ(t.bias.slope, 2.5);
    EXPECT_EQ(t.bias.constant, 100000.0);
}

// The engines' presets (docs/engines.md): each parses, writes back what it read, and carries the
// values docs/engines.md cites.
TEST(Technique, EnginePresetsParseAndRoundTrip) {
    const std::vector<std::string> engines = {"bevy",      "godot",    "unity-urp", "unreal-csm", "three",
                                              "three-csm", "filament", "babylon",   "babylon-csm"};
    for (const std::string& name : engines) {
        SCOPED_TRACE(name);
        const raster::Technique t = parse_technique({{"preset", name}}, "s.json: technique");
        const nlohmann::json written = t.to_json();
        EXPECT_EQ(written.at("preset"), name);
        EXPECT_EQ(parse_technique(written, "raster.json: technique").to_json(), written);
    }
    raster::Technique t = parse_technique({{"preset", "three"}}, "x");
    EXPECT_EQ(t.resolution, 512);
    EXPECT_EQ(t.fit, raster::Fit::scene_sphere);
    // three.js's shadowSide: a FrontSide material's back faces, a DoubleSide one's both.
    EXPECT_EQ(t.depth_layer, raster::DepthLayer::first);
    EXPECT_EQ(t.cull, raster::Cull::material);
    EXPECT_EQ(t.single_sided_cull, raster::Cull::front);
    EXPECT_EQ(t.filter.type, raster::FilterType::vogel);
    EXPECT_EQ(t.filter.taps, 5);
    EXPECT_EQ(t.filter.radius_texels, 1.0);
    EXPECT_TRUE(t.filter.bilinear_taps);

    t = parse_technique({{"preset", "bevy"}}, "x");
    EXPECT_EQ(t.family, "cascaded");
    EXPECT_EQ(t.bias.world, 0.02);
    EXPECT_NEAR(t.bias.normal_offset, 1.8 * std::sqrt(2.0), 1e-12);

    t = parse_technique({{"preset", "filament"}}, "x");
    EXPECT_EQ(t.resolution, 1024);
    EXPECT_EQ(t.bias.constant, 0.5);
    EXPECT_EQ(t.bias.slope, 2.0);
    EXPECT_EQ(t.bias.world, 0.001);

    // The user's keys still win over an engine preset's.
    t = parse_technique({{"preset", "godot"}, {"resolution", 1024}}, "x");
    EXPECT_EQ(t.resolution, 1024);
    EXPECT_EQ(t.depth_format, raster::DepthFormat::d16);
}

TEST(Technique, VogelFilterParsesAndWritesItsKeys) {
    const raster::Technique t =
        parse_technique({{"filter", {{"type", "vogel"}, {"taps", 7}, {"radius_texels", 2.5}}}}, "s.json: technique");
    EXPECT_EQ(t.filter.type, raster::FilterType::vogel);
    const nlohmann::json f = t.to_json().at("filter");
    EXPECT_EQ(f.at("type"), "vogel");
    EXPECT_EQ(f.at("taps"), 7);
    EXPECT_EQ(f.at("radius_texels"), 2.5);
    EXPECT_THAT(error_of({{"filter", {{"type", "gaussian"}}}}), HasSubstr("\"vogel\""));
}

// The engine bias keys (issue 38): off by default, parsed with their key paths in errors, per
// light, through --set, and written back by to_json.
TEST(Technique, EngineBiasKeysParseValidateAndRoundTrip) {
    const raster::Technique d = parse_technique(nlohmann::json::object(), "s.json: technique");
    EXPECT_EQ(d.bias.normal_offset_m, 0.0);
    EXPECT_EQ(d.bias.normal_factor, raster::NormalFactor::none);
    EXPECT_FALSE(d.bias.normal_perpendicular);
    EXPECT_EQ(d.bias.world_depth_range, 0.0);
    EXPECT_EQ(d.bias.caster, raster::CasterBias{});
    EXPECT_FALSE(d.reversed_z);

    nlohmann::json j = {{"reversed_z", true},
                        {"bias",
                         {{"normal_offset_m", 0.02},
                          {"normal_factor", "sin"},
                          {"normal_perpendicular", true},
                          {"world_depth_range", 0.001},
                          {"caster", {{"world", 0.05}, {"normal_factor", "one_minus_ndotl"}, {"depth", 1e-4}}}}},
                        {"lights", {{{"bias", {{"caster", {{"normal_texels", 2}}}, {"normal_factor", "none"}}}}}}};
    raster::apply_override(j, "bias.caster.world_texels=1.5");
    raster::apply_override(j, "bias.caster.normal=0.01");
    const raster::Technique t = parse_technique(j, "s.json: technique");
    EXPECT_TRUE(t.reversed_z);
    EXPECT_EQ(t.bias.normal_offset_m, 0.02);
    EXPECT_EQ(t.bias.normal_factor, raster::NormalFactor::sin);
    EXPECT_TRUE(t.bias.normal_perpendicular);
    EXPECT_EQ(t.bias.world_depth_range, 0.001);
    EXPECT_EQ(t.bias.caster.world, 0.05);
    EXPECT_EQ(t.bias.caster.world_texels, 1.5);
    EXPECT_EQ(t.bias.caster.normal, 0.01);
    EXPECT_EQ(t.bias.caster.normal_texels, 0.0);
    EXPECT_EQ(t.bias.caster.normal_factor, raster::NormalFactor::one_minus_ndotl);
    EXPECT_EQ(t.bias.caster.depth, 1e-4);
    // Light 0's override wins key by key, the nested caster keys included.
    const raster::Bias b0 = t.bias_for(0);
    EXPECT_EQ(b0.caster.normal_texels, 2.0);
    EXPECT_EQ(b0.caster.world, 0.05);
    EXPECT_EQ(b0.normal_factor, raster::NormalFactor::none);
    EXPECT_EQ(b0.normal_offset_m, 0.02);
    const raster::Technique back = parse_technique(t.to_json(), "round trip");
    EXPECT_EQ(back.to_json(), t.to_json());
    EXPECT_EQ(back.lights, t.lights);
    EXPECT_EQ(t.to_json()["bias"]["caster"]["normal_factor"], "one_minus_ndotl");
    EXPECT_EQ(t.to_json()["reversed_z"], true);

    EXPECT_THAT(error_of({{"bias", {{"caster", {{"normal_factor", "cos"}}}}}}),
                HasSubstr("s.json: technique.bias.caster.normal_factor: \"cos\" is not one of \"none\", "
                          "\"one_minus_ndotl\", \"sin\""));
    EXPECT_THAT(error_of({{"bias", {{"normal_factor", 1}}}}), HasSubstr("technique.bias.normal_factor"));
    EXPECT_THAT(error_of({{"bias", {{"world_depth_range", -0.1}}}}), HasSubstr("technique.bias.world_depth_range"));
    EXPECT_THAT(error_of({{"bias", {{"caster", {{"wrold", 1}}}}}}),
                HasSubstr("technique.bias.caster.wrold: unknown key"));
    EXPECT_THAT(error_of({{"bias", {{"caster", 1}}}}), HasSubstr("technique.bias.caster"));
    EXPECT_THAT(error_of({{"bias", {{"caster", {{"depth", 2}}}}}}), HasSubstr("technique.bias.caster.depth"));
    EXPECT_THAT(error_of({{"reversed_z", "yes"}}), HasSubstr("technique.reversed_z"));
    // The midpoint pass peels forward depths: refused with reversed Z, not drawn wrong.
    EXPECT_THAT(error_of({{"reversed_z", true}, {"depth_layer", "midpoint"}}),
                HasSubstr("technique.reversed_z: depth_layer \"midpoint\" stores forward depth"));
    // Families without a depth map have no bias or reversed_z keys.
    EXPECT_THAT(error_of({{"family", "shadow_volume"}, {"reversed_z", true}}), HasSubstr("technique.reversed_z"));
    EXPECT_THAT(error_of({{"family", "planar_projection"}, {"bias", {{"caster", {{"world", 1}}}}}}),
                HasSubstr("technique.bias"));
    EXPECT_THAT(error_of({{"lights", {{{"bias", {{"caster", {{"normal_texels", "x"}}}}}}}}}),
                HasSubstr("technique.lights[0].bias.caster.normal_texels"));
}

TEST(Technique, OverridesSetOneKeyAndParseJsonValues) {
    nlohmann::json j = {{"bias", {{"slope", 1.0}}}};
    raster::apply_override(j, "bias.slope=1.5");
    raster::apply_override(j, "filter.type=pcf");
    raster::apply_override(j, "bias.receiver_plane=true");
    raster::Technique t = parse_technique(j, "x");
    EXPECT_EQ(t.bias.slope, 1.5);
    EXPECT_EQ(t.filter.type, raster::FilterType::pcf);
    EXPECT_TRUE(t.bias.receiver_plane);
    EXPECT_THROW(raster::apply_override(j, "noequals"), InputError);
    EXPECT_THROW(raster::apply_override(j, "bias..x=1"), InputError);
}

glm::dvec3 clip_of(const glm::dmat4& m, const glm::dvec3& p) {
    glm::dvec4 c = m * glm::dvec4(p, 1.0);
    return glm::dvec3(c) / c.w;
}

// Every fit must put every receiver it is meant to cover inside the map, wherever the scene is.
class Fits : public ::testing::TestWithParam<std::tuple<raster::Fit, double>> {};

TEST_P(Fits, ContainTheSceneInsideTheMap) {
    auto [fit, offset] = GetParam();
    test::SceneBuilder b;
    glm::dvec3 o(offset, 0, -offset);
    b.quad(o + glm::dvec3(-5, 0, -5), o + glm::dvec3(-5, 0, 5), o + glm::dvec3(5, 0, 5), o + glm::dvec3(5, 0, -5));
    b.box(o + glm::dvec3(-1, 0, -1), o + glm::dvec3(1, 2, 1));
    Scenario sc = test::make_scenario(b.build(), test::look_at(o + glm::dvec3(0, 12, 12), o, 60),
                                      {test::directional({-0.3, -1, -0.2})}, 64, 48);
    raster::LightProjection lp = raster::fit_light(sc.lights[0], sc.scene, sc.camera, 64, 48, fit, 1024, sc.camera.eye);
    ASSERT_EQ(lp.view_proj.size(), 1u);
    // The frustum fit covers what the camera sees, not the whole scene; its depth range
    // still starts at the scene's front so that every caster lands in the map.
    bool whole_scene = fit != raster::Fit::camera_frustum;
    for (const auto& p : sc.scene.positions) {
        glm::dvec3 c = clip_of(lp.view_proj[0], p - sc.camera.eye);
        if (whole_scene) {
            EXPECT_LE(std::abs(c.x), 1.0 + 1e-9);
            EXPECT_LE(std::abs(c.y), 1.0 + 1e-9);
            EXPECT_LE(c.z, 1.0 + 1e-9);
        }
        EXPECT_GE(c.z, -1e-9);
    }
    EXPECT_GT(lp.metres_per_texel, 0.0);
}

INSTANTIATE_TEST_SUITE_P(Raster, Fits,
                         ::testing::Combine(::testing::Values(raster::Fit::scene_sphere, raster::Fit::scene_bounds,
                                                              raster::Fit::camera_frustum),
                                            ::testing::Values(0.0, 1e6)));

TEST(Fits, CubeFacesSeeTheirOwnDirectionsWithExactNinetyDegreeFrusta) {
    test::SceneBuilder b;
    b.box({-3, -3, -3}, {3, 3, 3});
    Scenario sc =
        test::make_scenario(b.build(), test::look_at({0, 0, 10}, {0, 0, 0}, 40), {test::point({0, 0, 0})}, 16, 16);
    raster::LightProjection lp =
        raster::fit_light(sc.lights[0], sc.scene, sc.camera, 16, 16, raster::Fit::scene_bounds, 512, sc.camera.eye);
    ASSERT_EQ(lp.view_proj.size(), 6u);
    const glm::dvec3 dirs[6] = {{1, 0.3, -0.2}, {-1, 0.5, 0.9}, {0.2, 1, 0.1},
                                {0.9, -1, 0.9}, {0, 0.1, 1},    {0.2, 0.2, -1}};
    for (int f = 0; f < 6; ++f) {
        glm::dvec3 c = clip_of(lp.view_proj[f], dirs[f] * 2.0 - sc.camera.eye);
        EXPECT_LT(std::abs(c.x), 1.0) << "face " << f;
        EXPECT_LT(std::abs(c.y), 1.0) << "face " << f;
        EXPECT_GT(c.z, 0.0);
        EXPECT_LT(c.z, 1.0);
        // The face's corner direction lands exactly on the map corner.
        glm::dvec3 corner = clip_of(lp.view_proj[f], lp.axis[f] * 2.0 + glm::dvec3(1e-300) - sc.camera.eye);
        EXPECT_NEAR(corner.x, 0.0, 1e-9);
    }
}

// A perspective map clips by depth along its axis, which off axis is less than the distance to
// the box: a light beside the scene's box, off its edge, must still have the whole box inside
// every layer's depth range, and the near plane no closer than the box needs.
TEST(Fits, PerspectiveNearPlaneIsTheLeastDepthAlongEachAxis) {
    test::SceneBuilder b;
    b.quad({-5, 0, -5}, {-5, 0, 5}, {5, 0, 5}, {5, 0, -5});
    b.box({-1, 0, -1}, {1, 2, 1});
    b.box({3.5, 0, -1}, {5, 2, 1});  // the box's corner (5, 2) lies 2 m along -X, sqrt 5 m away
    const glm::dvec3 pos(7, 3, 0);
    for (const Light& light : {test::point(pos), test::spot(pos, {-1, -0.4, 0}, 50)}) {
        Scenario sc = test::make_scenario(b.build(), test::look_at({0, 8, 12}, {0, 0, 0}, 50), {light}, 16, 16);
        raster::LightProjection lp =
            raster::fit_light(light, sc.scene, sc.camera, 16, 16, raster::Fit::scene_bounds, 512, sc.camera.eye);
        const Bounds& box = sc.scene.bounds;
        double least = 1e300;
        constexpr int kSteps = 40;
        for (int i = 0; i <= kSteps; ++i)
            for (int j = 0; j <= kSteps; ++j)
                for (int k = 0; k <= kSteps; ++k) {
                    if (i % kSteps && j % kSteps && k % kSteps) continue;  // the box's surface only
                    const glm::dvec3 p = box.lo + (box.hi - box.lo) * glm::dvec3(i, j, k) / double(kSteps);
                    for (std::size_t f = 0; f < lp.view_proj.size(); ++f) {
                        const glm::dvec4 c = lp.view_proj[f] * glm::dvec4(p - sc.camera.eye, 1.0);
                        if (c.w <= 0 || std::abs(c.x) > c.w || std::abs(c.y) > c.w) continue;  // not in this layer
                        EXPECT_GE(c.z / c.w, -1e-9) << "layer " << f << " clips (" << p.x << ", " << p.y << ", " << p.z
                                                    << ") in front of its near plane " << lp.near;
                        EXPECT_LE(c.z / c.w, 1.0);
                        least = std::min(least, glm::dot(p - pos, lp.axis[f]));
                    }
                }
        EXPECT_LT(lp.near, std::sqrt(5.0));
        EXPECT_NEAR(lp.near, least, 1e-9) << "the near plane as far out as the box allows";
    }
}

}  // namespace
}  // namespace penumbra
