// Scenario files: every refusal names the file, the JSON path and what was expected.
#include "common/scenario.h"

#include <gtest/gtest.h>

#include "common/errors.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

using test::TempDir;

class ScenarioTest : public ::testing::Test {
  protected:
    void SetUp() override { test::GltfFixture().write(dir_); }

    nlohmann::json valid() const {
        return {{"scene", "scene.gltf"},
                {"image", {{"width", 64}, {"height", 48}}},
                {"camera", {{"type", "perspective"}, {"eye", {0, 2, 3}}, {"target", {0, 0, 0}}, {"yfov_deg", 45}}},
                {"lights", {{{"type", "directional"}, {"direction", {0, -1, 0}}}}}};
    }

    // Loads `doc` and returns the InputError message ("" if it loaded).
    std::string error_of(const nlohmann::json& doc) { return error_of_text(doc.dump()); }
    std::string error_of_text(const std::string& text) {
        test::write_text(dir_ / "scenario.json", text);
        try {
            load_scenario(dir_ / "scenario.json");
        } catch (const InputError& e) {
            return e.what();
        }
        return "";
    }
    TempDir dir_;
};

TEST_F(ScenarioTest, LoadsAValidScenario) {
    test::write_text(dir_ / "scenario.json", valid().dump());
    Scenario s = load_scenario(dir_ / "scenario.json");
    EXPECT_EQ(s.width, 64);
    EXPECT_EQ(s.height, 48);
    ASSERT_EQ(s.lights.size(), 1u);
    EXPECT_EQ(s.lights[0].type, LightType::directional);
    EXPECT_EQ(s.scene.triangle_count(), 2u);
    EXPECT_NEAR(s.camera.forward.z, -3 / std::sqrt(13.0), 1e-12);
}

TEST_F(ScenarioTest, NamesThePathOfAZeroDirection) {
    auto doc = valid();
    doc["lights"].push_back({{"type", "directional"}, {"direction", {0, 0, 0}}});
    EXPECT_EQ(error_of(doc), "scenario.json: lights[1].direction: zero vector");
}

TEST_F(ScenarioTest, RefusesUnknownKeysAndWrongTypes) {
    auto doc = valid();
    doc["camera"]["fov"] = 45;
    EXPECT_EQ(error_of(doc), "scenario.json: camera.fov: unknown key");
    // A misspelt key in place of a required one is named as unknown, with the key it resembles,
    // not reported as the required key missing.
    doc = valid();
    doc["camera"].erase("yfov_deg");
    doc["camera"]["fov"] = 45;
    EXPECT_EQ(error_of(doc), "scenario.json: camera.fov: unknown key (did you mean \"yfov_deg\"?)");
    doc = valid();
    doc["lights"][0].erase("direction");
    doc["lights"][0]["dir"] = {0, -1, 0};
    EXPECT_EQ(error_of(doc), "scenario.json: lights[0].dir: unknown key (did you mean \"direction\"?)");
    doc = valid();
    doc.erase("image");
    doc["img"] = {{"width", 64}, {"height", 48}};
    EXPECT_EQ(error_of(doc), "scenario.json: img: unknown key (did you mean \"image\"?)");
    doc = valid();
    doc["image"]["width"] = "wide";
    EXPECT_EQ(error_of(doc), "scenario.json: image.width: expected an integer, got string");
    doc = valid();
    doc["lights"][0]["type"] = "laser";
    EXPECT_NE(error_of(doc).find("lights[0].type: expected one of directional"), std::string::npos);
}

TEST_F(ScenarioTest, RefusesDegenerateCameras) {
    auto doc = valid();
    doc["camera"]["target"] = doc["camera"]["eye"];
    EXPECT_NE(error_of(doc).find("camera.target: equals eye"), std::string::npos);
    doc = valid();
    doc["camera"]["eye"] = {0, 5, 0};
    EXPECT_NE(error_of(doc).find("camera.up: parallel to the view direction"), std::string::npos);
    doc = valid();
    doc["camera"]["yfov_deg"] = 180;
    EXPECT_NE(error_of(doc).find("camera.yfov_deg"), std::string::npos);
    doc = valid();
    doc["camera"]["zfar"] = 0.05;
    EXPECT_NE(error_of(doc).find("camera.zfar"), std::string::npos);
    doc = valid();
    doc["camera"] = {{"type", "orthographic"}, {"eye", {0, 2, 3}}, {"target", {0, 0, 0}}, {"xmag", 0}, {"ymag", 1}};
    EXPECT_NE(error_of(doc).find("camera.xmag"), std::string::npos);
}

TEST_F(ScenarioTest, RefusesAbsurdSizesAndNonFiniteNumbers) {
    auto doc = valid();
    doc["image"]["width"] = 100000;
    EXPECT_NE(error_of(doc).find("image.width: expected an integer in [1, 16384]"), std::string::npos);
    doc = valid();
    doc["image"] = {{"width", 16384}, {"height", 16384}};
    EXPECT_NE(error_of(doc).find("pixel limit"), std::string::npos);
    EXPECT_NE(error_of_text(R"({"scene": "scene.gltf", "image": {"width": 1e999}})").find("scenario.json"),
              std::string::npos);
    doc = valid();
    doc["lights"] = {{{"type", "point"}, {"position", {0, 1e300, 0}}}};
    EXPECT_NE(error_of(doc).find("lights[0].position: coordinate"), std::string::npos);
    doc = valid();
    doc["lights"] = {{{"type", "spot"}, {"position", {0, 1, 0}}, {"direction", {0, -1, 0}}, {"outer_cone_deg", 120}}};
    EXPECT_NE(error_of(doc).find("lights[0].outer_cone_deg"), std::string::npos);
}

TEST_F(ScenarioTest, RefusesMalformedJsonAndDuplicateKeys) {
    EXPECT_NE(error_of_text("{\"scene\": ").find("scenario.json: invalid JSON at byte"), std::string::npos);
    EXPECT_EQ(error_of_text(R"({"scene": "a", "scene": "b"})"), "scenario.json: duplicate key \"scene\"");
    EXPECT_NE(error_of_text("[1, 2]").find("expected an object"), std::string::npos);
}

TEST_F(ScenarioTest, RefusesAMissingScene) {
    auto doc = valid();
    doc["scene"] = "nowhere.glb";
    EXPECT_NE(error_of(doc).find("scenario.json: scene: no such file"), std::string::npos);
}

TEST_F(ScenarioTest, TakesCamerasAndLightsFromTheGltf) {
    test::GltfFixture g;
    g.doc["cameras"] = {{{"type", "perspective"}, {"perspective", {{"yfov", 0.8}, {"znear", 0.05}}}}};
    g.doc["extensionsUsed"] = {"KHR_lights_punctual"};
    g.doc["extensions"] = {
        {"KHR_lights_punctual", {{"lights", {{{"type", "spot"}, {"spot", {{"outerConeAngle", 0.5}}}}}}}}};
    // Camera at (0, 2, 0) looking down (rotated -90 degrees about X); the light node reuses it.
    double s = std::sqrt(0.5);
    g.doc["nodes"].push_back({{"camera", 0},
                              {"translation", {0, 2, 0}},
                              {"rotation", {-s, 0, 0, s}},
                              {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}});
    g.doc["scenes"][0]["nodes"] = {0, 1};
    g.write(dir_);
    auto doc = valid();
    doc["camera"] = {{"gltf_camera", 0}};
    doc["lights"] = "gltf";
    test::write_text(dir_ / "scenario.json", doc.dump());
    Scenario sc = load_scenario(dir_ / "scenario.json");
    EXPECT_NEAR(sc.camera.eye.y, 2.0, 1e-12);
    EXPECT_NEAR(sc.camera.forward.y, -1.0, 1e-12);
    EXPECT_NEAR(sc.camera.yfov_rad, 0.8, 1e-12);
    ASSERT_EQ(sc.lights.size(), 1u);
    EXPECT_EQ(sc.lights[0].type, LightType::spot);
    EXPECT_NEAR(sc.lights[0].direction.y, -1.0, 1e-12);
    EXPECT_NEAR(sc.lights[0].outer_cone_rad, 0.5, 1e-12);

    doc["camera"] = {{"gltf_camera", 3}};
    EXPECT_NE(error_of(doc).find("camera.gltf_camera: the scene has 1 cameras"), std::string::npos);
}

}  // namespace
}  // namespace penumbra
