// The technique model that families own (issue #34): the "family" key, each family's own
// parse and to_json, a family registered from outside the library, and the shadow views a
// light is drawn from.
#include "raster/technique_family.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <stdexcept>

#include "common/errors.h"
#include "raster/depth_map.h"
#include "raster/light_projection.h"
#include "raster/raster.h"
#include "raster/raster_output.h"
#include "tests/raster/technique_errors.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

using raster::parse_technique;
using ::testing::HasSubstr;

std::string error_of(const nlohmann::json& j) {
    return test::technique_error(j);
}

TEST(FamilyKey, DefaultIsTheDepthMapAndToJsonNamesIt) {
    const raster::Technique t = parse_technique(nlohmann::json::object(), "s.json: technique");
    EXPECT_EQ(t.family, "depth_map");
    EXPECT_EQ(t.to_json().at("family"), "depth_map");
    EXPECT_EQ(t.to_json().at("area_samples"), 0);  // the key raster.json readers know stays
}

TEST(FamilyKey, AnExplicitFamilyParsesItsOwnKeys) {
    raster::Technique t = parse_technique({{"family", "averaged_area"}, {"area_samples", 4}}, "t");
    EXPECT_EQ(t.family, "averaged_area");
    EXPECT_EQ(t.area_samples, 4);
    t = parse_technique({{"family", "averaged_area"}, {"resolution", 512}}, "t");
    EXPECT_EQ(t.area_samples, 16);  // the averaged-hard-shadows preset's count
    EXPECT_EQ(t.resolution, 512);
    EXPECT_EQ(parse_technique({{"family", "depth_map"}, {"area_samples", 0}}, "t").family, "depth_map");
    // Area samples are the averaged family's: the depth map names the family that has them.
    EXPECT_THAT(error_of({{"family", "depth_map"}, {"area_samples", 4}}),
                HasSubstr("s.json: technique.area_samples: only the averaged_area family"));
    EXPECT_THAT(error_of({{"family", "averaged_area"}, {"area_samples", 0}}), HasSubstr("technique.area_samples"));
    EXPECT_THAT(error_of({{"family", 3}}), HasSubstr("technique.family"));
}

TEST(FamilyKey, AnUnknownFamilyIsAnInputErrorNamingItAndTheKnownOnes) {
    const std::string e = error_of({{"family", "moments"}});
    EXPECT_THAT(e, HasSubstr("s.json: technique.family: \"moments\" is not a technique family"));
    EXPECT_THAT(e, HasSubstr("\"depth_map\""));
    EXPECT_THAT(e, HasSubstr("\"averaged_area\""));
    EXPECT_THAT(e, ::testing::Not(HasSubstr("did you mean")));
    EXPECT_THAT(error_of({{"family", "depth_mpa"}}), HasSubstr("(did you mean \"depth_map\"?)"));
    EXPECT_THAT(error_of({{"family", "averaged"}}), HasSubstr("(did you mean \"averaged_area\"?)"));
}

// Techniques written before the key keep drawing as they did: area_samples > 0 is averaged.
TEST(FamilyKey, WithoutTheKeyAreaSamplesInferTheAveragedFamily) {
    EXPECT_EQ(parse_technique({{"area_samples", 8}}, "t").family, "averaged_area");
    EXPECT_EQ(parse_technique({{"area_samples", 8}}, "t").area_samples, 8);
    EXPECT_EQ(parse_technique({{"area_samples", 0}}, "t").family, "depth_map");
    EXPECT_EQ(parse_technique({{"preset", "averaged-hard-shadows"}}, "t").family, "averaged_area");
    EXPECT_EQ(parse_technique({{"preset", "averaged-hard-shadows"}, {"area_samples", 0}}, "t").family, "depth_map");
    EXPECT_EQ(parse_technique({{"preset", "pcss"}}, "t").family, "depth_map");
    // Bad values fail as they did, naming the key.
    EXPECT_THAT(error_of({{"area_samples", -1}}), HasSubstr("technique.area_samples"));
    EXPECT_THAT(error_of({{"area_samples", 1000}}), HasSubstr("technique.area_samples"));
    EXPECT_THAT(error_of({{"area_samples", "many"}}), HasSubstr("technique.area_samples"));
}

TEST(FamilyKey, ToJsonParsesBackToTheSameTechniqueInEveryFamily) {
    std::vector<nlohmann::json> cases = {
        nlohmann::json::object(),
        {{"family", "averaged_area"}, {"area_samples", 3}, {"bias", {{"slope", 2}}}},
        {{"family", "depth_map"},
         {"filter", {{"type", "poisson"}, {"taps", 8}}},
         {"lights", {{{"bias", {{"world", 0.1}}}}}}},
        {{"depth_layer", "second"}, {"cull", "back"}},
        {{"family", "planar_projection"}, {"planar", {{"plane", {0, 2, 0, 1}}}}},
    };
    for (const auto& p : raster::presets()) cases.push_back({{"preset", p.name}});
    for (const auto& j : cases) {
        const raster::Technique t = parse_technique(j, "t");
        const nlohmann::json written = t.to_json();
        EXPECT_EQ(written.at("family"), t.family) << j.dump();
        const raster::Technique back = parse_technique(written, "t");
        EXPECT_EQ(back.family, t.family) << j.dump();
        EXPECT_EQ(back.to_json(), written) << j.dump();
    }
}

// The built-in families' scoring hints, memory and raster.json keys come from their entries.
TEST(FamilyKey, TheFamilySuppliesScoringHintsAndMemory) {
    const raster::Technique t = parse_technique({{"family", "averaged_area"},
                                                 {"area_samples", 5},
                                                 {"depth_format", "d16"},
                                                 {"resolution", 256},
                                                 {"filter", {{"type", "pcf"}, {"size", 5}}}},
                                                "t");
    const raster::FamilyEntry& f = raster::family_of(t);
    EXPECT_EQ(f.name, "averaged_area");
    EXPECT_DOUBLE_EQ(f.hints(t).filter_reach_texels, 2.5);
    EXPECT_DOUBLE_EQ(f.hints(t).depth_quantum, std::ldexp(1.0, -16));
    const RasterMemory m = f.memory(t);
    EXPECT_EQ(m.resolution, 256);
    EXPECT_EQ(m.depth_bytes, 2);
    EXPECT_EQ(m.area_samples, 5);
    EXPECT_EQ(raster::family_of(parse_technique({{"area_samples", 0}}, "t")).memory(t).area_samples, 0);
}

// Woo's midpoint and Wang & Molnar's second depth are the depth map's `depth_layer`; planar
// projection is a family of its own with a receiver plane and no map (issue #36).
TEST(FamilyKey, DepthLayerAndPlanarProjectionParseTheirKeysAndRefuseBadOnes) {
    EXPECT_EQ(parse_technique(nlohmann::json::object(), "t").depth_layer, raster::DepthLayer::first);
    const raster::Technique mid = parse_technique({{"preset", "rtr-midpoint"}, {"resolution", 256}}, "t");
    EXPECT_EQ(mid.depth_layer, raster::DepthLayer::midpoint);
    EXPECT_EQ(mid.cull, raster::Cull::none);
    // Two depth layers and the second pass's ids: the memory estimate counts both.
    EXPECT_EQ(raster::family_of(mid).memory(mid).depth_bytes, 4 + 4 + 4);
    // Second depth is the back faces alone, whatever `cull` said.
    EXPECT_EQ(parse_technique({{"depth_layer", "second"}, {"cull", "back"}}, "t").cull, raster::Cull::front);
    EXPECT_THAT(
        error_of({{"depth_layer", "third"}}),
        HasSubstr("s.json: technique.depth_layer: \"third\" is not one of \"first\", \"midpoint\", \"second\""));
    EXPECT_THAT(error_of({{"family", "cascaded"}, {"depth_layer", "midpoint"}}), HasSubstr("technique.depth_layer"));

    const raster::Technique planar = parse_technique({{"preset", "rtr-planar"}}, "t");
    EXPECT_EQ(planar.family, "planar_projection");
    EXPECT_EQ(planar.to_json().at("planar"), nlohmann::json::object());  // the plane is found in the scene
    EXPECT_TRUE(raster::family_of(planar).hints(planar).exact);
    EXPECT_EQ(raster::family_of(planar).memory(planar).resolution, 0);
    EXPECT_THAT(error_of({{"family", "planar_projection"}, {"planar", {{"plane", {0, 0, 0, 1}}}}}),
                HasSubstr("s.json: technique.planar.plane: the normal [nx, ny, nz] is zero"));
    EXPECT_THAT(error_of({{"family", "planar_projection"}, {"planar", {{"plane", {0, 1, 0}}}}}),
                HasSubstr("technique.planar.plane: expected [nx, ny, nz, d]"));
    EXPECT_THAT(error_of({{"family", "planar_projection"}, {"planar", {{"height", 1}}}}),
                HasSubstr("technique.planar.height"));
    EXPECT_THAT(error_of({{"family", "planar_projection"}, {"resolution", 1024}}), HasSubstr("technique.resolution"));
}

// The memory estimate counts the layers the family gives each kind of light (a cascaded sun:
// one per cascade), not a cube for points and one map for the rest.
TEST(FamilyKey, TheMemoryEstimateTakesTheFamilysLayersPerLight) {
    Scenario s;
    s.width = s.height = 16;
    Light spot;
    spot.type = LightType::spot;
    s.lights = {Light{}, Light{}, spot, test::point({0, 1, 0})};
    RasterMemory m = raster::family_of(parse_technique({{"resolution", 256}}, "t")).memory(raster::Technique{});
    m.resolution = 256;
    EXPECT_EQ(memory_inputs(s, false, &m, false).shadow_layers, 1u + 1 + 1 + 6);
    m.directional_layers = 4;
    EXPECT_EQ(memory_inputs(s, false, &m, false).shadow_layers, 4u + 4 + 1 + 6);
    // Beyond the budget one map of the most layers is shared.
    m.resolution = 16384;
    m.directional_layers = 8;
    EXPECT_EQ(memory_inputs(s, false, &m, false).shadow_layers, 8u);
}

// A family from outside the library: every pixel gets the shade its "value" key says.
struct ConstantShade final : raster::FamilyParameters {
    double value = 1;
};

class ConstantShadeFamily final : public raster::TechniqueFamily {
  public:
    explicit ConstantShadeFamily(const raster::SceneOnGpu& s) : pixels_(s.pixels) {}
    void render(const raster::Technique& t, std::span<const Light> lights, const raster::RenderOptions&,
                RasterFrame& frame, raster::RasterStats& stats) override {
        const auto& p = *t.parameters<ConstantShade>();
        for (std::size_t li = 0; li < lights.size(); ++li) {
            frame.lights.push_back({std::vector<float>(pixels_, static_cast<float>(p.value)), std::nullopt});
            stats.lights.emplace_back();
            stats.lights.back().gpu_ms.add("shade", 0.5);
            stats.gpu_ms.add("shade", 0.5);
        }
    }

  private:
    std::size_t pixels_;
};

void register_constant_shade() {
    if (raster::find_technique_family("constant_shade")) return;
    raster::FamilyEntry e;
    e.name = "constant_shade";
    e.description = "a test family: every pixel the same shade";
    e.parse = [](JsonObject& o, raster::Technique& t) {
        auto p = std::make_shared<ConstantShade>();
        p->value = o.number_in("value", 1.0, 0.0, 1.0, "a shade in [0, 1]");
        t.family_parameters = p;
    };
    e.write = [](const raster::Technique& t, nlohmann::json& j) { j["value"] = t.parameters<ConstantShade>()->value; };
    e.hints = [](const raster::Technique&) { return raster::ScoringHints{3, 0}; };
    e.memory = [](const raster::Technique&) { return RasterMemory{}; };
    e.describe_light = [](const raster::Technique&, const Light&, const raster::RasterLightStats&) {
        return nlohmann::json{{"shade", "constant"}};
    };
    e.sweep_keys = {"value"};
    e.make = [](const raster::SceneOnGpu& s) { return std::make_unique<ConstantShadeFamily>(s); };
    raster::register_technique_family(std::move(e));
}

TEST(RegisteredFamily, IsPickedByItsKeyAndParsesAndWritesItsOwnKeys) {
    register_constant_shade();
    const raster::Technique t = parse_technique({{"family", "constant_shade"}, {"value", 0.25}}, "t");
    EXPECT_EQ(t.family, "constant_shade");
    EXPECT_DOUBLE_EQ(t.parameters<ConstantShade>()->value, 0.25);
    EXPECT_EQ(t.to_json(),
              (nlohmann::json{{"family", "constant_shade"}, {"value", 0.25}, {"precision", "camera_relative"}}));
    EXPECT_EQ(parse_technique(t.to_json(), "t").to_json(), t.to_json());
    EXPECT_DOUBLE_EQ(raster::family_of(t).hints(t).filter_reach_texels, 3.0);
    // Its keys only: the depth map's are not its own (the message names their family), and its
    // own are checked.
    EXPECT_THAT(error_of({{"family", "constant_shade"}, {"resolution", 512}}),
                HasSubstr("technique.resolution: a key of the \"depth_map\" family, not of \"constant_shade\": add "
                          "\"family\": \"depth_map\""));
    // A key no family has stays unknown.
    EXPECT_THAT(error_of({{"family", "constant_shade"}, {"nothing", 1}}), HasSubstr("technique.nothing: unknown key"));
    EXPECT_THAT(error_of({{"family", "constant_shade"}, {"value", 2}}), HasSubstr("technique.value"));
    // The unknown-family message lists it with the built-in ones.
    EXPECT_THAT(error_of({{"family", "nope"}}), HasSubstr("\"constant_shade\""));
    raster::FamilyEntry again = *raster::find_technique_family("constant_shade");
    EXPECT_THROW(raster::register_technique_family(again), std::invalid_argument);
    again.name = "incomplete";
    again.make = nullptr;
    EXPECT_THROW(raster::register_technique_family(again), std::invalid_argument);
}

// Shadow views: what each light's shadow is drawn from.
Scenario views_scene(const Light& light) {
    test::SceneBuilder b;
    b.grid({-6, 0, -6}, {0, 0, 12}, {12, 0, 0}, 4, 4);
    b.box({-1, 0, -1}, {1, 1.5, 1});
    return test::make_scenario(b.build(), test::look_at({3, 4, 7}, {0, 0.5, 0}, 50), {light}, 96, 64);
}

TEST(ShadowViews, APointLightHasSixCubeFacesADirectionalLightOneOrthoView) {
    for (const Light& light : {test::point({0.5, 3, 0.2}), test::directional({-0.4, -1, -0.3})}) {
        const Scenario sc = views_scene(light);
        const raster::LightProjection lp = raster::fit_light(sc.lights[0], sc.scene, sc.camera, sc.width, sc.height,
                                                             raster::Fit::scene_bounds, 512, sc.camera.eye);
        const std::vector<raster::ShadowView> views = raster::shadow_views(lp);
        if (light.type == LightType::point) {
            ASSERT_EQ(views.size(), 6u);
            const char* faces[] = {"+x", "-x", "+y", "-y", "+z", "-z"};
            for (std::size_t k = 0; k < 6; ++k) {
                EXPECT_EQ(views[k].kind, raster::ViewKind::cube_face);
                EXPECT_EQ(views[k].name, faces[k]);
                EXPECT_EQ(views[k].axis, lp.axis[k]);
                EXPECT_DOUBLE_EQ(views[k].metres_per_texel_per_metre, 2.0 / 512);
                EXPECT_GT(views[k].far, views[k].near);
                EXPECT_GT(views[k].near, 0.0);
            }
        } else {
            ASSERT_EQ(views.size(), 1u);
            EXPECT_EQ(views[0].kind, raster::ViewKind::ortho);
            EXPECT_EQ(views[0].name, "");
            EXPECT_EQ(views[0].view_proj, lp.view_proj[0]);
            EXPECT_GT(views[0].metres_per_texel, 0.0);
            EXPECT_EQ(views[0].metres_per_texel, lp.metres_per_texel);
        }
    }
    const Scenario spot = views_scene(test::point({0.5, 3, 0.2}));
    Light s = spot.lights[0];
    s.type = LightType::spot;
    s.direction = {0, -1, 0};
    s.outer_cone_rad = 0.6;
    const auto views = raster::shadow_views(raster::fit_light(s, spot.scene, spot.camera, spot.width, spot.height,
                                                              raster::Fit::scene_bounds, 512, spot.camera.eye));
    ASSERT_EQ(views.size(), 1u);
    EXPECT_EQ(views[0].kind, raster::ViewKind::perspective);
}

class FamilyOnDevice : public ::testing::Test {
  protected:
    void SetUp() override {
        raster::ContextOptions o;
        o.validation = true;
        ctx_ = std::make_unique<raster::VulkanContext>(o);
    }
    void TearDown() override {
        if (!ctx_) return;
        EXPECT_TRUE(ctx_->validation_messages().empty()) << ctx_->validation_messages()[0];
    }
    std::unique_ptr<raster::VulkanContext> ctx_;
};

TEST_F(FamilyOnDevice, ARegisteredFamilyDrawsTheTechniquesThatNameIt) {
    register_constant_shade();
    const Scenario sc = views_scene(test::directional({-0.4, -1, -0.3}));
    raster::RasterSession session(sc, *ctx_);
    const raster::Technique t = parse_technique({{"family", "constant_shade"}, {"value", 0.25}}, "t");
    const raster::RasterResult r = session.render(t);
    EXPECT_EQ(r.stats.family, "constant_shade");
    ASSERT_EQ(r.frame.lights.size(), 1u);
    EXPECT_EQ(r.frame.lights[0].V, std::vector<float>(static_cast<std::size_t>(sc.width * sc.height), 0.25f));
    // Its passes and its keys reach raster.json without new fields.
    const nlohmann::json j = raster::raster_json(sc, t, r, {});
    EXPECT_EQ(j["gpu_ms"]["shade"], 0.5);
    EXPECT_EQ(j["lights"][0]["gpu_ms"]["shade"], 0.5);
    EXPECT_EQ(j["lights"][0]["shade"], "constant");
    EXPECT_EQ(j["family"], "constant_shade");
    // The same session goes on drawing depth maps.
    EXPECT_EQ(session.render(parse_technique(nlohmann::json::object(), "t")).stats.family, "depth_map");
}

// A depth-map variant added from outside the library (docs/raster.md, "Adding a depth-map
// variant"): its own code and one registration, nothing edited in the core. This one doubles
// every layer's hardware constant bias through the core's hook, so it must draw exactly the map
// the depth map draws with the constant doubled, and not the one it draws without.
class DoubledConstant final : public raster::DepthMapVariant {
  public:
    double constant_scale(const raster::Technique&, const Light&, const raster::LightProjection&,
                          std::uint32_t) const override {
        return 2.0;
    }
};

void register_doubled_constant() {
    if (raster::find_technique_family("doubled_constant")) return;
    raster::FamilyEntry e = raster::depth_map_family_entry();
    e.name = "doubled_constant";
    e.description = "a test variant: the depth map with each layer's constant bias doubled";
    e.make = [](const raster::SceneOnGpu& s) {
        raster::DepthMapVariants variants;
        variants.push_back(std::make_unique<DoubledConstant>());
        return raster::make_depth_map_core(s, std::move(variants));
    };
    raster::register_technique_family(std::move(e));
}

TEST_F(FamilyOnDevice, ADepthMapVariantFromOutsideDrawsThroughTheCoresHooks) {
    register_doubled_constant();
    for (const Light& light : {test::directional({-0.4, -1, -0.3}), test::point({0.5, 3, 0.2})}) {
        const Scenario sc = views_scene(light);
        raster::RasterSession session(sc, *ctx_);
        auto technique = [](const char* family, double constant) {
            return parse_technique({{"family", family},
                                    {"resolution", 256},
                                    {"depth_format", "d24"},
                                    {"bias", {{"constant", constant}, {"slope", 0}}}},
                                   "t");
        };
        const raster::RasterResult doubled = session.render(technique("doubled_constant", 20000));
        const raster::RasterResult twice = session.render(technique("depth_map", 40000));
        const raster::RasterResult once = session.render(technique("depth_map", 20000));
        EXPECT_EQ(doubled.stats.family, "doubled_constant");
        ASSERT_EQ(doubled.frame.lights.size(), 1u);
        ASSERT_TRUE(doubled.frame.lights[0].lookups && twice.frame.lights[0].lookups && once.frame.lights[0].lookups);
        EXPECT_EQ(doubled.frame.lights[0].V, twice.frame.lights[0].V);
        EXPECT_EQ(doubled.frame.lights[0].lookups->stored_depth, twice.frame.lights[0].lookups->stored_depth);
        EXPECT_NE(doubled.frame.lights[0].lookups->stored_depth, once.frame.lights[0].lookups->stored_depth);
    }
}

// A render without read-back leaves each light's output where the lookup pass wrote it, for a
// scorer on the device (metrics/gpu_classification.h): the lookups or V alone, nothing in the frame.
TEST_F(FamilyOnDevice, ARenderWithoutReadBackLeavesItsOutputOnTheDevice) {
    const Scenario sc = views_scene(test::directional({-0.4, -1, -0.3}));
    raster::RasterSession session(sc, *ctx_);
    const raster::Technique t = parse_technique({{"resolution", 256}}, "t");
    const std::size_t n = static_cast<std::size_t>(sc.width * sc.height);
    for (const bool lookups : {true, false}) {
        raster::RenderOptions o;
        o.lookups = lookups;
        o.read_back = false;
        const raster::RasterResult r = session.render(t, o);
        ASSERT_EQ(r.stats.on_device.size(), 1u);
        EXPECT_NE(r.stats.on_device[0].buffer, VkBuffer{VK_NULL_HANDLE});
        EXPECT_EQ(r.stats.on_device[0].lookups, lookups);
        EXPECT_EQ(r.stats.on_device[0].size, n * (lookups ? 36u : 4u));
        ASSERT_EQ(r.frame.lights.size(), 1u);
        EXPECT_TRUE(r.frame.lights[0].V.empty());
    }
    const raster::RasterResult read = session.render(t);
    EXPECT_TRUE(read.stats.on_device.empty());
    EXPECT_EQ(read.frame.lights[0].V.size(), n);
    // raster.json says which clocks its GPU times rest on.
    const nlohmann::json clocks = raster::raster_json(sc, t, read, {})["device"]["timestamps"];
    EXPECT_GT(clocks["period_ns"].get<double>(), 0.0);
    const std::string calibration = clocks["calibration"];
    if (calibration != "none") {
        const auto domains = clocks["time_domains"].get<std::vector<std::string>>();
        EXPECT_NE(std::find(domains.begin(), domains.end(), "device"), domains.end()) << calibration;
    }
}

// Lookups carry the view (layer) each pixel used: a cube face for a point light, chosen by the
// major axis from the light to the receiver; always 0 for a directional light.
TEST_F(FamilyOnDevice, LookupsNameTheLayerEachPixelUsed) {
    const glm::dvec3 lp(0.5, 3, 0.2);
    for (const Light& light : {test::point(lp), test::directional({-0.4, -1, -0.3})}) {
        const Scenario sc = views_scene(light);
        const raster::RasterResult r = raster::run_raster(sc, parse_technique({{"resolution", 256}}, "t"), *ctx_);
        const DepthMapLookups& lk = *r.frame.lights[0].lookups;
        std::set<std::uint32_t> layers;
        for (std::size_t i = 0; i < lk.flags.size(); ++i) {
            EXPECT_LT(lk.flags[i], 16u);  // the layer is not left in the flags
            if (lk.flags[i] != kRasterSurface) continue;
            layers.insert(lk.layer[i]);
            EXPECT_TRUE((r.stats.lights[0].layers_sampled >> lk.layer[i]) & 1u) << "layer " << lk.layer[i];
        }
        if (light.type == LightType::point) {
            // The ground below the light is seen through -y; the box's sides through the others.
            EXPECT_TRUE(layers.count(3));
            EXPECT_GE(layers.size(), 2u);
            for (std::uint32_t l : layers) EXPECT_LT(l, 6u);
        } else {
            EXPECT_EQ(layers, std::set<std::uint32_t>{0});
        }
    }
}

}  // namespace
}  // namespace penumbra
