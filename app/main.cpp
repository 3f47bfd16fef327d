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
#include "common/output_files.h"
#include "common/scenario.h"
#include "oracle/oracle.h"
#include "oracle/oracle_output.h"

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

int run_oracle_command(const std::filesystem::path& scenario_file, const Common& c) {
    auto t0 = std::chrono::steady_clock::now();
    ScenarioOptions so;
    so.allow_external_paths = c.allow_external_paths;
    Scenario scenario = load_scenario(scenario_file, so);
    OracleTimings timings;
    timings.load_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!c.quiet)
        for (const auto& w : scenario.scene.warnings) fmt::print(stderr, "warning: {}\n", w);

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

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        int code = app.exit(e);
        return code == 0 ? kExitSuccess : kExitBadInput;
    }
    try {
        if (*oracle) return run_oracle_command(scenario, common);
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
