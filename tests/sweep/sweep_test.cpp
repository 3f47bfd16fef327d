// sweep: configurations from --vary and --configs, shards, and merging shard tables back into
// one (pure: no device).
#include "sweep/sweep.h"

#include <gtest/gtest.h>

#include "common/errors.h"
#include "tests/test_support.h"

namespace penumbra::sweep {
namespace {

std::string message_of(const std::function<void()>& f) {
    try {
        f();
    } catch (const InputError& e) {
        return e.what();
    }
    return "accepted";
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

Table shard_table(Shard s, std::size_t total) {
    Table t;
    t.scenario = "s.json";
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
    Table other = shard_table({2, 2}, 5);
    other.scenario = "t.json";
    EXPECT_NE(message_of([&] {
                  merge({shard_table({1, 2}, 5), other}, labels);
              }).find("b: its scenario differs"),
              std::string::npos);
    EXPECT_EQ(to_json(table_from_json(to_json(whole), "x")), to_json(whole));
    EXPECT_NE(message_of([] {
                  table_from_json({{"scenario", "s"}}, "x/sweep.json");
              }).find("x/sweep.json: not a sweep.json"),
              std::string::npos);
}

}  // namespace
}  // namespace penumbra::sweep
