// report: report.json keys, the files validate writes, legends drawn into the PNGs, JUnit.
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <fstream>
#include <tuple>

#include "common/preview.h"
#include "report/bitmap_font.h"
#include "report/report_files.h"
#include "tests/metrics/synthetic_frames.h"
#include "tests/test_support.h"

namespace penumbra::report {
namespace {

struct Fixture {
    Scenario scenario;
    test::Frames frames{64, 40};
    metrics::FrameScore score;
    metrics::Gate gate;
    metrics::GateResult gate_result;
    ReportInputs in;

    explicit Fixture(const char* gate_text) {
        scenario.width = 64;
        scenario.height = 40;
        scenario.lights.push_back(test::directional({0, -1, 0}));
        frames.shadow(5, 0.01f);  // one lost contact shadow: peter-panning (bias 0, footprint 0.01)
        score = frames.score();
        if (gate_text) {
            gate = metrics::parse_gate(nlohmann::json::parse(gate_text), "gate.json", scenario.lights,
                                       metrics::GateOrigin::file);
            gate_result = metrics::evaluate_gate(gate, score.lights);
        }
        in.version = "test";
        in.scenario = &scenario;
        in.scenario_file = "scenes/contact.json";
        in.technique = {{"resolution", 1024}};
        in.scoring = {metrics::ScoringOptions{}};
        in.timing = {{"oracle_s", 0.1}, {"raster_s", 0.2}, {"metrics_s", 0.01}, {"raster_ms", {{"shadow", 1.0}}}};
        in.gate = gate_text ? &gate_result : nullptr;
    }
};

TEST(Report, JsonHasDesignKeysAndTheGate) {
    Fixture f(R"({"checks": [{"metric": "rates.peter_panning", "max": 0.0}]})");
    nlohmann::json r = report_json(f.in, f.score);
    for (const char* k : {"version", "scenario", "image", "technique", "lights", "timing", "gate"})
        EXPECT_TRUE(r.contains(k)) << k;
    EXPECT_EQ(r["lights"][0]["index"], 0);
    EXPECT_EQ(r["lights"][0]["type"], "directional");
    EXPECT_EQ(r["lights"][0]["counts"]["peter_panning"], 1);
    EXPECT_FALSE(r["gate"]["passed"].get<bool>());
    EXPECT_EQ(r["gate"]["checks"][0]["message"], fmt::format("light 0: rates.peter_panning = {} > 0", 1.0 / 2560));
}

TEST(Report, WritesEveryFileWithLegendsAndEmbeddedImages) {
    Fixture f(nullptr);
    nlohmann::json r = report_json(f.in, f.score);
    test::TempDir dir;
    {
        OutputTransaction out(dir.path());
        write_report(out, f.in, f.frames.o, f.frames.r, f.score, r);
        out.commit();
    }
    for (const char* name :
         {"errors.exr", "light0.classes.png", "light0.error.png", "light0.compare.png", "report.json", "report.html"})
        EXPECT_TRUE(std::filesystem::exists(dir / name)) << name;
    auto classes = OIIO::ImageInput::open((dir / "light0.classes.png").string());
    ASSERT_TRUE(classes);
    EXPECT_EQ(classes->spec().width, 64);
    EXPECT_GT(classes->spec().height, 40);  // the legend band under the image
    auto errors = OIIO::ImageInput::open((dir / "errors.exr").string());
    ASSERT_TRUE(errors);
    const auto& names = errors->spec().channelnames;
    EXPECT_NE(std::find(names.begin(), names.end(), "light0.class"), names.end());
    EXPECT_NE(std::find(names.begin(), names.end(), "light0.error"), names.end());
    std::ifstream html(dir / "report.html");
    std::string text((std::istreambuf_iterator<char>(html)), std::istreambuf_iterator<char>());
    EXPECT_EQ(text.find("src=\"light0"), std::string::npos) << "images must be embedded, not linked";
    std::size_t images = 0;
    for (std::size_t at = 0; (at = text.find("data:image/png;base64,", at)) != std::string::npos; ++at) ++images;
    EXPECT_EQ(images, 4u);                            // the three maps, and the class map's thumbnail in the summary
    EXPECT_EQ(text.find("Gate"), std::string::npos);  // no gate given, none shown
}

std::string read_text(const std::filesystem::path& file) {
    std::ifstream in(file);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

TEST(Report, TheLightObjectsAndThePageReadTheTypedScore) {
    Fixture f(R"({"checks": [{"metric": "acne_depth.max", "max": 0.01}]})");
    f.frames.drop_lookups();  // an engine's frame: V only
    metrics::ScoringOptions opt;
    opt.texel_footprint_m = 0.01f;
    f.in.scoring = {opt};
    f.score = f.frames.score(opt);
    f.gate_result = metrics::evaluate_gate(f.gate, f.score.lights);
    nlohmann::json r = report_json(f.in, f.score);
    nlohmann::json expected = metrics::to_json(f.score.lights[0]);
    expected["index"] = 0;
    expected["type"] = "directional";
    EXPECT_EQ(r["lights"][0], expected);
    EXPECT_EQ(r["lights"][0]["evidence"]["source"], "oracle_geometry");
    EXPECT_EQ(r["scoring"][0]["texel_footprint_m"], 0.01f);
    EXPECT_TRUE(r["gate"]["checks"][0]["value"].is_null());
    test::TempDir dir;
    {
        OutputTransaction out(dir.path());
        write_report(out, f.in, f.frames.o, f.frames.r, f.score, r);
        out.commit();
    }
    const std::string html = read_text(dir / "report.html");
    EXPECT_NE(html.find("the oracle&#39;s geometry (V only): texel footprint 0.01 m (given)"), std::string::npos);
    EXPECT_NE(html.find(">acne_depth.max</td><td>not measured</td>"), std::string::npos) << "a table row";
    EXPECT_NE(html.find(">peter_panning_gap.max</td><td>0.01</td><td>metres</td>"), std::string::npos);
    EXPECT_NE(html.find("id=\"gate\">FAILED"), std::string::npos);
    // The answer first (issue 33): the summary, a row per light, and the class maps as
    // thumbnails come before the first light's section.
    const std::size_t summary = html.find("id=\"summary-table\""), first_light = html.find("id=\"light-0\"");
    ASSERT_NE(summary, std::string::npos);
    EXPECT_LT(summary, first_light);
    EXPECT_LT(html.find("alt=\"class map, light 0, thumbnail\""), first_light);
    EXPECT_LT(html.find("<a href=\"#light-0\">0 (directional)</a>"), first_light);
    EXPECT_NE(junit_xml(f.in).find("acne_depth.max is not measured for this light"), std::string::npos);
}

TEST(Report, JunitHasOneTestcasePerLightAndCheck) {
    Fixture f(R"({"checks": [{"metric": "rates.peter_panning", "max": 0.5}, {"metric": "mae", "max": 0.0}]})");
    const std::string xml = junit_xml(f.in);
    std::size_t cases = 0;
    for (std::size_t at = 0; (at = xml.find("<testcase ", at)) != std::string::npos; ++at) ++cases;
    EXPECT_EQ(cases, 2u);
    EXPECT_NE(xml.find("tests=\"2\" failures=\"1\""), std::string::npos) << xml;
    EXPECT_NE(xml.find("<failure message=\"light 0: mae = "), std::string::npos) << xml;
    EXPECT_NE(xml.find("classname=\"penumbra.contact.light0\" name=\"rates.peter_panning &lt;= 0.5\""),
              std::string::npos)
        << xml;
}

// The visibility preview, pixel by pixel: background where nothing is seen, a light's tint
// where it reaches, dark where it is blocked, magenta where the oracle is unsure, relief from
// the normal; rows are independent of each other.
TEST(VisibilityPreview, ColoursEachPixelByWhatReachesIt) {
    const std::vector<float> A = {0, 1, 1, 1, 1, 1};
    const std::vector<glm::vec3> N = {{0, 1, 0}, {0, 1, 0}, {0, 1, 0}, {0, 1, 0}, {0, -1, 0}, {1, 0, 0}};
    const std::vector<float> V = {1, 1, 0, 1, 1, 1};
    const std::vector<float> U = {0, 0, 0, 1, 0, 0};
    const VisibilityPreview preview{3, &A, &N, {{&V, &U}}};
    std::vector<float> rgb(18);
    preview.row(1, rgb.data() + 9);  // rows in any order
    preview.row(0, rgb.data());
    auto px = [&](int i) { return glm::vec3(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]); };
    const glm::vec3 lit = 0.1f + 0.85f * glm::vec3(1.0f, 0.86f, 0.62f);  // the first light's tint
    EXPECT_EQ(px(0), glm::vec3(0.06f, 0.07f, 0.09f));
    EXPECT_EQ(px(1), lit);
    EXPECT_EQ(px(2), glm::vec3(0.1f));
    EXPECT_EQ(px(3), glm::vec3(0.95f, 0.1f, 0.9f));
    EXPECT_EQ(px(4), lit);         // |N.y| = 1 facing down too
    EXPECT_EQ(px(5), 0.6f * lit);  // a wall: the darkest relief

    const VisibilityPreview flat{3, &A, nullptr, {}};  // no normals, no lights: every seen pixel lit
    flat.row(1, rgb.data());
    EXPECT_EQ(px(2), glm::vec3(0.1f + 0.85f * 1.0f));
}

TEST(BitmapFont, DrawsInsideTheImageOnly) {
    std::vector<float> rgb(3 * 20 * 10, 0.0f);
    draw_text(rgb, 20, 10, 15, 5, "AB", {1, 1, 1});  // mostly off the right and bottom edges
    int lit = 0;
    for (float v : rgb) lit += v > 0;
    EXPECT_GT(lit, 0);
    std::vector<float> blank(3 * 20 * 10, 0.0f);
    draw_text(blank, 20, 10, 2, 2, " ", {1, 1, 1});
    for (float v : blank) EXPECT_EQ(v, 0.0f);
}

// validate --class-map-tint cascade: a cascaded light's class map (report.json has its cascades)
// tinted by the layer each pixel's lookup used, the tints in the legend; otherwise untinted.
// Writes the report of `f` with report.json `r` and reads back the PNG `name` as 8-bit RGB:
// (pixels, width, height); empty pixels when it cannot be read.
std::tuple<std::vector<unsigned char>, int, int> written_png(const Fixture& f, const nlohmann::json& r,
                                                             const char* name) {
    test::TempDir dir;
    {
        OutputTransaction out(dir.path());
        write_report(out, f.in, f.frames.o, f.frames.r, f.score, r);
        out.commit();
    }
    auto png = OIIO::ImageInput::open((dir / name).string());
    if (!png) return {};
    const int w = png->spec().width, h = png->spec().height;
    std::vector<unsigned char> pixels(static_cast<std::size_t>(w) * h * 3);
    if (!png->read_image(0, 0, 0, 3, OIIO::TypeDesc::UINT8, pixels.data())) return {};
    return {pixels, w, h};
}

// facing.png paints the side each pixel sees: grey where the triangle's front (counter-clockwise
// as seen) faces the camera, orange where the camera sees a double-sided triangle's back.
TEST(Report, TheFacingViewPaintsFrontsGreyAndBacksOrange) {
    Fixture f(nullptr);
    f.scenario.camera = test::look_at({0, 0, 5}, {0, 0, 0}, 45);
    f.scenario.scene.positions = {{-9, -9, 0}, {9, -9, 0}, {0, 9, 0}};
    f.scenario.scene.triangles = {{0, 1, 2}, {0, 2, 1}};  // normal +z (towards the eye), then -z
    for (std::size_t i = 0; i < f.frames.o.prim.size(); ++i) f.frames.o.prim[i] = i % 64 < 32 ? 0u : 1u;
    nlohmann::json r = report_json(f.in, f.score);
    r["facing"] = {{"from_behind_px", 1}, {"meshes", nlohmann::json::array()}};
    const auto [pixels, w, h] = written_png(f, r, "facing.png");
    ASSERT_FALSE(pixels.empty());
    const unsigned char* front = &pixels[3 * (20 * 64 + 10)];
    const unsigned char* back = &pixels[3 * (20 * 64 + 50)];
    EXPECT_TRUE(front[0] == front[1] && front[1] == front[2]) << "grey: the front seen";
    EXPECT_GT(int(back[0]), int(back[1]) + 60) << "orange: a double-sided triangle's back";
    EXPECT_GT(int(back[1]), int(back[2]) + 60);
}

TEST(Report, TheClassMapCanBeTintedByCascade) {
    const auto class_map = [](bool tint, bool cascaded) {
        Fixture f(nullptr);
        f.frames.lk().layer.assign(64 * 40, 0u);
        for (std::size_t i = 0; i < 64 * 40; ++i)
            if (i % 64 >= 32) f.frames.lk().layer[i] = 1;  // the right half in cascade 1
        f.in.tint_cascades = tint;
        nlohmann::json r = report_json(f.in, f.score);
        if (cascaded) r["lights"][0]["cascades"] = nlohmann::json::array({{{"index", 0}}, {{"index", 1}}});
        auto read = written_png(f, r, "light0.classes.png");
        EXPECT_FALSE(std::get<0>(read).empty());
        return read;
    };
    // Two correct, lit pixels of one row: left in cascade 0, right in cascade 1.
    const std::size_t left = 3 * (20 * 64 + 10), right = 3 * (20 * 64 + 50);
    const auto same = [&](const std::vector<unsigned char>& p) {
        return p[left] == p[right] && p[left + 1] == p[right + 1] && p[left + 2] == p[right + 2];
    };
    const auto [tinted, w, h] = class_map(true, true);
    EXPECT_EQ(w, 64);
    EXPECT_FALSE(same(tinted));
    const auto [plain, w2, plain_h] = class_map(false, true);
    EXPECT_TRUE(same(plain));
    EXPECT_GT(h, plain_h) << "the tints' legend entries";
    // A light without cascades is never tinted.
    const auto [single, w3, single_h] = class_map(true, false);
    EXPECT_EQ(single_h, plain_h);
    EXPECT_TRUE(same(single));
    EXPECT_EQ(std::get<0>(class_map(false, false)), single);
}

}  // namespace
}  // namespace penumbra::report
