// The command line's shared pieces: the options every subcommand takes, and the one way each
// subcommand registers itself (a CLI11 subcommand plus the function that runs it). One file per
// subcommand (app/*_command.cpp) keeps each one readable on its own.
#pragma once

#include <tbb/global_control.h>

#include <CLI/CLI.hpp>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/scenario.h"
#include "metrics/gate.h"
#include "oracle/oracle.h"
#include "pipeline/validate.h"
#include "raster/technique.h"

namespace penumbra::cli {

// Every path and text a user gives on the command line passes one of these two checks before any
// work (exit 2); both refuse an empty value. Names (presets, knobs, metrics, --set, --device) must
// be valid UTF-8, since they are matched and written into reports. Paths are the file system's
// bytes and any is accepted; wherever one is shown (reports, JSON, messages) it is converted by
// path_text (common/json_reader.h), never written as path.string().
std::string user_name_problem(const std::string& text);
std::string user_path_problem(const std::string& text);
extern const CLI::Validator kUserName, kUserPath;
// A number option's range, [lo, hi] inclusive: a finite number (CLI::Range lets NaN through)
// and a message that prints the bounds readably (CLI::Range prints DBL_MAX with 309 digits).
CLI::Validator range(double lo, double hi);
// --cache-max: a size (oracle/oracle_cache.h, parse_cache_size), or what is wrong with it.
std::string cache_size_problem(const std::string& text);
// The scenario every command that reads one takes as its positional SCENARIO.
CLI::Option* add_scenario(CLI::App* cmd, std::filesystem::path& scenario);

// Options every subcommand that reads a scenario takes.
struct Common {
    std::filesystem::path out;
    bool allow_external_paths = false;
    bool quiet = false;
    int threads = 0;
    std::string max_memory;  // empty: the default budget (common/memory_estimate.h)
    std::string size;        // --size WxH: replaces the scenario's image size; empty: the scenario's
};
void add_common(CLI::App* cmd, Common& c);
// --size WxH, for the commands that render (oracle, raster, validate, tune, sweep).
void add_size(CLI::App* cmd, Common& c);

// --threads N (N > 0) bounds the whole command while this lives: the scene's load, the oracle,
// the raster's and the metrics' parallel loops, not only the oracle's phases.
class ThreadLimit {
  public:
    explicit ThreadLimit(int threads);
    explicit ThreadLimit(const Common& c) : ThreadLimit(c.threads) {}

  private:
    std::optional<tbb::global_control> limit_;
};

// How the oracle samples area lights (docs/oracle.md, "Area lights").
struct SamplingArgs {
    std::uint64_t seed = 0;
    double target = 1.0 / 255;
    int max_rays = 4096;
};
void add_sampling(CLI::App* cmd, SamplingArgs& a);
OracleSettings oracle_settings(const Common& c, const SamplingArgs& a);

// Loads and validates the scenario every subcommand starts from; prints the scene's warnings.
Scenario load_for_command(const std::filesystem::path& scenario_file, const Common& c);

// Refuses, before any large allocation, a run the memory budget cannot hold (exit 2).
void check_run_memory(const Scenario& s, const Common& c, bool oracle, const raster::Technique* t, bool metrics);

// How a verdict is reached, as validate, tune, sweep and compare take it: the oracle's cache,
// its area-light sampling and tau.
struct VerdictArgs {
    std::filesystem::path cache_dir;
    std::string cache_max;  // --cache-max; empty: $PENUMBRA_CACHE_MAX or 2 GiB
    bool no_cache = false;
    double tolerance = 1.0 / 255.0;
    double visible_threshold = 0.1;
    SamplingArgs sampling;
};
// --cache, --cache-max, --no-cache, --tolerance and the sampling options.
void add_verdict_options(CLI::App* cmd, VerdictArgs& v);
// --tolerance (tau), as validate, compare, tune, sweep and stress take it.
void add_tolerance(CLI::App* cmd, double& tolerance);
// --visible-threshold: |error| from which a wrong pixel also counts as visible.
void add_visible_threshold(CLI::App* cmd, double& threshold);
// The pipeline's options from them (the oracle's progress shown unless quiet).
ValidateOptions validate_options(const Common& c, const VerdictArgs& v);

// The technique's three sources: the scenario or --technique file, --preset, --set.
struct TechniqueArgs {
    std::filesystem::path file;
    std::string preset;
    std::vector<std::string> sets;
    std::string device;
};
void add_technique(CLI::App* cmd, TechniqueArgs& t);
// The technique JSON from those sources, in order (not yet parsed).
nlohmann::json technique_json(const Scenario& scenario, const TechniqueArgs& t, std::string& label);
raster::Technique resolve_technique(const Scenario& scenario, const TechniqueArgs& t);
// Unless quiet, one stdout line saying what a technique with a preset kept from its other sources
// (the technique object's own keys and --set, which win over the preset's defaults): each key
// that differs from the preset alone, with the preset's value (raster::preset_differences).
void say_preset_differences(const raster::Technique& t, bool quiet);

// Prints each failed check of the gate (stderr) and, unless quiet, the gate's line; returns the
// exit code it gives (0 without a gate).
int gate_exit_code(const std::optional<metrics::GateResult>& gate, bool quiet);

// A registered subcommand: run() is called when CLI11 selected `app`. Arguments live in state
// the closure owns, so a subcommand's options stay private to its file.
struct Subcommand {
    CLI::App* app = nullptr;
    std::function<int()> run;
};

// Puts what a command writes and one example in front of its --help footer (issue 33: every
// command's help lists its outputs and an example).
void describe_outputs(CLI::App* cmd, std::string_view outputs, std::string_view example);

Subcommand add_oracle_command(CLI::App& parent);
Subcommand add_raster_command(CLI::App& parent);
Subcommand add_validate_command(CLI::App& parent);
Subcommand add_devices_command(CLI::App& parent);
Subcommand add_tune_command(CLI::App& parent);
Subcommand add_compare_command(CLI::App& parent);
Subcommand add_camera_command(CLI::App& parent);
Subcommand add_sweep_command(CLI::App& parent);
Subcommand add_merge_command(CLI::App& parent);
Subcommand add_stress_command(CLI::App& parent);
Subcommand add_init_command(CLI::App& parent);
Subcommand add_diff_command(CLI::App& parent);
Subcommand add_cache_command(CLI::App& parent);
Subcommand add_units_command(CLI::App& parent);

}  // namespace penumbra::cli
