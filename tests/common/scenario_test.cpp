// Scenario files: every refusal names the file, the JSON path and what was expected.
#include "common/scenario.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <glm/geometric.hpp>

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

TEST_F(ScenarioTest, ReadsASunsAngularDiameterAndRefusesOneOutOfRange) {
    auto doc = valid();
    test::write_text(dir_ / "scenario.json", doc.dump());
    EXPECT_EQ(load_scenario(dir_ / "scenario.json").lights[0].angular_diameter_rad, 0.0);  // punctual by default
    doc["lights"][0]["angular_diameter_deg"] = 0.53;
    test::write_text(dir_ / "scenario.json", doc.dump());
    const Scenario s = load_scenario(dir_ / "scenario.json");
    EXPECT_NEAR(s.lights[0].angular_diameter_rad, 0.53 * M_PI / 180, 1e-15);
    EXPECT_TRUE(is_soft_light(s.lights[0]));
    for (double bad : {-0.1, 20.0, 45.0}) {
        doc["lights"][0]["angular_diameter_deg"] = bad;
        EXPECT_EQ(error_of(doc), fmt::format("scenario.json: lights[0].angular_diameter_deg: {:g} degrees is outside "
                                             "[0, 20) (0: a punctual sun)",
                                             bad));
    }
    doc["lights"][0]["angular_diameter_deg"] = "wide";
    EXPECT_EQ(error_of(doc), "scenario.json: lights[0].angular_diameter_deg: expected a number, got string");
    // A size belongs to suns only: the other lights have their own keys for theirs.
    doc = valid();
    doc["lights"] = {{{"type", "point"}, {"position", {0, 1, 0}}, {"angular_diameter_deg", 1}}};
    EXPECT_EQ(error_of(doc), "scenario.json: lights[0].angular_diameter_deg: unknown key");
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

// Receivers (docs/scenario.md, "Receivers"): triangles of the one scene both paths draw.
TEST_F(ScenarioTest, AddsPlaneAndBoxReceiversToTheScene) {
    auto doc = valid();
    doc["receivers"] = {{{"type", "plane"}, {"center", {0, -1, 0}}, {"size", {10, 4}}},
                        {{"type", "box"}, {"center", {3, 0.5, 0}}, {"size", {1, 1, 2}}}};
    test::write_text(dir_ / "scenario.json", doc.dump());
    Scenario s = load_scenario(dir_ / "scenario.json");
    ASSERT_EQ(s.receivers.size(), 2u);
    ASSERT_EQ(s.scene.triangle_count(), 2u + 2u + 12u);  // the glTF's quad, the plane, the box
    // The plane: double-sided, facing +Y (its default normal), 10 m along x and 4 m along z.
    for (std::uint32_t t = 2; t < 4; ++t) {
        const auto& tri = s.scene.triangles[t];
        const glm::dvec3 a = s.scene.positions[tri.x], b = s.scene.positions[tri.y], c = s.scene.positions[tri.z];
        EXPECT_GT(glm::cross(b - a, c - a).y, 0.0);
        EXPECT_TRUE(s.scene.double_sided[t]);
        EXPECT_EQ(s.scene.triangle_node[t], kReceiverNode);
    }
    EXPECT_DOUBLE_EQ(s.scene.bounds.lo.x, -5.0);
    EXPECT_DOUBLE_EQ(s.scene.bounds.lo.y, -1.0);
    EXPECT_DOUBLE_EQ(s.scene.bounds.lo.z, -2.0);
    // The box: single-sided triangles facing away from its centre, its corners at centre +- size/2.
    const glm::dvec3 centre(3, 0.5, 0);
    for (std::uint32_t t = 4; t < 16; ++t) {
        const auto& tri = s.scene.triangles[t];
        const glm::dvec3 a = s.scene.positions[tri.x], b = s.scene.positions[tri.y], c = s.scene.positions[tri.z];
        EXPECT_GT(glm::dot(glm::cross(b - a, c - a), (a + b + c) / 3.0 - centre), 0.0) << "triangle " << t;
        EXPECT_FALSE(s.scene.double_sided[t]);
    }
    EXPECT_DOUBLE_EQ(s.scene.bounds.hi.x, 5.0);  // the plane's edge; the box reaches 3.5
    EXPECT_DOUBLE_EQ(s.scene.bounds.hi.y, 1.0);
    EXPECT_DOUBLE_EQ(s.scene.bounds.hi.z, 2.0);
}

TEST_F(ScenarioTest, RefusesMalformedReceiversNamingThePath) {
    auto with = [&](nlohmann::json receivers) {
        auto doc = valid();
        doc["receivers"] = std::move(receivers);
        return error_of(doc);
    };
    EXPECT_EQ(with({{"type", "plane"}}), "scenario.json: receivers: expected an array of receivers (planes and boxes)");
    EXPECT_EQ(with({{{"type", "disc"}, {"center", {0, 0, 0}}}}),
              "scenario.json: receivers[0].type: expected \"plane\" or \"box\", got \"disc\"");
    EXPECT_EQ(with({{{"type", "plane"}, {"center", {0, 0, 0}}}}),
              "scenario.json: receivers[0].size: missing required key");
    EXPECT_EQ(with({{{"type", "plane"}, {"center", {0, 0, 0}}, {"size", {1, 2, 3}}}}),
              "scenario.json: receivers[0].size: expected an array of 2 sizes in metres");
    EXPECT_EQ(with({{{"type", "box"}, {"center", {0, 0, 0}}, {"size", {1, 0, 1}}}}),
              "scenario.json: receivers[0].size: element 1 is 0; expected a size in [1e-12, 1e15] m");
    EXPECT_EQ(with({{{"type", "box"}, {"center", {0, 0, 0}}, {"size", {1, -2, 1}}}}),
              "scenario.json: receivers[0].size: element 1 is -2; expected a size in [1e-12, 1e15] m");
    EXPECT_EQ(with({{{"type", "plane"}, {"center", {0, 0, 0}}, {"normal", {0, 0, 0}}, {"size", {1, 1}}}}),
              "scenario.json: receivers[0].normal: zero vector");
    EXPECT_EQ(with({{{"type", "box"}, {"center", {0, 0, 0}}, {"normal", {0, 1, 0}}, {"size", {1, 1, 1}}}}),
              "scenario.json: receivers[0].normal: unknown key");
    EXPECT_EQ(with({{{"type", "box"}, {"center", {0, 0}}, {"size", {1, 1, 1}}}}),
              "scenario.json: receivers[0].center: expected an array of 3 numbers");
    EXPECT_EQ(with({{{"type", "box"}, {"center", {0, 0, 9e14}}, {"size", {1, 1, 5e14}}}}),
              "scenario.json: receivers[0].size: reaches beyond the 1e+15 m coordinate limit");
    EXPECT_EQ(with({{{"type", "box"}, {"center", {0, 0, 0}}, {"size", {1, 1, 1}}}, 3}),
              "scenario.json: receivers[1]: expected an object, got number");
}

// "scale": the model's units to metres, applied to everything the glTF places.
TEST_F(ScenarioTest, ScalesTheGltfSceneItsCamerasAndLights) {
    test::GltfFixture g;
    g.doc["cameras"] = {{{"type", "perspective"}, {"perspective", {{"yfov", 0.8}, {"znear", 0.05}, {"zfar", 100}}}}};
    g.doc["extensionsUsed"] = {"KHR_lights_punctual"};
    g.doc["extensions"] = {{"KHR_lights_punctual", {{"lights", {{{"type", "point"}}}}}}};
    g.doc["nodes"].push_back(
        {{"camera", 0}, {"translation", {0, 2, 3}}, {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}});
    g.doc["scenes"][0]["nodes"] = {0, 1};
    g.write(dir_);
    auto doc = valid();
    doc["scale"] = 0.001;
    doc["camera"] = {{"gltf_camera", 0}};
    doc["lights"] = "gltf";
    doc["receivers"] = {{{"type", "plane"}, {"center", {0, -1, 0}}, {"size", {4, 4}}}};  // metres, not scaled
    test::write_text(dir_ / "scenario.json", doc.dump());
    Scenario s = load_scenario(dir_ / "scenario.json");
    EXPECT_DOUBLE_EQ(s.scale, 0.001);
    EXPECT_DOUBLE_EQ(s.scene.positions[1].x, 0.001);  // the quad's corner (1, 0, 0)
    EXPECT_DOUBLE_EQ(s.scene.positions[2].z, -0.001);
    EXPECT_DOUBLE_EQ(s.scene.positions[4].x, -2.0);  // the plane, as written
    EXPECT_DOUBLE_EQ(s.scene.bounds.hi.x, 2.0);
    EXPECT_NEAR(s.camera.eye.y, 0.002, 1e-15);
    EXPECT_NEAR(s.camera.eye.z, 0.003, 1e-15);
    EXPECT_NEAR(s.camera.znear, 0.05e-3, 1e-15);
    EXPECT_NEAR(s.camera.zfar, 0.1, 1e-12);
    EXPECT_NEAR(s.camera.yfov_rad, 0.8, 1e-12);  // angles do not scale
    ASSERT_EQ(s.lights.size(), 1u);
    EXPECT_NEAR(s.lights[0].position.z, 0.003, 1e-15);
}

TEST_F(ScenarioTest, RefusesScalesOutOfRange) {
    for (double bad : {0.0, -1.0, 1e-7, 2e6}) {
        auto doc = valid();
        doc["scale"] = bad;
        EXPECT_NE(error_of(doc).find("scenario.json: scale: expected a factor in [1e-6, 1e6] (model units to metres)"),
                  std::string::npos)
            << bad;
    }
    auto doc = valid();
    doc["scale"] = "mm";
    EXPECT_EQ(error_of(doc), "scenario.json: scale: expected a number, got string");
    // A scene near the coordinate limit scaled beyond it.
    test::GltfFixture g;
    g.doc["nodes"][0]["translation"] = {1e12, 0, 0};
    g.write(dir_);
    doc = valid();
    doc["scale"] = 1e4;
    EXPECT_EQ(error_of(doc),
              "scenario.json: scale: the scaled scene reaches 1e+16 m, beyond the 1e+15 m coordinate limit");
}

// "scene" as a list of models (#48): each stood upright, scaled, rotated and moved, then appended.
TEST_F(ScenarioTest, PlacesSeveralModels) {
    auto doc = valid();
    doc["scene"] = {"scene.gltf", {{"model", "scene.gltf"},
                                   {"translation", {10, 0, 0}},
                                   {"rotation_deg", {0, 90, 0}},
                                   {"scale", 2},
                                   {"up", "z"}}};
    test::write_text(dir_ / "scenario.json", doc.dump());
    Scenario s = load_scenario(dir_ / "scenario.json");
    ASSERT_EQ(s.models.size(), 2u);
    EXPECT_EQ(s.scene_file, s.models[0].file);
    ASSERT_EQ(s.scene.triangle_count(), 4u);
    const std::size_t base = s.scene.positions.size() / 2;  // the second model's vertices follow the first's
    // (1, 0, 0): Z-up turn (x, z, -y) = (1, 0, 0); x2 = (2, 0, 0); 90 deg about +Y = (0, 0, -2); + (10, 0, 0).
    EXPECT_NEAR(s.scene.positions[base + 1].x, 10, 1e-12);
    EXPECT_NEAR(s.scene.positions[base + 1].y, 0, 1e-12);
    EXPECT_NEAR(s.scene.positions[base + 1].z, -2, 1e-12);
    // (1, 0, -1): turned (1, -1, 0), x2 (2, -2, 0), about +Y (0, -2, -2), moved to (10, -2, -2).
    EXPECT_NEAR(s.scene.positions[base + 2].x, 10, 1e-12);
    EXPECT_NEAR(s.scene.positions[base + 2].y, -2, 1e-12);
    EXPECT_NEAR(s.scene.positions[base + 2].z, -2, 1e-12);
    // The second model's triangles index its own vertices, on a node of their own.
    EXPECT_GE(s.scene.triangles[2].x, base);
    EXPECT_NE(s.scene.triangle_node[2], s.scene.triangle_node[0]);
    EXPECT_NEAR(s.scene.bounds.lo.y, -2, 1e-12);
    EXPECT_NEAR(s.scene.bounds.hi.x, 10, 1e-12);
    EXPECT_TRUE(scene_files_json(s).is_array());

    // A quaternion in glTF's order: 180 deg about +Y takes (1, 0, 0) to (-1, 0, 0).
    doc["scene"] = {{{"model", "scene.gltf"}, {"rotation", {0, 1, 0, 0}}}};
    test::write_text(dir_ / "scenario.json", doc.dump());
    s = load_scenario(dir_ / "scenario.json");
    EXPECT_NEAR(s.scene.positions[1].x, -1, 1e-12);
    EXPECT_TRUE(scene_files_json(s).is_string());

    // "up" at the top stands a single model upright: (1, 0, -1) turned (x, z, -y) is (1, -1, 0).
    doc = valid();
    doc["up"] = "z";
    test::write_text(dir_ / "scenario.json", doc.dump());
    s = load_scenario(dir_ / "scenario.json");
    EXPECT_NEAR(s.scene.positions[2].y, -1, 1e-12);
    EXPECT_NEAR(s.scene.positions[2].z, 0, 1e-12);
}

TEST_F(ScenarioTest, RefusesBadModelListsNamingTheEntry) {
    const auto with_scene = [&](const nlohmann::json& scene) {
        auto doc = valid();
        doc["scene"] = scene;
        return error_of(doc);
    };
    EXPECT_EQ(with_scene(nlohmann::json::array()),
              "scenario.json: scene: expected a glTF file or a non-empty array of models");
    EXPECT_EQ(with_scene({"scene.gltf", "none.glb"}).find("scenario.json: scene[1].model: no such file: "), 0u);
    EXPECT_EQ(with_scene({{{"model", "scene.gltf"}, {"rotation", {0, 0, 0, 2}}}}),
              "scenario.json: scene[0].rotation: length 2; expected a unit quaternion [x, y, z, w]");
    EXPECT_EQ(with_scene({{{"model", "scene.gltf"}, {"rotation", {0, 0, 1}}}}),
              "scenario.json: scene[0].rotation: expected a quaternion [x, y, z, w]");
    EXPECT_EQ(with_scene({{{"model", "scene.gltf"}, {"rotation", {0, 0, 0, 1}}, {"rotation_deg", {0, 0, 0}}}}),
              "scenario.json: scene[0].rotation_deg: given with \"rotation\": one rotation, a quaternion or Euler "
              "angles");
    EXPECT_EQ(with_scene({{{"model", "scene.gltf"}, {"up", "x"}}}),
              "scenario.json: scene[0].up: \"x\": expected \"y\" (glTF's) or \"z\" (a Z-up model)");
    EXPECT_EQ(with_scene({{{"model", "scene.gltf"}, {"scale", 0}}}).find("scenario.json: scene[0].scale: "), 0u);
    EXPECT_EQ(with_scene({{{"model", "scene.gltf"}, {"translation", {2e15, 0, 0}}}}).find("scenario.json: scene[0].translation: "), 0u);
    EXPECT_EQ(with_scene({{{"model", "scene.gltf"}, {"shear", 1}}}).find("scenario.json: scene[0].shear: unknown key"), 0u);
    EXPECT_NE(with_scene({3}).find("scene[0]"), std::string::npos);
}

TEST_F(ScenarioTest, AGltfCameraTakesAFarPlane) {
    test::GltfFixture g;
    g.doc["cameras"] = {{{"type", "perspective"}, {"perspective", {{"yfov", 0.8}, {"znear", 0.05}}}}};
    g.doc["nodes"].push_back({{"camera", 0}, {"translation", {0, 2, 3}}});
    g.doc["scenes"][0]["nodes"] = {0, 1};
    g.write(dir_);
    auto doc = valid();
    doc["camera"] = {{"gltf_camera", 0}, {"zfar", 40}};
    test::write_text(dir_ / "scenario.json", doc.dump());
    EXPECT_DOUBLE_EQ(load_scenario(dir_ / "scenario.json").camera.zfar, 40);
    doc["camera"]["zfar"] = 0.01;
    EXPECT_EQ(error_of(doc).find("scenario.json: camera.zfar: must exceed the glTF camera's znear"), 0u);
}

// "camera_path" (issue #34, shimmer): keys in the camera format, frames linear between them.
nlohmann::json path_key(glm::dvec3 eye, glm::dvec3 target, double yfov_deg) {
    return {{"type", "perspective"},
            {"eye", {eye.x, eye.y, eye.z}},
            {"target", {target.x, target.y, target.z}},
            {"yfov_deg", yfov_deg},
            {"znear", 0.5},
            {"zfar", 100}};
}

TEST_F(ScenarioTest, CameraPathFramesAreLinearBetweenKeys) {
    auto doc = valid();
    doc.erase("camera");  // the path's first frame stands for it
    doc["camera_path"] = {{"frames", 5},
                          {"keys", {path_key({0, 2, 4}, {0, 0, 0}, 40), path_key({4, 2, 4}, {4, 0, 0}, 60)}}};
    test::write_text(dir_ / "scenario.json", doc.dump());
    const Scenario s = load_scenario(dir_ / "scenario.json");
    ASSERT_TRUE(s.camera_path);
    const CameraPath& path = *s.camera_path;
    EXPECT_EQ(path.frames, 5);
    ASSERT_EQ(path.keys.size(), 2u);
    EXPECT_EQ(s.camera.eye, glm::dvec3(0, 2, 4));
    for (int f = 0; f < 5; ++f) {
        const std::optional<Camera> c = path_camera(path, f);
        ASSERT_TRUE(c);
        const double t = f / 4.0;
        EXPECT_NEAR(c->eye.x, 4 * t, 1e-12) << f;
        EXPECT_NEAR(c->eye.y, 2, 1e-12);
        EXPECT_NEAR(c->yfov_rad, (40 + 20 * t) * M_PI / 180, 1e-12) << f;
        // A pan: the same view direction all along, up stays up.
        EXPECT_NEAR(glm::dot(c->forward, glm::normalize(glm::dvec3(0, -2, -4))), 1, 1e-12) << f;
        EXPECT_NEAR(c->up.y, std::sqrt(0.8), 1e-12) << f;
        EXPECT_DOUBLE_EQ(c->znear, 0.5);
        EXPECT_DOUBLE_EQ(c->zfar, 100);
    }
    // The end frames are the keys themselves, bit for bit.
    EXPECT_EQ(path_camera(path, 0)->forward, path.keys[0].camera.forward);
    EXPECT_EQ(path_camera(path, 4)->eye, path.keys[1].camera.eye);
    EXPECT_EQ(path_camera(path, 4)->yfov_rad, path.keys[1].camera.yfov_rad);

    // Three keys over 5 frames: frame 2 is the middle key, frame 1 half-way to it.
    doc["camera_path"] = {
        {"frames", 5},
        {"keys",
         {path_key({0, 2, 4}, {0, 0, 0}, 40), path_key({2, 2, 4}, {2, 0, 0}, 40), path_key({2, 2, 8}, {2, 0, 4}, 40)}}};
    doc["camera"] = valid()["camera"];  // an explicit camera stays the scenario's camera
    test::write_text(dir_ / "scenario.json", doc.dump());
    const Scenario three = load_scenario(dir_ / "scenario.json");
    EXPECT_EQ(three.camera.eye, glm::dvec3(0, 2, 3));
    EXPECT_EQ(path_camera(*three.camera_path, 2)->eye, glm::dvec3(2, 2, 4));
    EXPECT_NEAR(path_camera(*three.camera_path, 1)->eye.x, 1, 1e-12);
    EXPECT_NEAR(path_camera(*three.camera_path, 3)->eye.z, 6, 1e-12);
    // Without a path the scenario has none.
    test::write_text(dir_ / "scenario.json", valid().dump());
    EXPECT_FALSE(load_scenario(dir_ / "scenario.json").camera_path);
}

TEST_F(ScenarioTest, CameraPathErrorsNameTheKeyPath) {
    auto with_path = [&](nlohmann::json path) {
        auto doc = valid();
        doc["camera_path"] = std::move(path);
        return error_of(doc);
    };
    const nlohmann::json a = path_key({0, 2, 4}, {0, 0, 0}, 40), b = path_key({4, 2, 4}, {4, 0, 0}, 40);
    EXPECT_EQ(with_path({{"frames", 1}, {"keys", {a, b}}}),
              "scenario.json: camera_path.frames: expected an integer in [2, 10000] (got 1)");
    EXPECT_EQ(with_path({{"keys", {a, b}}}), "scenario.json: camera_path.frames: missing required key");
    EXPECT_EQ(with_path({{"frames", 3}, {"keys", nlohmann::json::array()}}),
              "scenario.json: camera_path.keys: expected an array of at least one camera");
    nlohmann::json bad = b;
    bad["yfov_deg"] = 0;
    EXPECT_EQ(with_path({{"frames", 3}, {"keys", {a, bad}}}).rfind("scenario.json: camera_path.keys[1].yfov_deg: ", 0),
              0u);
    bad = b;
    bad["fov_deg"] = 40;
    EXPECT_EQ(with_path({{"frames", 3}, {"keys", {a, bad}}})
                  .rfind("scenario.json: camera_path.keys[1].fov_deg: unknown key", 0),
              0u);
    bad = {{"type", "orthographic"}, {"eye", {0, 2, 4}}, {"target", {0, 0, 0}}, {"xmag", 1}, {"ymag", 1}};
    EXPECT_EQ(
        with_path({{"frames", 3}, {"keys", {a, bad}}}),
        "scenario.json: camera_path.keys[1].type: differs from keys[0]'s: a path interpolates one kind of camera");
    EXPECT_EQ(with_path({{"frames", 3}, {"keys", {a, b}}, {"loop", true}}),
              "scenario.json: camera_path.loop: unknown key");
    EXPECT_EQ(with_path({{"frames", 2}, {"keys", {a, b, a}}}),
              "scenario.json: camera_path.keys: 3 keys for 2 frames: every key must be a frame");
    EXPECT_EQ(with_path(nlohmann::json::array()), "scenario.json: camera_path: expected an object");
    // Keys fine on their own whose in-between frame looks nowhere: the eye passes through the
    // target half-way (frame 1 of 3).
    const nlohmann::json from = path_key({0, 0, 2}, {0, 0, 0}, 40), to = path_key({0, 0, -2}, {0, 0, 0}, 40);
    EXPECT_EQ(with_path({{"frames", 3}, {"keys", {from, to}}}).rfind("scenario.json: camera_path.keys: frame 1 ", 0),
              0u);
    // Neither camera nor camera_path: the camera is required, as before.
    auto doc = valid();
    doc.erase("camera");
    EXPECT_EQ(error_of(doc), "scenario.json: camera: missing required key");
}

}  // namespace
}  // namespace penumbra
