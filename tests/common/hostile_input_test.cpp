// Hostile input (issue #18): each row the fuzzing and hostile runs found has a test here at the
// level of the function that fixes it; tests/cli/hostile_input.sh replays them end to end.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cmath>
#include <fstream>
#include <string>

#include "common/errors.h"
#include "common/gltf_loader.h"
#include "common/json_reader.h"
#include "common/memory_estimate.h"
#include "common/output_files.h"
#include "common/ranges.h"
#include "common/scenario.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

using test::GltfFixture;
using test::TempDir;

template <class F>
std::string error_of(F&& f) {
    try {
        f();
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

bool contains(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}

std::string nested(int depth, const std::string& inner = "") {
    return std::string(static_cast<std::size_t>(depth), '[') + inner +
           std::string(static_cast<std::size_t>(depth), ']');
}

// ---- rows 2-5: one nesting limit for every JSON ----------------------------------------------

TEST(HostileInput, NestingUpToTheLimitIsReadAndOneLevelMoreIsRefusedWithItsPath) {
    EXPECT_NO_THROW(parse_json_strict(nested(kMaxJsonDepth), "ok.json"));
    const std::string e =
        error_of([&] { parse_json_strict(R"({"a": {"b": [1, )" + nested(kMaxJsonDepth - 2) + "]}}", "deep.json"); });
    EXPECT_TRUE(contains(e, "deep.json: a.b[1]")) << e;
    EXPECT_TRUE(contains(e, "nested deeper than 64 levels")) << e;
}

TEST(HostileInput, AMillionLevelsAreRefusedWithoutRecursing) {
    // Row 5 (--technique), row 4 (scenario technique and gate): the parser, copies and dump()
    // would each overflow the stack on this.
    const std::string e = error_of([&] { parse_json_strict(R"({"resolution": )" + nested(1000000) + "}", "t.json"); });
    EXPECT_TRUE(contains(e, "t.json: resolution[0]")) << e;
}

TEST(HostileInput, BracketsInsideStringsDoNotCount) {
    const std::string text = R"({"s": ")" + std::string(1000, '[') + R"(\"["})";
    EXPECT_NO_THROW(parse_json_strict(text, "s.json"));
}

TEST(HostileInput, AScenarioTechniqueOrGateNestedTooDeepIsRefused) {
    TempDir dir;
    GltfFixture().write(dir);
    for (const char* key : {"technique", "gate"}) {
        test::write_text(dir / "s.json",
                         std::string(R"({"scene": "scene.gltf", "image": {"width": 4, "height": 4},)") +
                             R"("camera": {"type": "perspective", "eye": [0, 2, 3], "target": [0, 0, 0],)" +
                             R"("yfov_deg": 45}, "lights": [], ")" + key + R"(": {"x": )" + nested(150000) + "}}");
        const std::string e = error_of([&] { load_scenario(dir / "s.json"); });
        EXPECT_TRUE(contains(e, fmt::format("s.json: {}.x", key))) << e;
    }
}

TEST(HostileInput, DeepGltfExtrasAndDeepWronglyTypedValuesAreRefusedBeforeTinygltf) {
    // Row 2: tinygltf's ParseJsonAsValue recursed 20,000 deep; row 3: the schema check's
    // message dumped a 100,000 deep value.
    TempDir dir;
    GltfFixture g;
    g.doc["extras"] = "@";
    std::string text = g.doc.dump();
    text.replace(text.find("\"@\""), 3, nested(20000));
    g.write(dir);
    test::write_text(dir / "scene.gltf", text);
    std::string e = error_of([&] { load_gltf(dir / "scene.gltf"); });
    EXPECT_TRUE(contains(e, "scene.gltf: extras[0]")) << e;

    g.doc.erase("extras");
    g.doc["nodes"][0]["mesh"] = "@";
    text = g.doc.dump();
    text.replace(text.find("\"@\""), 3, nested(100000, "1"));
    test::write_text(dir / "scene.gltf", text);
    e = error_of([&] { load_gltf(dir / "scene.gltf"); });
    EXPECT_TRUE(contains(e, "scene.gltf: nodes[0].mesh[0]")) << e;
}

TEST(HostileInput, SetAssignmentsNestingTooDeepAreRefused) {
    // --set a.a.a...=1 builds one object level per segment; 60,000 of them crashed the copy in
    // parse_technique (found after the issue, same class as row 5).
    std::string deep;
    for (int i = 0; i < 60000; ++i) deep += "a.";
    EXPECT_TRUE(contains(set_assignment_problem(deep + "b=1"), "60001 segments")) << set_assignment_problem(deep);
    EXPECT_EQ(set_assignment_problem("bias.slope=1.5"), "");
    EXPECT_EQ(set_assignment_problem("filter.type=pcf.x"), "");  // dots in the value do not count
    EXPECT_NE(set_assignment_problem("preset=\xff"), "");
}

// ---- row 6: bytes that are not UTF-8 ---------------------------------------------------------

TEST(HostileInput, NonUtf8BytesAreEscapedInMessagesNotThrown) {
    EXPECT_TRUE(is_valid_utf8("caf\xc3\xa9"));
    EXPECT_FALSE(is_valid_utf8("caf\xe9"));
    EXPECT_FALSE(is_valid_utf8("\xed\xa0\x80"));  // a UTF-16 surrogate
    EXPECT_FALSE(is_valid_utf8("\xc0\xaf"));      // overlong '/'
    EXPECT_EQ(escape_non_utf8("caf\xe9 \xc3\xa9"), "caf\\xE9 \xc3\xa9");
    EXPECT_TRUE(contains(utf8_problem("caf\xe9"), "caf\\xE9")) << utf8_problem("caf\xe9");
    EXPECT_EQ(utf8_problem("pcss"), "");
    nlohmann::json j = {{"preset", "\xff\xfe"}};
    EXPECT_NO_THROW(json_excerpt(j));
}

TEST(HostileInput, WrittenJsonReplacesBytesThatAreNotUtf8) {
    TempDir dir;
    {
        OutputTransaction out(dir / "out");
        out.write_json("a.json", {{"scenario", "/tmp/d\xe9j\xe0/s.json"}});
        out.commit();
    }
    std::ifstream in(dir / "out" / "a.json");
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_TRUE(contains(text, "/tmp/d\xef\xbf\xbdj")) << text;  // U+FFFD
}

// ---- row 7: NaN options ----------------------------------------------------------------------

TEST(HostileInput, OptionChecksRefuseNanAndInfinity) {
    EXPECT_NE(finite_number_problem("nan"), "");
    EXPECT_NE(finite_number_problem("-NaN"), "");
    EXPECT_NE(finite_number_problem("inf"), "");
    EXPECT_EQ(finite_number_problem("0.004"), "");
    EXPECT_EQ(finite_number_problem("abc"), "");  // not a number at all: CLI11's conversion says so
}

// ---- row 8: memory estimate ------------------------------------------------------------------

TEST(HostileInput, MemoryEstimateNamesTheTotalAndTheBiggestTerm) {
    MemoryInputs in;
    in.width = in.height = 8192;
    in.lights = 100;
    in.oracle = true;
    const MemoryEstimate e = estimate_memory(in);
    EXPECT_GT(e.total(), 100ull << 30);
    EXPECT_TRUE(contains(e.biggest().name, "oracle frame (8192x8192 px, 100 lights)")) << e.biggest().name;
    const std::string msg = error_of([&] { check_memory(e, 8ull << 30, "s.json"); });
    EXPECT_TRUE(contains(msg, "s.json: needs about")) << msg;
    EXPECT_TRUE(contains(msg, "biggest: oracle frame")) << msg;
    EXPECT_TRUE(contains(msg, "more than the 8.0 GiB")) << msg;
    EXPECT_NO_THROW(check_memory(e, UINT64_MAX, "s.json"));
}

TEST(HostileInput, MemoryEstimateSaturatesInsteadOfWrapping) {
    MemoryInputs in;
    in.triangles = UINT64_MAX / 2;
    EXPECT_EQ(estimate_memory(in).total(), UINT64_MAX);
}

TEST(HostileInput, ShadowMapsCountCubeFacesAndAreaSamples) {
    Scenario s;
    s.width = s.height = 16;
    Light rect;
    rect.type = LightType::rect;
    s.lights = {rect, Light{}};
    RasterMemory rm{16384, 4, 16};
    const MemoryInputs in = memory_inputs(s, false, &rm, false);
    EXPECT_EQ(in.raster_lights, 17u);  // 16 points for the rect, 1 directional
    EXPECT_EQ(in.shadow_layers, 6u);   // the rect's points need cube maps
    EXPECT_EQ(estimate_memory(in).biggest().bytes, 16384ull * 16384 * 6 * 8);
}

// A family without a map (shadow volumes, planar projection) counts its targets and geometry.
TEST(HostileInput, AFamilyWithoutAMapCountsItsTargetsAndGeometry) {
    Scenario s;
    s.width = 100;
    s.height = 50;
    s.lights = {Light{}, Light{}};
    s.scene.triangles.resize(1000);
    RasterMemory rm;
    rm.resolution = 0;
    rm.pixel_bytes = 12;
    rm.pixel_bytes_per_light = 4;
    rm.triangle_bytes_per_light = 192;
    const MemoryInputs in = memory_inputs(s, false, &rm, false);
    EXPECT_EQ(in.family_bytes, 5000u * (12 + 2 * 4) + 1000u * 2 * 192);
    const MemoryEstimate e = estimate_memory(in);
    bool found = false;
    for (const MemoryTerm& t : e.terms)
        found |= contains(t.name, "own targets and geometry") && t.bytes == in.family_bytes;
    EXPECT_TRUE(found);
    rm = RasterMemory{2048};  // a depth map: no such term
    EXPECT_EQ(memory_inputs(s, false, &rm, false).family_bytes, 0u);
}

TEST(HostileInput, MaxMemoryParsesSizesAndRefusesTheRest) {
    EXPECT_EQ(parse_memory_size("8G"), 8ull << 30);
    EXPECT_EQ(parse_memory_size("512MiB"), 512ull << 20);
    EXPECT_EQ(parse_memory_size("1.5k"), 1536u);
    EXPECT_EQ(parse_memory_size("4096"), 4096u);
    EXPECT_EQ(memory_budget("0"), UINT64_MAX);
    EXPECT_GT(memory_budget(""), 0u);
    for (const char* bad : {"lots", "8X", "-1G", "nan", "1e30", ""})
        EXPECT_TRUE(contains(error_of([&] { parse_memory_size(bad); }), "--max-memory")) << bad;
}

TEST(HostileInput, AFewKilobytesThatInstanceAMeshIntoBillionsOfTrianglesAreRefusedBeforeFlattening) {
    TempDir dir;
    GltfFixture g;
    g.doc["nodes"] = nlohmann::json::array();
    g.doc["scenes"][0]["nodes"] = nlohmann::json::array();
    for (int i = 0; i < 1000; ++i) {
        g.doc["nodes"].push_back({{"mesh", 0}});
        g.doc["scenes"][0]["nodes"].push_back(i);
    }
    g.write(dir);
    GltfLoadOptions options;
    options.max_memory_bytes = 1000 * 2 * kBytesPerTriangle;  // 2000 triangles fit, their vertices do not
    const std::string e = error_of([&] { load_gltf(dir / "scene.gltf", options); });
    EXPECT_TRUE(contains(e, "scene.gltf: needs about")) << e;
    EXPECT_TRUE(contains(e, "scene (2000 triangles, 4000 vertices)")) << e;
    options.max_memory_bytes = 1 << 20;
    EXPECT_EQ(load_gltf(dir / "scene.gltf", options).triangle_count(), 2000u);
}

// ---- rows 1, 9, 10, 14: one range check ------------------------------------------------------

TEST(HostileInput, CamerasOutsideTheOraclesRangeAreRefusedWhateverTheirSource) {
    Camera ortho = test::look_at_ortho({0, 2, 5}, {0, 0, 0}, 1e19, 1e19);
    EXPECT_TRUE(contains(error_of([&] { validate_camera(ortho, "x.gltf: cameras[0]"); }), "x.gltf: cameras[0]: xmag"));
    ortho.xmag = ortho.ymag = 5e-324;
    EXPECT_TRUE(camera_problem(ortho));
    ortho.xmag = ortho.ymag = 1e15;
    EXPECT_FALSE(camera_problem(ortho));
    Camera c = test::look_at({0, 2, 5}, {0, 0, 0}, 45);
    EXPECT_FALSE(camera_problem(c));
    for (double znear : {1e300, 5e-324, 0.0, -1.0}) {
        Camera bad = c;
        bad.znear = znear;
        ASSERT_TRUE(camera_problem(bad)) << znear;
        EXPECT_EQ(camera_problem(bad)->key, "znear");
    }
    Camera far = c;
    far.zfar = -1;
    EXPECT_EQ(camera_problem(far)->key, "zfar");
    Camera eye = c;
    eye.eye.x = 1e20;
    EXPECT_EQ(camera_problem(eye)->key, "eye");
}

TEST(HostileInput, LightsOutsideTheOraclesRangeAreRefusedWhateverTheirSource) {
    EXPECT_EQ(light_problem(test::point({1e300, 0, 0}))->key, "position");
    EXPECT_FALSE(light_problem(test::point({1e15, 0, 0})));
    Light spot = test::spot({0, 3, 0}, {0, -1, 0}, 30);
    spot.inner_cone_rad = spot.outer_cone_rad * 1.1;
    EXPECT_EQ(light_problem(spot)->key, "inner_cone_deg");
    EXPECT_EQ(light_problem(test::rect({0, 3, 0}, {1e100, 0, 0}, {0, 0, 1}))->key, "u");
    EXPECT_FALSE(light_problem(test::rect({0, 3, 0}, {1e15, 0, 0}, {0, 0, 1})));
    EXPECT_EQ(light_problem(test::sphere({0, 3, 0}, 1e16))->key, "radius");
}

class HostileScenario : public ::testing::Test {
  protected:
    std::string error_with(const nlohmann::json& doc) {
        test::write_text(dir_ / "s.json", doc.dump());
        return error_of([&] { load_scenario(dir_ / "s.json"); });
    }
    nlohmann::json valid(nlohmann::json lights) const {
        return {{"scene", "scene.gltf"},
                {"image", {{"width", 8}, {"height", 8}}},
                {"camera", {{"type", "perspective"}, {"eye", {0, 2, 3}}, {"target", {0, 0, 0}}, {"yfov_deg", 45}}},
                {"lights", lights}};
    }
    TempDir dir_;
};

TEST_F(HostileScenario, RectEdgesBeyondTheLimitAndOverflowingDirectionsSayWhatIsWrong) {
    GltfFixture().write(dir_);
    std::string e =
        error_with(valid({{{"type", "rect"}, {"center", {0, 3, 0}}, {"u", {1e100, 0, 0}}, {"v", {0, 0, 1}}}}));
    EXPECT_TRUE(contains(e, "s.json: lights[0].u: edge length 1e+100 m exceeds the 1e+15 m limit")) << e;
    e = error_with(valid({{{"type", "rect"}, {"center", {0, 3, 0}}, {"u", {1, 0, 0}}, {"v", {0, 0, 1e200}}}}));
    EXPECT_TRUE(contains(e, "lights[0].v: edge length 1e+200 m")) << e;
    e = error_with(valid({{{"type", "directional"}, {"direction", {1e308, -1e308, 0}}}}));
    EXPECT_TRUE(contains(e, "lights[0].direction: length overflows a double")) << e;
    e = error_with(valid({{{"type", "directional"}, {"direction", {0, 0, 0}}}}));
    EXPECT_TRUE(contains(e, "lights[0].direction: zero vector")) << e;
}

TEST_F(HostileScenario, GltfCamerasAndLightsGetTheScenariosChecks) {
    GltfFixture g;
    g.doc["extensionsUsed"] = {"KHR_lights_punctual"};
    g.doc["extensions"] = {
        {"KHR_lights_punctual",
         {{"lights",
           {{{"type", "point"}}, {{"type", "spot"}, {"spot", {{"innerConeAngle", 0.7}, {"outerConeAngle", 0.6}}}}}}}}};
    g.doc["cameras"] = {
        {{"type", "orthographic"}, {"orthographic", {{"xmag", 1e19}, {"ymag", 1e19}, {"znear", 0.1}, {"zfar", 100}}}},
        {{"type", "perspective"}, {"perspective", {{"yfov", 0.8}, {"znear", 0.1}, {"zfar", -5}}}},
        {{"type", "perspective"}, {"perspective", {{"yfov", 0.8}, {"znear", 0.1}}}}};
    g.doc["nodes"].push_back({{"camera", 0}, {"translation", {0, 2, 5}}});
    g.doc["nodes"].push_back({{"camera", 1}, {"translation", {0, 2, 5}}});
    g.doc["nodes"].push_back({{"camera", 2}, {"translation", {0, 2, 5}}});
    g.doc["nodes"].push_back(
        {{"translation", {1e300, 0, 0}}, {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}});
    g.doc["scenes"][0]["nodes"] = {0, 1, 2, 3, 4};
    g.write(dir_);
    auto doc = valid(nlohmann::json::array());
    doc["camera"] = {{"gltf_camera", 0}};
    std::string e = error_with(doc);
    EXPECT_TRUE(contains(e, "scene.gltf: cameras[0] (the scenario's camera.gltf_camera): xmag")) << e;
    doc["camera"] = {{"gltf_camera", 1}};
    e = error_with(doc);
    EXPECT_TRUE(contains(e, "scene.gltf: cameras[1]")) << e;
    EXPECT_TRUE(contains(e, "zfar: must exceed znear (-5 <= 0.1)")) << e;
    doc["camera"] = {{"gltf_camera", 2}};  // no zfar: infinite
    EXPECT_EQ(error_with(doc), "");
    doc["lights"] = "gltf";
    e = error_with(doc);
    EXPECT_TRUE(contains(e, "scene.gltf: KHR_lights_punctual.lights[0] (placed by nodes[4]): position")) << e;

    g.doc["nodes"][4]["translation"] = {0, 3, 0};
    g.doc["nodes"][4]["extensions"]["KHR_lights_punctual"]["light"] = 1;
    g.write(dir_);
    e = error_with(doc);
    EXPECT_TRUE(contains(e, "KHR_lights_punctual.lights[1] (placed by nodes[4]): inner_cone_deg")) << e;
}

// ---- rows 11, 12: files that never end, NUL bytes --------------------------------------------

TEST(HostileInput, OnlyRegularFilesAreRead) {
    TempDir dir;
    EXPECT_TRUE(
        contains(error_of([&] { read_json_file("/dev/zero", kScenarioJson); }), "/dev/zero: not a regular file"));
    ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
    EXPECT_TRUE(contains(error_of([&] { read_json_file(dir / "fifo", kScenarioJson); }), "fifo: not a regular file"));
    EXPECT_TRUE(contains(error_of([&] { load_gltf(dir / "fifo"); }), "fifo: not a regular file"));
    EXPECT_TRUE(contains(error_of([&] { read_json_file(dir.path(), kScenarioJson); }), "not a regular file"));
}

TEST(HostileInput, NulBytesAreRefused) {
    const std::string text = std::string("{\"a\": 1}") + '\0' + "garbage";
    EXPECT_TRUE(contains(error_of([&] { parse_json_strict(text, "n.json"); }), "n.json: invalid JSON at byte 9"));
    nlohmann::json j = {{"scene", std::string("scene.glb") + '\0' + ".txt"}};
    JsonObject o(j, "n.json", "");
    EXPECT_TRUE(contains(error_of([&] { o.string("scene"); }), "n.json: scene: contains a NUL character"));

    TempDir dir;
    GltfFixture g;
    g.write(dir);
    test::write_text(dir / "scene.gltf", g.doc.dump() + std::string(1, '\0') + "{");
    EXPECT_TRUE(contains(error_of([&] { load_gltf(dir / "scene.gltf"); }), "scene.gltf: JSON: a NUL byte"));
}

// ---- row 13: --junit checked before work -----------------------------------------------------

TEST(HostileInput, ResultFilesAreCheckedBeforeAnyWork) {
    TempDir dir;
    EXPECT_TRUE(
        contains(error_of([&] { check_output_file(dir / "out", dir / "out", "--junit"); }), "is the --out folder"));
    EXPECT_TRUE(contains(error_of([&] { check_output_file(dir.path(), dir / "out", "--junit"); }), "is a folder"));
    test::write_text(dir / "plain", "x");
    EXPECT_TRUE(contains(error_of([&] { check_output_file(dir / "plain" / "j.xml", dir / "out", "--junit"); }),
                         "plain is not a folder"));
    EXPECT_TRUE(contains(error_of([&] { check_output_file("/proc/j.xml", dir / "out", "--junit"); }),
                         "cannot write into /proc"));
    EXPECT_NO_THROW(check_output_file(dir / "new" / "j.xml", dir / "out", "--junit"));
    EXPECT_NO_THROW(check_output_file(dir / "out" / "j.xml", dir / "out", "--junit"));
}

// ---- row 14: glTF 1.0, GLB headers, duplicate roots ------------------------------------------

TEST(HostileInput, GltfOneIsNamedAsSuch) {
    TempDir dir;
    test::write_text(dir / "old.gltf",
                     R"({"asset": {"version": "1.0"}, "scene": "defaultScene", "scenes": {"defaultScene": {}}})");
    EXPECT_TRUE(contains(error_of([&] { load_gltf(dir / "old.gltf"); }),
                         "old.gltf: asset.version: glTF \"1.0\" is not supported"));
    test::write_text(dir / "older.gltf", R"({"scene": "defaultScene", "meshes": {}})");
    EXPECT_TRUE(contains(error_of([&] { load_gltf(dir / "older.gltf"); }), "looks like glTF 1.0"));
    std::string glb1("glTF\x01\0\0\0", 8);
    glb1 += std::string(12, '\0');
    test::write_text(dir / "old.glb", glb1);
    EXPECT_TRUE(contains(error_of([&] { load_gltf(dir / "old.glb"); }), "old.glb: GLB header: version 1"));
    test::write_text(dir / "short.glb", std::string("glTF\x02\0\0\0\xff\xff", 10));
    EXPECT_TRUE(contains(error_of([&] { load_gltf(dir / "short.glb"); }), "short.glb: GLB header: truncated"));
}

TEST(HostileInput, ARootListedTwiceIsUsedOnceWithAWarning) {
    TempDir dir;
    GltfFixture g;
    g.doc["scenes"][0]["nodes"] = {0, 0};
    Scene s = load_gltf(g.write(dir));
    EXPECT_EQ(s.triangle_count(), 2u);
    ASSERT_FALSE(s.warnings.empty());
    EXPECT_TRUE(contains(s.warnings[0], "scene.gltf: scene lists root node 0 more than once")) << s.warnings[0];
}

}  // namespace
}  // namespace penumbra
