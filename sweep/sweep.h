// penumbra sweep: error against run time over technique configurations (docs/sweep.md). One
// oracle (cache), one RasterSession; per configuration the verdict (a diagnostic render with
// the depth-map lookups) and the time an engine would pay (a production render: shadow pass and
// V alone, maps redrawn), both from GPU timestamps. Shards split the configurations across
// machines; merge() puts shard tables back together into what one run gives.
#pragma once

#include <cstddef>
#include <functional>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "common/scenario.h"
#include "pipeline/validate.h"
#include "raster/technique.h"
#include "raster/vulkan_context.h"

namespace penumbra::sweep {

// One --vary KEY=V1,V2,...: a technique key (dotted, as --set) and its values (JSON when they
// parse, else strings, as --set).
struct Axis {
    std::string key;
    std::vector<std::string> values;
};
// InputError naming the argument for a missing '=', an empty key or value.
Axis parse_axis(const std::string& argument);

struct Config {
    std::size_t index = 0;            // in the full (unsharded) list
    std::vector<std::string> values;  // per axis, as typed; a --configs entry: its name
    raster::Technique technique;
};

// The cartesian product of the axes over `base` (first axis slowest), each configuration parsed
// and checked against the scenario's lights before any work: a bad key or value is InputError
// naming the configuration (its KEY=VALUE pairs) and the key.
std::vector<Config> expand(const nlohmann::json& base, std::span<const Axis> axes, const std::vector<Light>& lights);

// A --configs file: a JSON array whose entries are preset names or technique objects (an object
// may carry "name"); each is applied over `base`.
std::vector<Config> configs_from_file(const std::filesystem::path& file, const nlohmann::json& base,
                                      const std::vector<Light>& lights);

// --shard K/N (1 <= K <= N): the configurations whose index % N == K - 1.
struct Shard {
    int k = 1, n = 1;
};
Shard parse_shard(const std::string& text);

// The verdict columns of sweep.csv: metric paths (metrics/metric_table.h), pooled over the
// scenario's lights weighted by scored pixels. Soft-shadow columns only with area lights.
std::vector<std::string> verdict_columns(const Scenario& scenario);

struct Row {
    std::size_t index = 0;
    std::vector<std::string> values;
    nlohmann::json technique;           // resolved, every key
    std::vector<double> verdict;        // per verdict column
    nlohmann::json lights;              // per light, report.json's light objects
    std::vector<double> production_ms;  // per repeat: shadow + lookup (+ mask) GPU ms, V only
    std::vector<double> diagnostic_ms;  // per repeat: the same passes with the lookups
    double seconds = 0;                 // wall clock of this configuration: verdict and timings
};

struct Table {
    std::string scenario;              // as given on the command line
    std::vector<std::string> keys;     // varied keys ("configuration" for --configs)
    std::vector<std::string> columns;  // verdict columns
    std::size_t total = 0;             // configurations in the whole sweep
    int repeat = 1;
    nlohmann::json device;  // name, driver
    Shard shard;
    double setup_s = 0;     // wall clock: the oracle (or its cache) and the session
    std::vector<Row> rows;  // by index
};

struct SweepOptions {
    ValidateOptions validate;
    int repeat = 3;
    std::function<void(const Row&, std::size_t done, std::size_t of)> progress;
};

Table run_sweep(const Scenario& scenario, const std::string& scenario_name, std::span<const std::string> keys,
                std::span<const Config> configs, std::size_t total, Shard shard, const SweepOptions& options,
                const raster::VulkanContext& ctx);

double median(std::vector<double> v);
double minimum(const std::vector<double>& v);

nlohmann::json to_json(const Table& t);
// sweep.json back into a table; InputError naming `label` and the key when it is not one.
Table table_from_json(const nlohmann::json& j, const std::string& label);
// The shards' tables as one: same scenario, keys, columns and total; every configuration exactly
// once. InputError naming what differs or what is missing.
Table merge(std::vector<Table> shards, std::span<const std::string> labels);

std::string sweep_csv(const Table& t);

}  // namespace penumbra::sweep
