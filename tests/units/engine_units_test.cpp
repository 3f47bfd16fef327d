// Engine units (engines/engine_units.h, docs/units.md): every pair of engines round-trips, the
// conversions match values worked out by hand from each engine's formula, and the maps' texel and
// depth range come from penumbra's own fit of a synthetic scene.
#include "engines/engine_units.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/errors.h"
#include "raster/technique.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

using engines::EngineBias;
using engines::MapContext;
using nlohmann::json;

constexpr double kPi = 3.14159265358979323846;

// A hand-made map: 1 cm texels, a 50 m depth range, 16-bit depth, receivers at 30 degrees.
MapContext hand_map() {
    MapContext c;
    c.texel_m = 0.01;
    c.depth_range_m = 50;
    c.metres_per_depth = 50;
    c.depth_r = std::ldexp(1.0, -16);
    c.angle_rad = 30 * kPi / 180;
    return c;
}

EngineBias bias(const std::string& engine, const std::vector<std::string>& kv) {
    return engines::parse_engine_bias(engine, kv, "test");
}

double value(const EngineBias& b, const char* key) {
    return b.values.at(key).get<double>();
}

// Each engine with both free parameters away from 0 (three's and Babylon's defaults have a zero).
EngineBias sample(const std::string& engine) {
    if (engine == "three") return bias(engine, {"bias=-0.0004", "normalBias=0.02"});
    if (engine == "babylon") return bias(engine, {"bias=0.0003", "normalBias=0.015"});
    if (engine == "penumbra")
        return bias(engine, {"world=0.01", "normal_offset=1.5", "constant=3", "slope=1.5", "caster.normal=0.01",
                             "caster.normal_factor=sin", "shader_depth=0.0001"});
    return engines::engine_defaults(engine);
}

bool close(double a, double b, double rel = 1e-6) {
    return std::abs(a - b) <= rel * std::max(std::abs(a), std::abs(b)) + 1e-15;
}

TEST(EngineUnits, BevyNormalBiasIsTexelsTimesSqrtTwoInPenumbraKeys) {
    const json k =
        engines::penumbra_keys(bias("bevy", {"shadow_depth_bias=0.02", "shadow_normal_bias=1.8"}), hand_map());
    EXPECT_NEAR(k.at("normal_offset").get<double>(), 1.8 * std::sqrt(2.0), 1e-12);
    EXPECT_EQ(k.at("normal_factor"), "none");
    EXPECT_NEAR(k.at("world").get<double>(), 0.02, 1e-15);
    // bevy draws no hardware bias: the technique's default (0.5, 2.0) must not stay.
    EXPECT_EQ(k.at("constant").get<double>(), 0.0);
    EXPECT_EQ(k.at("slope").get<double>(), 0.0);
}

TEST(EngineUnits, ThreeBiasIsNormalisedDepthOfTheMapsRange) {
    // three's bias b moves the receiver's depth by b of near..far: -0.0004 of 50 m is 2 cm towards the light.
    const EngineBias b = engines::convert(bias("three", {"bias=-0.0004"}), "bevy", hand_map());
    EXPECT_NEAR(value(b, "shadow_depth_bias"), 0.0004 * 50, 1e-12);
    EXPECT_NEAR(value(b, "shadow_normal_bias"), 0.0, 1e-15);
    const EngineBias t =
        engines::convert(bias("bevy", {"shadow_depth_bias=0.02", "shadow_normal_bias=1.8"}), "three", hand_map());
    EXPECT_NEAR(value(t, "bias"), -0.02 / 50, 1e-15);
    // Neither has an angular factor: 1.8 sqrt(2) texels of 1 cm, at any angle.
    EXPECT_NEAR(value(t, "normalBias"), 1.8 * std::sqrt(2.0) * 0.01, 1e-12);
    EXPECT_EQ(engines::penumbra_keys(bias("three", {"bias=-0.0004"}), hand_map()).at("shader_depth"), 0.0004);
}

TEST(EngineUnits, GodotDividesByTheSplitsDepthRangeAndTheFilterRadius) {
    const EngineBias g =
        engines::convert(bias("bevy", {"shadow_depth_bias=0.02", "shadow_normal_bias=1.8"}), "godot", hand_map());
    // 0.02 m = shadow_bias / 100 * 50 m * blur 1 * Soft Low's radius 2.
    EXPECT_NEAR(value(g, "shadow_bias"), 0.02 * 100 / (50 * 2.0), 1e-12);
    // Godot's normal offset loses its part along L: N - cos(t) L has sin^2(t) along N.
    EXPECT_NEAR(value(g, "shadow_normal_bias"), 1.8 * std::sqrt(2.0) / (0.5 * 0.5), 1e-9);
    const EngineBias hard = engines::convert(bias("bevy", {"shadow_depth_bias=0.02", "shadow_normal_bias=1.8"}),
                                             "godot", hand_map(), {{"soft_shadow_filter_quality", "hard"}});
    EXPECT_NEAR(value(hard, "shadow_bias"), 0.02 * 100 / 50, 1e-12);
}

TEST(EngineUnits, FilamentSubtractsItsPolygonOffsetAndScalesNormalBiasByHalfATexelAndSine) {
    const EngineBias f =
        engines::convert(bias("bevy", {"shadow_depth_bias=0.02", "shadow_normal_bias=1.8"}), "filament", hand_map());
    // polygonOffsetConstant 0.5 of r = 2^-16 over 50 m is part of the 2 cm.
    EXPECT_NEAR(value(f, "constantBias"), 0.02 - 0.5 * std::ldexp(1.0, -16) * 50, 1e-12);
    // 1.8 sqrt(2) T / cos = 0.5 nb T sin / cos + 2.0 T tan  =>  nb = 2 (1.8 sqrt(2) - 2 sin) / sin.
    EXPECT_NEAR(value(f, "normalBias"), 2 * (1.8 * std::sqrt(2.0) - 2.0 * 0.5) / 0.5, 1e-9);
}

TEST(EngineUnits, BabylonBiasIsHalvedOnTheDepthTexturePath) {
    EXPECT_NEAR(value(engines::convert(bias("babylon", {"bias=0.0004"}), "bevy", hand_map()), "shadow_depth_bias"),
                0.02, 1e-12);
    EXPECT_NEAR(
        value(engines::convert(bias("babylon", {"bias=0.0004", "pcf=true"}), "bevy", hand_map()), "shadow_depth_bias"),
        0.01, 1e-12);
}

TEST(EngineUnits, UnrealSlopeBiasIsAMultipleOfItsDepthBias) {
    // Defaults: 10 x half a 1 cm texel x 0.5 = 2.5 cm; slope 2.5 cm x 3 x 0.5 x tan 30.
    const engines::Clearance c = engines::clearance(engines::engine_defaults("unreal"), hand_map());
    EXPECT_NEAR(c.constant_m, 0.025, 1e-12);
    EXPECT_NEAR(c.angular_m, 0.025 * 3 * 0.5 * std::tan(30 * kPi / 180), 1e-12);
    // No depth bias to multiply: a slope term cannot be carried.
    EXPECT_THROW(engines::from_clearance("unreal", {0.0, 0.01}, hand_map()), InputError);
}

TEST(EngineUnits, UnityIncludesItsHardwareBiasAndKernelRadius) {
    const engines::Clearance c = engines::clearance(engines::engine_defaults("unity-urp"), hand_map());
    const double t = 30 * kPi / 180;
    EXPECT_NEAR(c.constant_m, 0.01 + std::ldexp(1.0, -16) * 50, 1e-12);
    EXPECT_NEAR(c.angular_m, 0.01 * (1 - std::cos(t)) / std::cos(t) + 2.5 * 0.01 * std::tan(t), 1e-12);
    const engines::Clearance soft =
        engines::clearance(bias("unity-urp", {"soft_shadows=true", "soft_shadow_quality=high"}), hand_map());
    EXPECT_NEAR(soft.constant_m, 3.5 * 0.01 + std::ldexp(1.0, -16) * 50, 1e-12);
}

TEST(EngineUnits, AnEngineWhoseNormalBiasVanishesAtTheAngleCannotCarryOne) {
    MapContext c = hand_map();
    c.angle_rad = 0;  // light along the normal: Godot's (N - cos L) and Unity's 1 - N.L are 0
    const EngineBias bevy = bias("bevy", {"shadow_normal_bias=1"});
    EXPECT_THROW(engines::convert(bevy, "godot", c), InputError);
    EXPECT_THROW(engines::convert(bevy, "unity-urp", c), InputError);
    EXPECT_NO_THROW(engines::convert(bias("bevy", {"shadow_normal_bias=0"}), "godot", c));
}

// A ground plane under a box, a sun 30 degrees from the vertical: the maps penumbra fits.
Scenario synthetic() {
    test::SceneBuilder b;
    b.quad({-10, 0, 10}, {10, 0, 10}, {10, 0, -10}, {-10, 0, -10});
    b.box({-1, 0, -1}, {1, 2, 1});
    const double t = 30 * kPi / 180;
    return test::make_scenario(b.build(), test::look_at({0, 6, 14}, {0, 0, 0}, 45),
                               {test::directional({std::sin(t), -std::cos(t), 0})}, 64, 48);
}

raster::Technique technique(const json& j) {
    return raster::parse_technique(j, "test");
}

TEST(EngineUnits, TheReferenceReceiverIsTheLargestPlaneAtTheLightsAngle) {
    const Scenario s = synthetic();
    const engines::ReferenceReceiver r = engines::reference_receiver(s, s.lights[0], std::nullopt);
    EXPECT_NEAR(r.angle_rad, 30 * kPi / 180, 1e-9);
    EXPECT_NEAR(r.normal.y, 1.0, 1e-12);
    EXPECT_NEAR(r.area_m2, 400 + 4, 1e-9);  // the ground and the box's bottom face share y = 0
    EXPECT_NEAR(engines::reference_receiver(s, s.lights[0], 45.0).angle_rad, kPi / 4, 1e-12);
}

TEST(EngineUnits, AMapsDepthRangeAndTexelAreTheFitsOfTheScene) {
    const Scenario s = synthetic();
    const auto ref = engines::reference_receiver(s, s.lights[0], std::nullopt);
    const auto maps = engines::map_contexts(
        s, technique({{"fit", "scene_bounds"}, {"resolution", 1000}, {"depth_format", "d16"}}), 0, ref);
    ASSERT_EQ(maps.size(), 1u);
    // Light-space depth of every vertex along L = (sin 30, -cos 30, 0): the ground's spans
    // x sin 30 for x in [-10, 10]; the box's top (x sin 30 - 2 cos 30, |x| <= 1) stays within.
    const double t = 30 * kPi / 180;
    const double lo = -10 * std::sin(t), hi = 10 * std::sin(t);
    ASSERT_GT(-std::sin(t) - 2 * std::cos(t), lo);
    EXPECT_NEAR(maps[0].depth_range_m, hi - lo, 1e-9);
    EXPECT_NEAR(maps[0].metres_per_depth, hi - lo, 1e-9);
    // Across the light: z spans 20 m, the other axis 20 cos 30 + 2 sin 30 < 20: texel = 20 / 1000.
    EXPECT_NEAR(maps[0].texel_m, 0.02, 1e-9);
    EXPECT_EQ(maps[0].depth_r, std::ldexp(1.0, -16));
    EXPECT_FALSE(maps[0].cascade.has_value());

    const auto cascades = engines::map_contexts(
        s, technique({{"family", "cascaded"}, {"cascades", {{"count", 3}, {"max_distance", 30}}}}), 0, ref);
    ASSERT_EQ(cascades.size(), 3u);
    for (std::size_t k = 0; k < cascades.size(); ++k) {
        EXPECT_EQ(cascades[k].cascade, static_cast<int>(k));
        if (k > 0) {
            EXPECT_GT(cascades[k].texel_m, cascades[k - 1].texel_m);
        }
    }
}

TEST(EngineUnits, EveryPairRoundTrips) {
    const Scenario s = synthetic();
    const auto ref = engines::reference_receiver(s, s.lights[0], std::nullopt);
    std::vector<MapContext> maps = {hand_map()};
    for (const auto& m : engines::map_contexts(
             s, technique({{"family", "cascaded"}, {"cascades", {{"count", 2}, {"max_distance", 20}}}}), 0, ref))
        maps.push_back(m);
    for (const auto& m : engines::map_contexts(s, technique({{"depth_format", "d32"}}), 0, ref)) maps.push_back(m);
    ASSERT_EQ(maps.size(), 4u);
    int pairs = 0;
    for (const MapContext& m : maps)
        for (const std::string& a : engines::engine_names())
            for (const std::string& b : engines::engine_names()) {
                SCOPED_TRACE(a + " -> " + b + " -> " + a);
                const EngineBias from = sample(a);
                const EngineBias there = engines::convert(from, b, m);
                const EngineBias back = engines::convert(there, a, m);
                const engines::Clearance c0 = engines::clearance(from, m), c1 = engines::clearance(there, m),
                                         c2 = engines::clearance(back, m);
                // B gives the clearance A gave, and A's own values come back.
                EXPECT_TRUE(close(c0.constant_m, c1.constant_m)) << c0.constant_m << " " << c1.constant_m;
                EXPECT_TRUE(close(c0.angular_m, c1.angular_m)) << c0.angular_m << " " << c1.angular_m;
                EXPECT_TRUE(close(c0.constant_m, c2.constant_m));
                EXPECT_TRUE(close(c0.angular_m, c2.angular_m));
                // penumbra's own keys come back as the engine's way of giving them: compared by clearance.
                for (auto it = from.values.begin(); a != "penumbra" && it != from.values.end(); ++it) {
                    EXPECT_TRUE(close(it->get<double>(), back.values.at(it.key()).get<double>()))
                        << it.key() << ": " << *it << " came back as " << back.values.at(it.key());
                }
                ++pairs;
            }
    EXPECT_EQ(pairs, 4 * 8 * 8);
}

// --to penumbra's keys are a technique's (issue #38's contract): a technique parsed from them gives
// back, through its resolved bias (Technique::to_json), the engine's clearance.
TEST(EngineUnits, PenumbraKeysAreTechniqueKeysWithTheEnginesClearance) {
    const MapContext m = hand_map();
    for (const std::string& e : engines::engine_names()) {
        SCOPED_TRACE(e);
        const json keys = engines::nested_bias(engines::penumbra_keys(sample(e), m));
        const raster::Technique t = technique({{"bias", keys}});
        const EngineBias b = engines::penumbra_bias(t.bias_for(0));
        const engines::Clearance want = engines::clearance(sample(e), m), got = engines::clearance(b, m);
        EXPECT_TRUE(close(want.constant_m, got.constant_m)) << want.constant_m << " " << got.constant_m;
        EXPECT_TRUE(close(want.angular_m, got.angular_m)) << want.angular_m << " " << got.angular_m;
    }
}

TEST(EngineUnits, BadEnginesKeysAndValuesAreRefusedByName) {
    auto message = [](auto f) {
        try {
            f();
        } catch (const InputError& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    EXPECT_NE(message([] { engines::engine_info("ogre", "--from"); }).find("no engine \"ogre\""), std::string::npos);
    EXPECT_NE(message([] { bias("bevy", {"shadow_bias=1"}); }).find("no key \"shadow_bias\""), std::string::npos);
    EXPECT_NE(message([] { bias("three", {"bias=nan"}); }).find("bias=nan"), std::string::npos);
    EXPECT_NE(message([] { bias("three", {"bias"}); }).find("not KEY=VALUE"), std::string::npos);
    EXPECT_NE(message([] { bias("godot", {"soft_shadow_filter_quality=fuzzy"}); }).find("soft_low"), std::string::npos);
    EXPECT_NE(
        message([] { engines::parse_engine_bias("three", {"bias=1"}, "--assume", true); }).find("no assumption key"),
        std::string::npos);
}

}  // namespace
}  // namespace penumbra
