// sweep's pure half (docs/sweep.md): configurations from --vary and --configs, the limits on a
// sweep's work, shards, and sweep.json/sweep.csv read back and merged. No device and no oracle,
// so the libFuzzer targets (tests/fuzz) build it with common and the technique parser alone.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "common/scenario.h"
#include "raster/technique.h"

namespace penumbra::sweep {

// Limits checked before any work (docs/sweep.md, "Limits"). A whole sweep (every shard
// together) holds at most kMaxConfigurations: each is parsed and kept before sharding.
inline constexpr std::size_t kMaxConfigurations = 100000;
inline constexpr int kMaxRepeat = 100;
// One run's estimated wall clock: per configuration the verdict (a diagnostic render and the
// metrics on the CPU: measured 1.0-1.25 s at 1280 x 720 on the H100) and 1 + 2 x --repeat
// renders of at most kRenderSeconds (an 8192² production render with 8 layers: 92 ms).
inline constexpr double kVerdictSeconds = 1.0;
inline constexpr double kRenderSeconds = 0.1;
inline constexpr double kMaxRunSeconds = 12 * 3600.0;
// Timings to trust (docs/sweep.md, "What is measured"): before the --repeat timed renders of
// each kind, kWarmUpRenders renders are drawn and discarded (for the diagnostic kind the
// verdict's render is the first of them); a configuration whose repeats spread by more than
// kRepeatSpreadMargin of their median ((max - min) / median) is named in the report.
inline constexpr int kWarmUpRenders = 1;
inline constexpr double kRepeatSpreadMargin = 0.10;
// What production_ms and diagnostic_ms include, as sweep.json's "timings" says.
inline constexpr const char* kProductionMsIncludes =
    "GPU ms of a production render: every pass the technique's family timed, as an engine draws it (depth "
    "map: a depth-only shadow pass per drawn map layer with the technique's depth bias, no triangle-id target; "
    "the lookup writing V alone; the cube-face mask for point lights); maps redrawn every time; neither the "
    "camera pass nor the copy to the host";
inline constexpr const char* kDiagnosticMsIncludes =
    "GPU ms of a diagnostic render: the same passes as penumbra draws them for the verdict (depth map: the "
    "shadow pass also writing the triangle id per texel; the lookup writing V and every diagnostic, 36 bytes a "
    "pixel; the cube-face mask); maps redrawn every time; neither the camera pass nor the copy to the host";
// Memory a run keeps per configuration: its parsed technique and values (about 1 KB), and per
// row the resolved technique and the per-light verdict objects as JSON.
inline constexpr std::uint64_t kConfigBytes = 2048;
inline constexpr std::uint64_t kRowBytes = 8192;
inline constexpr std::uint64_t kRowLightBytes = 8192;
// The largest shard file merge reads: a whole sweep's rows at a few KB each.
inline constexpr std::uint64_t kMaxShardFileBytes = 1ull << 30;

// One --vary KEY=V1,V2,...: a technique key (dotted, as --set) and its values (JSON when they
// parse, else strings, as --set).
struct Axis {
    std::string key;
    std::vector<std::string> values;
};
// InputError naming the argument for a missing '=', an empty key or value, text that is not
// UTF-8 or a key path deeper than --set allows.
Axis parse_axis(const std::string& argument);
// InputError naming both --vary arguments when two keys overlap: the same key twice, or one a
// prefix path of the other (bias and bias.slope), where the later would silently replace the
// earlier's value and the rows would be mislabelled.
void check_axes(std::span<const Axis> axes);
// The number of configurations of the axes' product, saturated at SIZE_MAX.
std::size_t product_size(std::span<const Axis> axes);
// InputError when `count` configurations exceed kMaxConfigurations; `what` names them.
void check_configuration_count(std::size_t count, const std::string& what);

struct Config {
    std::size_t index = 0;            // in the full (unsharded) list
    std::vector<std::string> values;  // per axis, as typed; a --configs entry: its name
    raster::Technique technique;
};

// The cartesian product of the axes over `base` (first axis slowest), each configuration parsed
// and checked against the scenario's lights before any work: overlapping keys, a product beyond
// kMaxConfigurations, a bad key or value are InputErrors naming the configuration (its
// KEY=VALUE pairs) and the key.
std::vector<Config> expand(const nlohmann::json& base, std::span<const Axis> axes, const std::vector<Light>& lights);

// A --configs list: a JSON array of at most kMaxConfigurations entries, preset names or
// technique objects (an object may carry "name"); each is applied over `base`: a name
// replaces base's preset and keeps the keys base sets (as --preset NAME with the same --set),
// an object's keys win over base's. `name` labels errors.
std::vector<Config> configs_from_json(const nlohmann::json& list, const std::string& name, const nlohmann::json& base,
                                      const std::vector<Light>& lights);
std::vector<Config> configs_from_file(const std::filesystem::path& file, const nlohmann::json& base,
                                      const std::vector<Light>& lights);

// --shard K/N (1 <= K <= N): the configurations whose index % N == K - 1.
struct Shard {
    int k = 1, n = 1;
};
Shard parse_shard(const std::string& text);
// How many of `total` configurations shard `s` runs.
std::size_t shard_size(std::size_t total, Shard s);

// One run's estimated work before it starts: wall clock and the memory its configurations
// and rows keep.
struct WorkEstimate {
    double seconds = 0;
    std::uint64_t bytes = 0;
};
WorkEstimate estimate_work(std::size_t total, std::size_t in_run, int repeat, std::size_t lights);
// InputError naming the product (`what`) when this run's estimate is beyond kMaxRunSeconds or
// `memory_budget` bytes (0: no budget), suggesting the smallest --shard K/N whose shards fit.
void check_work(std::size_t total, std::size_t in_run, int repeat, std::size_t lights, std::uint64_t memory_budget,
                const std::string& what);

// 32 hex digits over the whole sweep definition: the oracle's cache key (the scenario's
// content: geometry, camera, lights, image size, oracle settings; not its path), the starting
// technique, the keys and every configuration (values and resolved technique), the tolerance,
// the repeats and the device. Shards of one sweep share it; merge refuses shards that differ.
std::string definition_fingerprint(const std::string& oracle_key, const nlohmann::json& base,
                                   std::span<const std::string> keys, std::span<const Config> all, double tolerance,
                                   int repeat, const nlohmann::json& device);

struct Row {
    std::size_t index = 0;
    std::vector<std::string> values;
    nlohmann::json technique;           // resolved, every key
    std::vector<double> verdict;        // per verdict column
    nlohmann::json lights;              // per light, report.json's light objects
    std::vector<double> production_ms;  // per repeat: shadow + lookup (+ mask) GPU ms, V only
    std::vector<double> diagnostic_ms;  // per repeat: the same passes with the lookups
    double seconds = 0;                 // wall clock of this configuration: verdict and timings
    // Where `seconds` went, for benchmarks (not written to the files): the verdict (its render
    // and scoring), the timed renders of each kind with their warm-ups, the wait for the
    // perceptual error after them; and of the timed renders' wall clock, the families' set-up
    // and their submit-and-wait (RasterStats::setup_s, render_s).
    double verdict_s = 0, diagnostic_s = 0, production_s = 0, perceptual_wait_s = 0;
    double perceptual_s = 0;      // the perceptual error's own time, beside the timed renders
    double verdict_render_s = 0;  // of verdict_s, the render
    double timed_setup_s = 0, timed_submit_s = 0;
};

struct Table {
    std::string scenario;              // as given on the command line
    std::vector<std::string> keys;     // varied keys ("configuration" for --configs)
    std::vector<std::string> columns;  // verdict columns, wrong_fraction first
    std::size_t total = 0;             // configurations in the whole sweep
    int repeat = 1;
    nlohmann::json device;    // name, driver
    std::string fingerprint;  // definition_fingerprint
    Shard shard;
    double setup_s = 0;     // wall clock: the oracle (or its cache) and the session
    std::vector<Row> rows;  // by index
};

double median(std::vector<double> v);
double minimum(const std::vector<double>& v);
double maximum(const std::vector<double>& v);
// (max - min) / median of a configuration's repeats; 0 for fewer than two or a zero median.
double spread(const std::vector<double>& v);
// The repeats of production_ms or diagnostic_ms spread by more than kRepeatSpreadMargin.
bool repeats_disagree(const Row& r);

nlohmann::json to_json(const Table& t);
// sweep.json back into a table, every field checked (types, shapes and counts against keys,
// columns and repeat, finite numbers, fractions in [0, 1], times >= 0, indices in [0, total)
// and in the shard): InputError naming `label` and the JSON path when it is not one.
Table table_from_json(const nlohmann::json& j, const std::string& label);
// A shard's files as merge reads them: sweep.json's text and, when the shard has one,
// sweep.csv's, which must be the rows sweep.json gives (InputError naming the first line that
// differs). `folder` labels errors.
Table read_shard(const std::string& json_text, const std::optional<std::string>& csv_text, const std::string& folder);
// The shards' tables as one: the same fingerprint, keys, columns, total, repeats and device;
// every configuration exactly once. InputError naming what differs (both shards) or what is
// missing. The scenario's path may differ (a relative and an absolute path to one file).
Table merge(std::vector<Table> shards, std::span<const std::string> labels);

std::string sweep_csv(const Table& t);

}  // namespace penumbra::sweep
