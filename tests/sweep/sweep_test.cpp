// sweep: configurations from --vary and --configs, shards, and merging shard tables back into
// one (pure: no device).
#include "sweep/sweep.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/errors.h"
#include "tests/test_support.h"

namespace penumbra::sweep {
namespace {

// An InputError's message, "accepted" when none; any other exception fails the test (it would
// reach the user as exit 3 or 4).
std::string message_of(const std::function<void()>& f) {
    try {
        f();
    } catch (const InputError& e) {
        return e.what();
    } catch (const std::exception& e) {
        ADD_FAILURE() << "not an InputError: " << e.what();
        return std::string("not an InputError: ") + e.what();
    }
    return "accepted";
}

bool has(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}

const std::vector<Light> kSun = {test::directional({0.3, -1, 0.2})};

TEST(SweepConfigs, TheProductOfTheAxesInOrderFirstAxisSlowest) {
    const std::vector<Axis> axes = {parse_axis("resolution=256,512"), parse_axis("filter.type=none,pcf,poisson")};
    const auto c = expand(nlohmann::json::object(), axes, kSun);
    ASSERT_EQ(c.size(), 6u);
    EXPECT_EQ(c[0].values, (std::vector<std::string>{"256", "none"}));
    EXPECT_EQ(c[2].values, (std::vector<std::string>{"256", "poisson"}));
    EXPECT_EQ(c[3].values, (std::vector<std::string>{"512", "none"}));
    EXPECT_EQ(c[5].technique.resolution, 512);
    EXPECT_EQ(c[5].technique.filter.type, raster::FilterType::poisson);
    for (std::size_t i = 0; i < c.size(); ++i) EXPECT_EQ(c[i].index, i);
}

TEST(SweepConfigs, BadKeysValuesAndShardsAreNamed) {
    EXPECT_NE(message_of([] { parse_axis("resolution"); }).find("--vary resolution: expected KEY=V1,V2"),
              std::string::npos);
    EXPECT_NE(message_of([] { parse_axis("resolution=256,,512"); }).find("an empty value"), std::string::npos);
    const std::string unknown = message_of([] {
        const std::vector<Axis> a = {parse_axis("resolutoin=256")};
        expand(nlohmann::json::object(), a, kSun);
    });
    EXPECT_NE(unknown.find("--vary resolutoin=256"), std::string::npos) << unknown;
    EXPECT_NE(unknown.find("resolutoin"), std::string::npos);
    const std::string value = message_of([] {
        const std::vector<Axis> a = {parse_axis("resolution=256,abc")};
        expand(nlohmann::json::object(), a, kSun);
    });
    EXPECT_NE(value.find("--vary resolution=abc"), std::string::npos) << value;
    EXPECT_EQ(parse_shard("2/3").k, 2);
    for (const char* bad : {"3/2", "0/2", "1", "a/b", "1/0", "1/2x"})
        EXPECT_NE(message_of([&] { parse_shard(bad); }).find("--shard"), std::string::npos) << bad;
}

TEST(SweepConfigs, VaryValuesMustBeUtf8) {
    // Once accepted, the preset's name reached a message through json::dump, which throws on
    // invalid UTF-8: exit 4.
    const std::string m = message_of([] {
        const std::vector<Axis> a = {parse_axis("preset=caf\xe9")};
        expand(nlohmann::json::object(), a, kSun);
    });
    EXPECT_TRUE(has(m, "--vary preset=caf\\xE9")) << m;
    EXPECT_TRUE(has(m, "UTF-8")) << m;
}

TEST(SweepConfigs, OverlappingKeysAreRefusedNamingBoth) {
    for (const auto& [first, second] :
         std::vector<std::pair<std::string, std::string>>{{"bias.slope=5", "bias={\"constant\":1}"},
                                                          {"bias={\"slope\":1}", "bias.slope=5"},
                                                          {"resolution=256", "resolution=512"}}) {
        const std::string m = message_of([&] {
            const std::vector<Axis> a = {parse_axis(first), parse_axis(second)};
            expand(nlohmann::json::object(), a, kSun);
        });
        const std::string k1 = first.substr(0, first.find('=')), k2 = second.substr(0, second.find('='));
        EXPECT_TRUE(has(m, "--vary " + k1)) << m;
        EXPECT_TRUE(k1 == k2 || has(m, "--vary " + k2)) << m;
    }
    // Keys that only share a prefix of their text do not overlap.
    const std::vector<Axis> ok = {parse_axis("filter.size=3,5"), parse_axis("filter.sizes_x=1")};
    EXPECT_NO_THROW(check_axes(ok));
}

TEST(SweepConfigs, APresetNameInConfigsKeepsTheStartingTechniquesKeys) {
    // docs/sweep.md: each entry applies over the starting technique (here --set resolution=512).
    const nlohmann::json base = {{"preset", "d3d12-textbook"}, {"resolution", 512}};
    const auto c = configs_from_json(
        nlohmann::json::array({"camera-frustum-article", nlohmann::json{{"resolution", 1024}}}), "c.json", base, kSun);
    ASSERT_EQ(c.size(), 2u);
    EXPECT_EQ(c[0].technique.preset, "camera-frustum-article");
    EXPECT_EQ(c[0].technique.depth_format, raster::DepthFormat::d32);  // the preset's, not the default's
    EXPECT_EQ(c[0].technique.resolution, 512);                         // the starting technique's, not 4096
    EXPECT_EQ(c[1].technique.preset, "d3d12-textbook");
    EXPECT_EQ(c[1].technique.resolution, 1024);
}

TEST(SweepLimits, HugeSweepsAreRefusedBeforeAnyConfigurationIsBuilt) {
    std::string thousand;
    for (int i = 0; i < 1000; ++i) {
        if (i) thousand += ',';
        thousand += std::to_string(256 + i);
    }
    const std::vector<Axis> a = {parse_axis("resolution=" + thousand), parse_axis("bias.slope=" + thousand)};
    EXPECT_EQ(product_size(a), 1000000u);
    const std::string m = message_of([&] { expand(nlohmann::json::object(), a, kSun); });
    EXPECT_TRUE(has(m, "1000000 configurations")) << m;
    EXPECT_TRUE(has(m, "resolution (1000 values) x bias.slope (1000 values)")) << m;
    const nlohmann::json many(kMaxConfigurations + 1, "pcss");
    EXPECT_TRUE(has(message_of([&] { configs_from_json(many, "c.json", {}, kSun); }), "100001 configurations"));
    // One run's estimate: 20000 configurations x (1 + 2 x 100) renders is refused, and split as
    // suggested it fits.
    const std::string run = message_of([&] { check_work(20000, 20000, 100, 3, 0, "--vary x"); });
    EXPECT_TRUE(has(run, "--vary x: 20000 of 20000 configurations")) << run;
    EXPECT_TRUE(has(run, "--shard K/N, N >= ")) << run;
    const int n = std::stoi(run.substr(run.rfind(">= ") + 3));
    EXPECT_NO_THROW(check_work(20000, shard_size(20000, {1, n}), 100, 3, 0, "--vary x"));
    EXPECT_TRUE(has(message_of([&] {
                        check_work(20000, shard_size(20000, {1, n - 1}), 100, 3, 0, "--vary x");
                    }),
                    "--vary x"));
    EXPECT_TRUE(has(message_of([&] { check_work(10, 10, 3, 3, 1024, "--vary x"); }), "--max-memory"));
    EXPECT_EQ(shard_size(5, {1, 3}), 2u);
    EXPECT_EQ(shard_size(5, {3, 3}), 1u);
}

Table shard_table(Shard s, std::size_t total) {
    Table t;
    t.scenario = "s.json";
    t.repeat = 1;
    t.device = {{"name", "gpu"}, {"driver", "1"}};
    t.fingerprint = "0123456789abcdef0123456789abcdef";
    t.keys = {"resolution"};
    t.columns = {"wrong_fraction"};
    t.total = total;
    t.shard = s;
    for (std::size_t i = 0; i < total; ++i)
        if (static_cast<int>(i % s.n) == s.k - 1) {
            Row r;
            r.index = i;
            r.values = {std::to_string(256 << i)};
            r.verdict = {0.1 * static_cast<double>(i)};
            r.technique = {{"resolution", 256 << i}};
            r.lights = nlohmann::json::array();
            r.production_ms = {1.0};
            r.diagnostic_ms = {2.0};
            t.rows.push_back(r);
        }
    return t;
}

TEST(SweepMerge, ShardsMergeIntoOneTableAndGapsOrOverlapsAreRefused) {
    const std::vector<std::string> labels = {"a", "b", "c"};
    const Table whole = shard_table({1, 1}, 5);
    const Table merged = merge({shard_table({2, 3}, 5), shard_table({1, 3}, 5), shard_table({3, 3}, 5)}, labels);
    EXPECT_EQ(to_json(merged), to_json(whole));
    EXPECT_EQ(sweep_csv(merged), sweep_csv(whole));
    EXPECT_NE(message_of([&] {
                  merge({shard_table({1, 3}, 5), shard_table({2, 3}, 5)}, labels);
              }).find("configuration 2 is in no shard"),
              std::string::npos);
    EXPECT_NE(message_of([&] {
                  merge({shard_table({1, 2}, 5), shard_table({1, 2}, 5)}, labels);
              }).find("b: configuration 0 is also in a"),
              std::string::npos);
    // Another sweep (other values, technique, tolerance: another fingerprint) with the same
    // keys and count is refused naming both; the scenario's path string alone may differ.
    Table other = shard_table({2, 2}, 5);
    other.fingerprint = "fedcba9876543210fedcba9876543210";
    const std::string m = message_of([&] { merge({shard_table({1, 2}, 5), other}, labels); });
    EXPECT_TRUE(has(m, "a and b: shards of different sweeps")) << m;
    other = shard_table({2, 2}, 5);
    other.scenario = "/abs/s.json";
    EXPECT_NO_THROW(merge({shard_table({1, 2}, 5), other}, labels));
    EXPECT_EQ(to_json(table_from_json(to_json(whole), "x")), to_json(whole));
    EXPECT_NE(message_of([] {
                  table_from_json({{"scenario", "s"}}, "x/sweep.json");
              }).find("x/sweep.json: keys: missing"),
              std::string::npos);
}

// One sweep.json edited by `edit`: the message of reading it ("accepted" when read).
std::string read_edited(const std::function<void(nlohmann::json&)>& edit) {
    nlohmann::json j = to_json(shard_table({1, 1}, 3));
    edit(j);
    return message_of([&] { table_from_json(j, "d/sweep.json"); });
}

TEST(SweepMerge, EveryFieldOfSweepJsonIsCheckedAndNamed) {
    EXPECT_EQ(read_edited([](nlohmann::json&) {}), "accepted");
    // The boundary: the last configuration is total - 1; total itself is beyond.
    EXPECT_EQ(read_edited([](nlohmann::json& j) { j["configurations"].erase(2); }), "accepted");
    EXPECT_EQ(read_edited([](nlohmann::json& j) {
                  j["configurations"].erase(2);
                  j["configurations"][1]["index"] = 2;
              }),
              "accepted");
    const std::vector<std::pair<std::string, std::function<void(nlohmann::json&)>>> bad = {
        {"configurations[0].values: expected 1 elements, got 2",
         [](nlohmann::json& j) { j["configurations"][0]["values"].push_back("x"); }},
        {"columns: expected the verdict columns", [](nlohmann::json& j) { j["columns"] = nlohmann::json::array(); }},
        {"configurations[2].index: expected an integer in [0, 2] (got 3)",
         [](nlohmann::json& j) { j["configurations"][2]["index"] = 3; }},
        {"configurations[1].index: configuration 0 appears twice",
         [](nlohmann::json& j) { j["configurations"][1]["index"] = 0; }},
        {"configurations[1].verdict.wrong_fraction: expected a fraction in [0, 1]",
         [](nlohmann::json& j) { j["configurations"][1]["verdict"]["wrong_fraction"] = -0.1; }},
        {"configurations[1].verdict.wrong_fraction: expected a finite number",
         [](nlohmann::json& j) { j["configurations"][1]["verdict"]["wrong_fraction"] = std::nan(""); }},
        {"configurations[1].verdict.wrong_fraction: missing",
         [](nlohmann::json& j) { j["configurations"][1]["verdict"].erase("wrong_fraction"); }},
        {"configurations[0].production_ms[0]: expected a finite time >= 0",
         [](nlohmann::json& j) { j["configurations"][0]["production_ms"][0] = -1.0; }},
        {"configurations[0].diagnostic_ms: expected 1 timings",
         [](nlohmann::json& j) { j["configurations"][0]["diagnostic_ms"].push_back(1.0); }},
        {"configurations[0].seconds: expected a time >= 0",
         [](nlohmann::json& j) { j["configurations"][0]["seconds"] = -2.0; }},
        {"configurations[0].lights[0]: expected an object",
         [](nlohmann::json& j) { j["configurations"][0]["lights"] = {1}; }},
        {"configurations[0].technique: expected an object",
         [](nlohmann::json& j) { j["configurations"][0]["technique"] = 3; }},
        {"keys[0]: expected a string", [](nlohmann::json& j) { j["keys"] = {7}; }},
        {"total: expected an integer in [1, 100000]", [](nlohmann::json& j) { j["total"] = 0; }},
        {"repeat: expected an integer", [](nlohmann::json& j) { j["repeat"] = 1.5; }},
        {"setup_s: expected a time >= 0", [](nlohmann::json& j) { j["setup_s"] = -1.0; }},
        {"device.name: expected a string", [](nlohmann::json& j) { j["device"]["name"] = 1; }},
        {"fingerprint: missing", [](nlohmann::json& j) { j.erase("fingerprint"); }},
        {"shard.k: expected an integer in [1, 2]",
         [](nlohmann::json& j) {
             j["shard"] = {{"k", 3}, {"n", 2}};
         }},
        {"configurations[1].index: configuration 1 is not in shard 1/2",
         [](nlohmann::json& j) {
             j["shard"] = {{"k", 1}, {"n", 2}};
         }},
        {"(top level): expected an object", [](nlohmann::json& j) { j = nlohmann::json::array(); }},
    };
    for (const auto& [expected, edit] : bad) {
        const std::string m = read_edited(edit);
        EXPECT_TRUE(has(m, "d/sweep.json: " + expected)) << expected << "\n got: " << m;
    }
}

TEST(SweepMerge, SweepCsvMustBeTheRowsOfSweepJson) {
    const Table t = shard_table({1, 1}, 3);
    const std::string json = to_json(t).dump(), csv = sweep_csv(t);
    EXPECT_EQ(to_json(read_shard(json, csv, "d")), to_json(t));
    EXPECT_EQ(to_json(read_shard(json, std::nullopt, "d")), to_json(t));
    // Two rows swapped: the lines no longer follow sweep.json's configurations.
    std::vector<std::string> lines;
    for (std::size_t at = 0, end; (end = csv.find('\n', at)) != std::string::npos; at = end + 1)
        lines.push_back(csv.substr(at, end - at));
    std::swap(lines[1], lines[2]);
    std::string swapped;
    for (const auto& l : lines) swapped += l + "\n";
    std::string m = message_of([&] { read_shard(json, swapped, "d"); });
    EXPECT_TRUE(has(m, "d/sweep.csv: line 2 does not match sweep.json (configuration 0)")) << m;
    m = message_of([&] { read_shard(json, csv.substr(0, csv.rfind('\n', csv.size() - 2) + 1), "d"); });
    EXPECT_TRUE(has(m, "d/sweep.csv: line 4")) << m;
    m = message_of([&] { read_shard("{\"keys\": [", csv, "d"); });
    EXPECT_TRUE(has(m, "d/sweep.json")) << m;
}

TEST(SweepMerge, SweepJsonCarriesSetupTimeAndFingerprint) {
    Table t = shard_table({1, 1}, 2);
    t.setup_s = 0.25;
    const nlohmann::json j = to_json(t);
    EXPECT_EQ(j.at("setup_s"), 0.25);
    EXPECT_EQ(j.at("fingerprint"), t.fingerprint);
    EXPECT_EQ(table_from_json(j, "x").setup_s, 0.25);
    // The fingerprint follows every part of the definition.
    const std::vector<std::string> keys = {"resolution"};
    const std::vector<Axis> a = {parse_axis("resolution=256,512")}, b = {parse_axis("resolution=256,1024")};
    const auto ca = expand(nlohmann::json::object(), a, kSun), cb = expand(nlohmann::json::object(), b, kSun);
    const nlohmann::json dev = {{"name", "gpu"}, {"driver", "1"}};
    const std::string f = definition_fingerprint("k", {}, keys, ca, 0.01, 3, dev);
    EXPECT_EQ(f.size(), 32u);
    EXPECT_EQ(f, definition_fingerprint("k", {}, keys, ca, 0.01, 3, dev));
    EXPECT_NE(f, definition_fingerprint("k2", {}, keys, ca, 0.01, 3, dev));
    EXPECT_NE(f, definition_fingerprint("k", {{"preset", "pcss"}}, keys, ca, 0.01, 3, dev));
    EXPECT_NE(f, definition_fingerprint("k", {}, keys, cb, 0.01, 3, dev));
    EXPECT_NE(f, definition_fingerprint("k", {}, keys, ca, 0.02, 3, dev));
    EXPECT_NE(f, definition_fingerprint("k", {}, keys, ca, 0.01, 3, {{"name", "other"}, {"driver", "1"}}));
}

// sweep.json says what each time includes and how it was taken, and per configuration the
// spread of its repeats; repeats further apart than the margin are flagged.
TEST(SweepMerge, SweepJsonSaysWhatItsTimesIncludeAndHowFarTheRepeatsSpread) {
    Table t = shard_table({1, 1}, 2);
    t.repeat = 3;
    t.rows[0].production_ms = {1.0, 1.05, 1.02};  // spread 0.05 / 1.02: within the margin
    t.rows[0].diagnostic_ms = {2.0, 2.0, 2.0};
    t.rows[1].production_ms = {1.0, 1.5, 1.1};  // 0.5 / 1.1: beyond it
    t.rows[1].diagnostic_ms = {2.0, 2.1, 2.0};
    const nlohmann::json j = to_json(t);
    const nlohmann::json& timings = j.at("timings");
    EXPECT_TRUE(has(timings.at("production_ms").get<std::string>(), "depth-only shadow pass"));
    EXPECT_TRUE(has(timings.at("diagnostic_ms").get<std::string>(), "triangle id"));
    EXPECT_EQ(timings.at("warm_up_renders"), kWarmUpRenders);
    EXPECT_EQ(timings.at("spread_margin"), kRepeatSpreadMargin);
    const nlohmann::json& r0 = j.at("configurations")[0];
    EXPECT_EQ(r0.at("production_spread").at("min"), 1.0);
    EXPECT_EQ(r0.at("production_spread").at("median"), 1.02);
    EXPECT_EQ(r0.at("production_spread").at("max"), 1.05);
    EXPECT_NEAR(r0.at("production_spread").at("spread").get<double>(), 0.05 / 1.02, 1e-12);
    EXPECT_EQ(r0.at("repeats_disagree"), false);
    const nlohmann::json& r1 = j.at("configurations")[1];
    EXPECT_NEAR(r1.at("production_spread").at("spread").get<double>(), 0.5 / 1.1, 1e-12);
    EXPECT_EQ(r1.at("repeats_disagree"), true);
    EXPECT_TRUE(repeats_disagree(t.rows[1]));
    EXPECT_FALSE(repeats_disagree(t.rows[0]));
    // One repeat has no spread; a merge writes what one run writes.
    EXPECT_EQ(spread({3.0}), 0.0);
    EXPECT_EQ(to_json(table_from_json(j, "x")), j);
}

}  // namespace
}  // namespace penumbra::sweep
