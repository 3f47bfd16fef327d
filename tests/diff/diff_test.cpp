// `penumbra diff`'s comparison: what "worse" means, identical runs, runs of other scenarios and
// malformed files refused with the file and the JSON path named (docs/design.md, "penumbra diff").
#include "pipeline/diff.h"

#include <gtest/gtest.h>

#include "common/errors.h"

namespace penumbra::diff {
namespace {

nlohmann::json classes(double acne, double other = 0.0) {
    return {{"acne", acne}, {"peter_panning", other}, {"aliasing", other}, {"false_shadow", 0.0}, {"false_lit", 0.0}};
}

nlohmann::json counts(std::uint64_t acne) {
    return {{"acne", acne}, {"peter_panning", 0}, {"aliasing", 0}, {"false_shadow", 0}, {"false_lit", 0}};
}

// A validate report.json with one light whose visible acne rate is `visible_acne` (and all-pixel
// acne rate twice that).
nlohmann::json report(double visible_acne, std::string camera = "c0") {
    nlohmann::json light = {{"index", 0},
                            {"type", "directional"},
                            {"pixels", {{"scored", 1000}}},
                            {"counts", counts(static_cast<std::uint64_t>(2000 * visible_acne))},
                            {"rates", classes(2 * visible_acne)},
                            {"counts_visible", counts(static_cast<std::uint64_t>(1000 * visible_acne))},
                            {"rates_visible", classes(visible_acne)},
                            {"wrong_fraction", 2 * visible_acne},
                            {"perceptual", {{"mean", visible_acne}, {"max", 1.0}}}};
    return {{"version", "test"},
            {"scenario", "scenario.json"},
            {"image", {{"width", 64}, {"height", 32}}},
            {"technique", {{"resolution", 2048}}},
            {"fingerprint", {{"scene", "s0"}, {"camera", camera}, {"lights", "l0"}}},
            {"scoring", {{{"light", 0}, {"tolerance", 1.0 / 255}, {"visible_threshold", 0.1}}}},
            {"lights", {light}}};
}

diff::Run run(const nlohmann::json& doc, const char* name = "a/report.json") {
    return parse_run(doc, name);
}

TEST(Diff, IdenticalRunsAreNotWorse) {
    const DiffResult d = diff_runs(run(report(0.01)), run(report(0.01), "b/report.json"), 0.0);
    EXPECT_FALSE(d.worse());
    EXPECT_TRUE(d.identical());
    EXPECT_TRUE(d.warnings.empty());
}

TEST(Diff, ARiseOfAVisibleRateBeyondTheToleranceIsWorseAndNamesTheLightAndClass) {
    const DiffResult d = diff_runs(run(report(0.01)), run(report(0.05), "b/report.json"), 0.0);
    ASSERT_TRUE(d.worse());
    ASSERT_EQ(d.worse_lines.size(), 1u);
    EXPECT_NE(d.worse_lines[0].find("light 0 (directional): acne visible rate"), std::string::npos) << d.worse_lines[0];
    EXPECT_TRUE(d.lights[0].visible_basis);
    EXPECT_NEAR(d.lights[0].classes[0].change, 0.04, 1e-12);
    EXPECT_FALSE(d.identical());
}

TEST(Diff, TheToleranceIsAbsoluteOnTheVisibleRate) {
    const diff::Run a = run(report(0.01)), b = run(report(0.05), "b/report.json");
    EXPECT_FALSE(diff_runs(a, b, 0.04 + 1e-9).worse());  // the all-pixel rate rose by 0.08: not the basis
    EXPECT_TRUE(diff_runs(a, b, 0.04 - 1e-9).worse());
}

TEST(Diff, ABetterRunIsNotWorse) {
    const DiffResult d = diff_runs(run(report(0.05)), run(report(0.01), "b/report.json"), 0.0);
    EXPECT_FALSE(d.worse());
    EXPECT_FALSE(d.identical());
}

TEST(Diff, WithoutVisibleCountsTheRatesAreCompared) {
    nlohmann::json a = report(0.01), b = report(0.01);
    b["lights"][0]["rates"]["aliasing"] = 0.2;
    for (auto* doc : {&a, &b}) {
        (*doc)["lights"][0].erase("counts_visible");
        (*doc)["lights"][0].erase("rates_visible");
    }
    const DiffResult d = diff_runs(run(a), run(b, "b/report.json"), 0.1);
    EXPECT_FALSE(d.lights[0].visible_basis);
    ASSERT_EQ(d.worse_lines.size(), 1u);
    EXPECT_NE(d.worse_lines[0].find("aliasing rate"), std::string::npos) << d.worse_lines[0];
}

// light_bleeding is newer than the other classes: a run without it reads it as 0, and a rise of
// it in the other run is worse like any class's.
TEST(Diff, LightBleedingIsComparedAndAbsentInOlderRunsIsZero) {
    nlohmann::json b = report(0.01);
    b["lights"][0]["counts_visible"]["light_bleeding"] = 50;
    b["lights"][0]["rates_visible"]["light_bleeding"] = 0.05;
    b["lights"][0]["counts"]["light_bleeding"] = 50;
    b["lights"][0]["rates"]["light_bleeding"] = 0.05;
    const DiffResult d = diff_runs(run(report(0.01)), run(b, "b/report.json"), 0.01);
    ASSERT_EQ(d.worse_lines.size(), 1u);
    EXPECT_NE(d.worse_lines[0].find("light_bleeding visible rate"), std::string::npos) << d.worse_lines[0];
}

TEST(Diff, RunsOfOtherScenariosAreRefusedNamingWhatDiffers) {
    try {
        diff_runs(run(report(0.01)), run(report(0.01, "c1"), "b/report.json"), 0.0);
        FAIL() << "another camera was diffed";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("the camera differs"), std::string::npos) << e.what();
        EXPECT_EQ(std::string(e.what()).find("scene"), std::string::npos) << e.what();
    }
    nlohmann::json other = report(0.01);
    other["image"]["width"] = 65;
    other["lights"][0]["type"] = "spot";
    try {
        diff_runs(run(report(0.01)), run(other, "b/report.json"), 0.0);
        FAIL() << "another image and light were diffed";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("image 64x32 against 65x32"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("lights 1 (directional) against 1 (spot)"), std::string::npos) << e.what();
    }
}

TEST(Diff, WithoutAFingerprintTheScenarioFileDecidesWithAWarning) {
    nlohmann::json a = report(0.01), b = report(0.01);
    a.erase("fingerprint");
    EXPECT_EQ(diff_runs(run(a), run(b, "b/report.json"), 0.0).warnings.size(), 1u);
    b["scenario"] = "other.json";
    EXPECT_THROW(diff_runs(run(a), run(b, "b/report.json"), 0.0), InputError);
}

TEST(Diff, MalformedRunsNameTheFileAndThePath) {
    nlohmann::json bad = report(0.01);
    bad["lights"][0]["rates_visible"]["acne"] = "high";
    try {
        run(bad, "b/report.json");
        FAIL() << "a string rate was read";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("b/report.json: lights[0].rates_visible.acne"), std::string::npos)
            << e.what();
    }
    EXPECT_THROW(run(nlohmann::json::array()), InputError);
    EXPECT_THROW(run(nlohmann::json{{"image", {{"width", 1}, {"height", 1}}}, {"technique", {}}}), InputError);
    EXPECT_THROW(read_run("/nonexistent/penumbra/report.json"), InputError);
}

TEST(Diff, StressRunsArePairedByCaseAndLight) {
    auto stress = [](double acne, const char* second_case) {
        nlohmann::json light = report(acne)["lights"][0];
        light.erase("counts_visible");
        light.erase("rates_visible");
        return nlohmann::json{{"version", "test"},
                              {"image", {{"width", 160}, {"height", 120}}},
                              {"technique", nlohmann::json::object()},
                              {"seed", 20},
                              {"cases",
                               {{{"name", "far_1e7"}, {"triangles", 12}, {"lights", {light}}},
                                {{"name", second_case}, {"triangles", 12}, {"lights", {light}}}}}};
    };
    const DiffResult d =
        diff_runs(run(stress(0.01, "grazing"), "a/stress.json"), run(stress(0.02, "grazing"), "b/stress.json"), 0.0);
    ASSERT_EQ(d.worse_lines.size(), 2u);
    EXPECT_NE(d.worse_lines[0].find("far_1e7 light 0 (directional): acne rate"), std::string::npos) << d.worse_lines[0];
    EXPECT_EQ(d.lights[1].a.class_map, std::filesystem::path("a/grazing.light0.classes.png"));
    try {
        diff_runs(run(stress(0.01, "grazing"), "a/stress.json"), run(stress(0.01, "needles"), "b/stress.json"), 0.0);
        FAIL() << "other cases were diffed";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("cases only in A: grazing"), std::string::npos) << e.what();
    }
    EXPECT_THROW(diff_runs(run(stress(0.01, "grazing"), "a/stress.json"), run(report(0.01)), 0.0), InputError);
}

}  // namespace
}  // namespace penumbra::diff
