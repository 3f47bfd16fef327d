// penumbra: where shadow maps are wrong, pixel by pixel, and why. The command-line front end:
// parses arguments, wires the modules together, maps failures to the exit codes of design.md.
#include <fmt/format.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <new>
#include <string>

#include "common/errors.h"
#include "common/json_reader.h"
#include "common/output_files.h"
#include "common/scenario.h"
#include "oracle/oracle.h"
#include "oracle/oracle_output.h"
#include "raster/raster.h"
#include "raster/raster_output.h"
#include "raster/technique.h"

namespace {

using namespace penumbra;

struct Common {
    std::filesystem::path out;
    bool allow_external_paths = false;
    bool quiet = false;
    int threads = 0;
};

void add_common(CLI::App* cmd, Common& c) {
    cmd->add_option("--out", c.out, "Output folder (created if missing)")->required();
    cmd->add_flag("--allow-external-paths", c.allow_external_paths,
                  "Let glTF buffer URIs point outside the scene's folder");
    cmd->add_option("--threads", c.threads, "Worker threads (default: all)")->check(CLI::Range(0, 1024));
    cmd->add_flag("-q,--quiet", c.quiet, "Print nothing but errors");
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Loads and validates the scenario every subcommand starts from; prints the scene's warnings.
Scenario load_for_command(const std::filesystem::path& scenario_file, const Common& c) {
    ScenarioOptions so;
    so.allow_external_paths = c.allow_external_paths;
    Scenario scenario = load_scenario(scenario_file, so);
    if (!c.quiet)
        for (const auto& w : scenario.scene.warnings) fmt::print(stderr, "warning: {}\n", w);
    return scenario;
}

int run_oracle_command(const std::filesystem::path& scenario_file, const Common& c) {
    auto t0 = std::chrono::steady_clock::now();
    Scenario scenario = load_for_command(scenario_file, c);
    OracleTimings timings;
    timings.load_s = seconds_since(t0);

    OracleSettings settings;
    settings.threads = c.threads;
    settings.progress = !c.quiet;
    OracleResult result = run_oracle(scenario, settings);

    OutputTransaction out(c.out);
    write_oracle_outputs(out, scenario, result, timings);
    out.commit();
    if (!c.quiet) {
        const auto& s = result.stats;
        fmt::print("oracle: {}x{} px, {} triangles, {} lights; trace {:.3f} s, boundaries {:.3f} s\n", scenario.width,
                   scenario.height, scenario.scene.triangle_count(), scenario.lights.size(), s.trace_s, s.boundary_s);
        for (std::size_t li = 0; li < s.lights.size(); ++li)
            fmt::print("  light {} ({}): {} lightable px, {} shadowed, {} ambiguous\n", li,
                       to_string(scenario.lights[li].type), s.lights[li].lightable, s.lights[li].shadowed,
                       s.lights[li].uncertain);
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
    cmd->add_option("--preset", t.preset, "Start from a named preset (see below)");
    cmd->add_option("--set", t.sets, "Override one technique key, e.g. --set bias.slope=1.5 (repeatable)");
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
    return raster::parse_technique(j, label);
}

int run_raster_command(const std::filesystem::path& scenario_file, const Common& c, const TechniqueArgs& t) {
    auto t0 = std::chrono::steady_clock::now();
    Scenario scenario = load_for_command(scenario_file, c);
    raster::Technique technique = resolve_technique(scenario, t);
    raster::RasterTimings timings;
    timings.load_s = seconds_since(t0);

    auto t1 = std::chrono::steady_clock::now();
    raster::ContextOptions co;
    co.device = t.device;
    raster::VulkanContext ctx(co);
    timings.device_s = seconds_since(t1);
    raster::RasterResult result = raster::run_raster(scenario, technique, ctx);

    OutputTransaction out(c.out);
    raster::write_raster_outputs(out, scenario, technique, result, timings);
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
    app.set_version_flag("--version", std::string("penumbra ") + PENUMBRA_VERSION);

    Common common;
    std::filesystem::path scenario;
    CLI::App* oracle = app.add_subcommand("oracle", "Trace the exact visibility of every light (Embree)");
    oracle->add_option("SCENARIO", scenario, "Scenario JSON file")->required();
    add_common(oracle, common);

    TechniqueArgs technique;
    CLI::App* raster = app.add_subcommand("raster", "Render the scenario's shadows with a technique (Vulkan)");
    raster->add_option("SCENARIO", scenario, "Scenario JSON file")->required();
    add_common(raster, common);
    add_technique(raster, technique);

    CLI::App* devices = app.add_subcommand("devices", "List the Vulkan devices --device can choose");

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        int code = app.exit(e);
        return code == 0 ? kExitSuccess : kExitBadInput;
    }
    try {
        if (*oracle) return run_oracle_command(scenario, common);
        if (*raster) return run_raster_command(scenario, common, technique);
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
