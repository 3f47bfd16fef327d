// penumbra: where shadow maps are wrong, pixel by pixel, and why. The command-line front end:
// parses arguments, wires the modules together, maps failures to the exit codes of docs/design.md.
#include <fmt/format.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <new>
#include <string>

#include "common/errors.h"
#include "common/json_reader.h"
#include "common/memory_estimate.h"
#include "common/output_files.h"
#include "common/scenario.h"
#include "common/stopwatch.h"
#include "common/version.h"
#include "metrics/classification.h"
#include "metrics/gate.h"
#include "oracle/oracle.h"
#include "oracle/oracle_cache.h"
#include "oracle/oracle_output.h"
#include "pipeline/validate.h"
#include "pipeline/validate_files.h"
#include "raster/raster.h"
#include "raster/raster_output.h"
#include "raster/technique.h"
#include "report/frame_files.h"
#include "report/report.h"

namespace {

using namespace penumbra;

struct Common {
    std::filesystem::path out;
    bool allow_external_paths = false;
    bool quiet = false;
    int threads = 0;
    std::string max_memory;  // empty: the default budget (common/memory_estimate.h)
};

void add_common(CLI::App* cmd, Common& c) {
    cmd->add_option("--out", c.out, "Output folder (created if missing)")->required();
    cmd->add_flag("--allow-external-paths", c.allow_external_paths,
                  "Let glTF buffer URIs point outside the scene's folder");
    cmd->add_option("--threads", c.threads, "Worker threads (default: all)")->check(CLI::Range(0, 1024));
    cmd->add_flag("-q,--quiet", c.quiet, "Print nothing but errors");
    cmd->add_option("--max-memory", c.max_memory,
                    "Refuse runs estimated to need more memory, e.g. 8G (0: no limit; default 3/4 of the machine's)");
}

// How the oracle samples area lights (docs/oracle.md, "Area lights").
struct SamplingArgs {
    std::uint64_t seed = 0;
    double target = 1.0 / 255;
    int max_rays = 4096;
};

void add_sampling(CLI::App* cmd, SamplingArgs& a) {
    cmd->add_option("--seed", a.seed, "Area lights: seed of the sampling pattern (default 0)");
    cmd->add_option("--area-target", a.target, "Area lights: 95% half-width E a pixel samples down to (default 1/255)")
        ->check(CLI::Range(1e-6, 1.0))
        ->check(finite_number_problem);
    cmd->add_option("--area-max-rays", a.max_rays, "Area lights: most rays per pixel (default 4096)")
        ->check(CLI::Range(16, 1 << 20));
}

OracleSettings oracle_settings(const Common& c, const SamplingArgs& a) {
    OracleSettings settings;
    settings.threads = c.threads;
    settings.progress = !c.quiet;
    settings.seed = a.seed;
    settings.area_target = a.target;
    settings.area_max_rays = a.max_rays;
    return settings;
}

// Loads and validates the scenario every subcommand starts from; prints the scene's warnings.
Scenario load_for_command(const std::filesystem::path& scenario_file, const Common& c) {
    ScenarioOptions so;
    so.allow_external_paths = c.allow_external_paths;
    so.max_memory_bytes = memory_budget(c.max_memory);
    Scenario scenario = load_scenario(scenario_file, so);
    if (!c.quiet) {
        for (const auto& w : scenario.scene.warnings) fmt::print(stderr, "warning: {}\n", w);
        if (auto w = no_lights_warning(scenario)) fmt::print(stderr, "warning: {}\n", *w);
    }
    return scenario;
}

// Refuses, before any large allocation, a run the memory budget cannot hold (exit 2).
void check_run_memory(const Scenario& s, const Common& c, bool oracle, const raster::Technique* t, bool metrics) {
    RasterMemory rm;
    if (t) rm = {t->resolution, t->depth_format == raster::DepthFormat::d16 ? 2 : 4, t->area_samples};
    check_memory(estimate_memory(memory_inputs(s, oracle, t ? &rm : nullptr, metrics)), memory_budget(c.max_memory),
                 s.label);
}

int run_oracle_command(const std::filesystem::path& scenario_file, const Common& c, const SamplingArgs& a) {
    auto t0 = SteadyClock::now();
    Scenario scenario = load_for_command(scenario_file, c);
    check_run_memory(scenario, c, true, nullptr, false);
    OracleTimings timings;
    timings.load_s = seconds_since(t0);

    OracleResult result = run_oracle(scenario, oracle_settings(c, a));

    OutputTransaction out(c.out);
    report::write_oracle_outputs(out, scenario, result, timings);
    out.commit();
    if (!c.quiet) {
        const auto& s = result.stats;
        fmt::print(
            "oracle: {}x{} px, {} triangles, {} lights; trace {:.3f} s, area lights {:.3f} s, boundaries {:.3f} s\n",
            scenario.width, scenario.height, scenario.scene.triangle_count(), scenario.lights.size(), s.trace_s,
            s.area_s, s.boundary_s);
        for (std::size_t li = 0; li < s.lights.size(); ++li) {
            const OracleLightStats& l = s.lights[li];
            fmt::print("  light {} ({}): {} lightable px, {} shadowed, {} ambiguous", li,
                       to_string(scenario.lights[li].type), l.lightable, l.shadowed, l.uncertain);
            if (l.area)
                fmt::print("; {:.1f} rays/px (max {}), {} px refined, {} at the ray cap",
                           l.sampling.rays_per_pixel_mean, l.sampling.rays_per_pixel_max, l.sampling.refined,
                           l.sampling.capped);
            fmt::print("\n");
        }
        fmt::print("results: {}/oracle.exr, oracle.json, oracle.png\n", c.out.string());
    }
    return kExitSuccess;
}

struct TechniqueArgs {
    std::filesystem::path file;
    std::string preset;
    std::vector<std::string> sets;
    std::string device;
};

void add_technique(CLI::App* cmd, TechniqueArgs& t) {
    cmd->add_option("--technique", t.file, "Technique JSON file (replaces the scenario's \"technique\")");
    cmd->add_option("--preset", t.preset, "Start from a named preset (see below)")->check(utf8_problem);
    cmd->add_option("--set", t.sets, "Override one technique key, e.g. --set bias.slope=1.5 (repeatable)")
        ->check(set_assignment_problem);
    cmd->add_option("--device", t.device,
                    "Vulkan device index or name part (default: $PENUMBRA_VK_DEVICE, else lavapipe)");
    std::string text = "Presets:\n";
    for (const auto& p : raster::presets()) text += fmt::format("  {:<24}{}\n", p.name, p.description);
    cmd->footer(text);
}

// The technique from its three sources, in order: scenario or --technique file, --preset, --set.
raster::Technique resolve_technique(const Scenario& scenario, const TechniqueArgs& t) {
    nlohmann::json j = scenario.technique;
    std::string label = scenario.label + ": technique";
    if (!t.file.empty()) {
        j = read_json_file(t.file);
        label = t.file.filename().string();
    }
    if (!t.preset.empty()) j["preset"] = t.preset;
    for (const auto& s : t.sets) raster::apply_override(j, s);
    return raster::parse_technique(j, label, scenario.lights);
}

int run_raster_command(const std::filesystem::path& scenario_file, const Common& c, const TechniqueArgs& t) {
    auto t0 = SteadyClock::now();
    Scenario scenario = load_for_command(scenario_file, c);
    raster::Technique technique = resolve_technique(scenario, t);
    check_run_memory(scenario, c, false, &technique, false);
    raster::RasterTimings timings;
    timings.load_s = seconds_since(t0);

    auto t1 = SteadyClock::now();
    raster::ContextOptions co;
    co.device = t.device;
    raster::VulkanContext ctx(co);
    timings.device_s = seconds_since(t1);
    raster::RasterResult result = raster::run_raster(scenario, technique, ctx);

    OutputTransaction out(c.out);
    report::write_raster_outputs(out, scenario, technique, result, timings);
    out.commit();
    if (!c.quiet) {
        const auto& s = result.stats;
        for (const auto& w : s.warnings) fmt::print(stderr, "warning: {}\n", w);
        fmt::print("raster: {}x{} px, {} lights on {}; {}^2 {} map; GPU shadow {:.2f} ms, camera {:.2f} ms\n",
                   scenario.width, scenario.height, scenario.lights.size(), s.device.name, technique.resolution,
                   raster::to_string(technique.depth_format), s.shadow_ms, s.camera_ms + s.lookup_ms);
        fmt::print("results: {}/raster.exr, raster.json, raster.png\n", c.out.string());
    }
    return kExitSuccess;
}

struct ValidateArgs {
    std::filesystem::path gate_file;
    std::filesystem::path junit_file;
    std::filesystem::path cache_dir;
    bool no_cache = false;
    bool frames = false;
    double tolerance = 1.0 / 255.0;
    SamplingArgs sampling;
};

int run_validate_command(const std::filesystem::path& scenario_file, const Common& c, const TechniqueArgs& t,
                         const ValidateArgs& v) {
    if (!v.junit_file.empty()) check_output_file(v.junit_file, c.out, "--junit");
    Scenario scenario = load_for_command(scenario_file, c);
    // Everything the user wrote is checked before any work starts.
    raster::Technique technique = resolve_technique(scenario, t);
    const nlohmann::json gate_json = v.gate_file.empty() ? scenario.gate : read_json_file(v.gate_file);
    const std::string gate_label = v.gate_file.empty() ? scenario.label + ": gate" : v.gate_file.filename().string();
    const metrics::Gate gate =
        metrics::parse_gate(gate_json, gate_label, scenario.lights,
                            v.gate_file.empty() ? metrics::GateOrigin::scenario : metrics::GateOrigin::file);
    check_run_memory(scenario, c, true, &technique, true);

    ValidateOptions options;
    options.oracle = oracle_settings(c, v.sampling);
    options.use_cache = !v.no_cache;
    options.cache_dir = v.cache_dir;
    options.keep_oracle_frame = v.frames;
    options.tolerance = v.tolerance;
    options.device = t.device;
    OutputTransaction out(c.out);
    const ValidateResult r = validate(scenario, technique, gate, options);

    auto t0 = SteadyClock::now();
    write_validate_outputs(out, scenario, r, v.frames);
    out.commit();
    const double write_s = seconds_since(t0);
    if (!v.junit_file.empty()) {
        std::filesystem::path dir = v.junit_file.parent_path();
        OutputTransaction junit(dir.empty() ? std::filesystem::path(".") : dir);
        junit.write_text(v.junit_file.filename().string(), validate_junit(scenario, r));
        junit.commit();
    }

    if (!c.quiet) {
        for (const auto& w : r.warnings) fmt::print(stderr, "warning: {}\n", w);
        fmt::print(
            "validate: {}x{} px, {} lights; oracle {} ({:.3f} s), Vulkan device {:.3f} s, raster {:.3f} s, metrics "
            "{:.3f} s, writing {:.3f} s\n",
            scenario.width, scenario.height, scenario.lights.size(), r.oracle->cached ? "from cache" : "traced",
            r.oracle->seconds, r.raster_timings.device_s, r.raster_s, r.metrics_s, write_s);
        for (std::size_t li = 0; li < r.score.lights.size(); ++li)
            fmt::print("  light {} ({}): {}\n", li, to_string(scenario.lights[li].type),
                       metrics::summary_line(r.score.lights[li]));
        fmt::print("results: {}/report.html, report.json, errors.exr\n", c.out.string());
    }
    if (r.gate) {
        for (const auto& o : r.gate->outcomes)
            if (!o.passed) fmt::print(stderr, "{}\n", o.failure());
        if (!c.quiet)
            fmt::print("gate: {} ({} checks)\n", r.gate->passed ? "passed" : "FAILED", r.gate->outcomes.size());
        if (!r.gate->passed) return kExitGateFailed;
    }
    return kExitSuccess;
}

int run_devices_command() {
    for (const auto& d : raster::list_devices())
        fmt::print("{}: {} ({}, Vulkan {}, {}){}\n", d.index, d.name, d.type, d.api_version, d.driver,
                   d.lavapipe ? " [default]" : "");
    return kExitSuccess;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"penumbra: tells, pixel by pixel, where shadows are wrong and why"};
    app.require_subcommand(1);
    app.set_version_flag("--version", std::string("penumbra ") + version_string());

    Common common;
    std::filesystem::path scenario;
    CLI::App* oracle = app.add_subcommand("oracle", "Trace the exact visibility of every light (Embree)");
    oracle->add_option("SCENARIO", scenario, "Scenario JSON file")->required();
    add_common(oracle, common);
    SamplingArgs sampling;
    add_sampling(oracle, sampling);

    TechniqueArgs technique;
    CLI::App* raster = app.add_subcommand("raster", "Render the scenario's shadows with a technique (Vulkan)");
    raster->add_option("SCENARIO", scenario, "Scenario JSON file")->required();
    add_common(raster, common);
    add_technique(raster, technique);

    ValidateArgs validate_args;
    CLI::App* validate =
        app.add_subcommand("validate", "Oracle + raster + metrics: the verdict per pixel, reports and CI gates");
    validate->add_option("SCENARIO", scenario, "Scenario JSON file")->required();
    add_common(validate, common);
    add_technique(validate, technique);
    validate->add_option("--gate", validate_args.gate_file, "Gate JSON file (replaces the scenario's \"gate\")");
    validate->add_option("--junit", validate_args.junit_file, "Write the gate's checks as JUnit XML to this file");
    validate->add_option(
        "--cache", validate_args.cache_dir,
        "Oracle cache folder (default: $PENUMBRA_CACHE_DIR, $XDG_CACHE_HOME/penumbra, ~/.cache/penumbra)");
    validate->add_flag("--no-cache", validate_args.no_cache, "Trace the oracle and keep nothing");
    validate->add_flag("--frames", validate_args.frames, "Also write oracle.exr and raster.exr (the oracle is traced)");
    validate->add_option("--tolerance", validate_args.tolerance, "tau: |error| above this plus the oracle's E is wrong")
        ->check(CLI::Range(0.0, 1.0))
        ->check(finite_number_problem);
    add_sampling(validate, validate_args.sampling);

    CLI::App* devices = app.add_subcommand("devices", "List the Vulkan devices --device can choose");

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        int code = app.exit(e);
        return code == 0 ? kExitSuccess : kExitBadInput;
    }
    try {
        if (*oracle) return run_oracle_command(scenario, common, sampling);
        if (*raster) return run_raster_command(scenario, common, technique);
        if (*validate) return run_validate_command(scenario, common, technique, validate_args);
        if (*devices) return run_devices_command();
    } catch (const InputError& e) {
        fmt::print(stderr, "error: {}\n", e.what());
        return kExitBadInput;
    } catch (const EnvironmentError& e) {
        fmt::print(stderr, "error: {}\n", e.what());
        return kExitEnvironment;
    } catch (const std::bad_alloc&) {
        fmt::print(stderr, "error: out of memory\n");
        return kExitEnvironment;
    } catch (const std::exception& e) {
        fmt::print(stderr, "internal error (a bug in penumbra, please report it): {}\n", e.what());
        return kExitInternal;
    }
    return kExitBadInput;
}
