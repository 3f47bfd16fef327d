// `penumbra validate`: oracle + raster + metrics, the verdict per pixel, reports and CI gates.
#include <fmt/format.h>

#include <algorithm>
#include <memory>

#include "app/cli.h"
#include "common/errors.h"
#include "common/json_reader.h"
#include "common/memory_estimate.h"
#include "common/output_files.h"
#include "common/progress.h"
#include "common/stopwatch.h"
#include "metrics/gate.h"
#include "metrics/metric_table.h"
#include "pipeline/camera_path.h"
#include "pipeline/camera_path_files.h"
#include "pipeline/validate.h"
#include "pipeline/validate_files.h"
#include "sweep/sweep_table.h"

namespace penumbra::cli {
namespace {

struct ValidateArgs {
    std::filesystem::path gate_file;
    std::filesystem::path junit_file;
    bool frames = false;
    bool errors = false;
    std::string class_map_tint = "none";
    VerdictArgs verdict;
};

// Where the cached oracle lives and what the cache holds, so that its disk use is never a surprise.
std::optional<std::string> cache_line(const nlohmann::json& oracle_info) {
    const nlohmann::json& c = oracle_info.value("cache", nlohmann::json::object());
    if (!c.contains("total_bytes")) return std::nullopt;
    const auto max = c.at("max_bytes").get<std::uint64_t>();
    const auto entries = c.at("entries").get<std::size_t>();
    const std::string held = fmt::format("the cache holds {} in {} {} (cap {}; `penumbra cache list`)",
                                         format_bytes(c.at("total_bytes").get<std::uint64_t>()), entries,
                                         entries == 1 ? "entry" : "entries", max == 0 ? "none" : format_bytes(max));
    if (!c.contains("file")) return fmt::format("oracle cache: {}: not kept; {}", c.at("dir").get<std::string>(), held);
    return fmt::format("oracle cache: {} ({}); {}", c.at("file").get<std::string>(),
                       format_bytes(c.at("bytes").get<std::uint64_t>()), held);
}

// A camera path's wall clock before it starts: every frame traces the oracle and takes a verdict
// (~1 s each even at 16 x 9, sweep's kVerdictSeconds) and a render, both growing with the pixels
// beyond 1280 x 720. Beyond sweep's 12 hours a run is refused, as sweep refuses one (#50).
double camera_path_seconds(const Scenario& s) {
    const double pixels = static_cast<double>(s.width) * s.height;
    return s.camera_path->frames * (sweep::kVerdictSeconds + sweep::kRenderSeconds) * std::max(1.0, pixels / 921600.0);
}

int run_validate_command(const std::filesystem::path& scenario_file, const Common& c, const TechniqueArgs& t,
                         const ValidateArgs& v) {
    const ThreadLimit limit(c);
    if (!v.junit_file.empty()) check_output_file(v.junit_file, c.out, "--junit");
    Scenario scenario = load_for_command(scenario_file, c);
    // Everything the user wrote is checked before any work starts.
    raster::Technique technique = resolve_technique(scenario, t);
    say_preset_differences(technique, c.quiet);
    const nlohmann::json gate_json = v.gate_file.empty() ? scenario.gate : read_json_file(v.gate_file, kGateJson);
    const std::string gate_label = v.gate_file.empty() ? scenario.label + ": gate" : v.gate_file.filename().string();
    const metrics::Gate gate =
        metrics::parse_gate(gate_json, gate_label, scenario.lights,
                            v.gate_file.empty() ? metrics::GateOrigin::scenario : metrics::GateOrigin::file,
                            scenario.camera_path.has_value());
    check_run_memory(scenario, c, true, &technique, true);
    if (scenario.camera_path) {
        const double seconds = camera_path_seconds(scenario);
        if (seconds > sweep::kMaxRunSeconds)
            throw InputError(fmt::format(
                "{}: camera_path: {} frames at {}x{} px: about {:.1f} h at ~{} s a frame (more beyond 1280x720); "
                "beyond {:.0f} h a run; judge fewer frames or a smaller image",
                scenario.label, scenario.camera_path->frames, scenario.width, scenario.height, seconds / 3600,
                sweep::kVerdictSeconds + sweep::kRenderSeconds, sweep::kMaxRunSeconds / 3600));
        if (!c.quiet && seconds >= 600)
            fmt::print(stderr, "validate: camera_path of {} frames: about {:.1f} h (estimated before it starts)\n",
                       scenario.camera_path->frames, seconds / 3600);
    }

    ValidateOptions options = validate_options(c, v.verdict);
    options.keep_oracle_frame = v.frames;
    options.device = t.device;
    ProgressLine progress("validate", !c.quiet);
    options.progress = &progress;
    OutputTransaction out(c.out);
    // A camera path is judged frame by frame (pipeline/camera_path.h); its report is the last frame's.
    std::optional<CameraPathResult> path;
    std::optional<ValidateResult> single;
    if (scenario.camera_path)
        path = validate_camera_path(scenario, technique, gate, options);
    else
        single = validate(scenario, technique, gate, options);
    const ValidateResult& r = path ? path->last : *single;

    auto t0 = SteadyClock::now();
    progress.phase("writing the report and images");
    const ValidateFiles files{v.frames, v.errors, v.class_map_tint == "cascade"};
    if (path)
        write_camera_path_outputs(out, scenario, *path, files);
    else
        write_validate_outputs(out, scenario, r, files);
    out.commit();
    const double write_s = seconds_since(t0);
    if (!v.junit_file.empty()) {
        std::filesystem::path dir = v.junit_file.parent_path();
        OutputTransaction junit(dir.empty() ? std::filesystem::path(".") : dir);
        junit.write_text(v.junit_file.filename().string(), validate_junit(scenario, r));
        junit.commit();
    }

    progress.clear();
    if (!c.quiet) {
        for (const auto& w : r.warnings) fmt::print(stderr, "warning: {}\n", w);
        fmt::print(
            "validate: {}x{} px, {} lights; oracle {} ({:.3f} s), Vulkan device {:.3f} s, raster {:.3f} s, metrics "
            "{:.3f} s, writing {:.3f} s\n",
            scenario.width, scenario.height, scenario.lights.size(), r.oracle->cached ? "from cache" : "traced",
            r.oracle->seconds, r.raster_timings.device_s, r.raster_s, r.metrics_s, write_s);
        for (std::size_t li = 0; li < r.score.lights.size(); ++li) {
            fmt::print("  light {} ({}): {}\n", li, to_string(scenario.lights[li].type),
                       metrics::summary_line(r.score.lights[li]));
            if (auto hint = metrics::reading_line(r.score.lights[li], r.facts)) fmt::print("    hint: {}\n", *hint);
            if (path && li < r.report["lights"].size()) {
                const nlohmann::json& temporal = r.report["lights"][li]["temporal"];
                fmt::print("    flicker over {} frames: {:.5f} ({} of {} points seen in consecutive frames)\n",
                           path->frames, temporal["flicker_rate"].get<double>(),
                           temporal["flicker_pixels"].get<std::uint64_t>(), temporal["points"].get<std::uint64_t>());
            }
        }
        if (auto line = cache_line(r.oracle->info)) fmt::print("{}\n", *line);
        fmt::print("results: {}/report.html, report.json{}{}\n", c.out.string(),
                   files.frames || files.errors ? ", errors.exr" : "",
                   path ? fmt::format(" (the last of {} frames), flicker.exr", path->frames) : "");
    }
    return gate_exit_code(r.gate, c.quiet);
}

}  // namespace

Subcommand add_validate_command(CLI::App& parent) {
    struct Args {
        std::filesystem::path scenario;
        Common common;
        TechniqueArgs technique;
        ValidateArgs validate;
    };
    auto a = std::make_shared<Args>();
    ValidateArgs& v = a->validate;
    CLI::App* cmd =
        parent.add_subcommand("validate", "Oracle + raster + metrics: the verdict per pixel, reports and CI gates");
    add_scenario(cmd, a->scenario);
    add_common(cmd, a->common);
    add_size(cmd, a->common);
    add_technique(cmd, a->technique);
    cmd->add_option("--gate", v.gate_file, "Gate JSON file (replaces the scenario's \"gate\")")->check(kUserPath);
    cmd->add_option("--junit", v.junit_file, "Write the gate's checks as JUnit XML to this file")->check(kUserPath);
    cmd->add_flag("--frames", v.frames,
                  "Also write oracle.exr and raster.exr (the oracle is traced) and errors.exr (as --errors)");
    cmd->add_flag("--errors", v.errors,
                  "Also write errors.exr: per light the signed error, class id and perceptual error per pixel");
    cmd->add_option("--class-map-tint", v.class_map_tint,
                    "none (default) or cascade: a cascaded light's class map tinted by the cascade each pixel used")
        ->check(CLI::IsMember({"none", "cascade"}));
    add_verdict_options(cmd, v.verdict);
    describe_outputs(
        cmd,
        "Outputs (in --out): report.json (the verdict per light; gates read it), report.html (the answer first,\nthen "
        "the details), light<i>.classes.png / .error.png / .compare.png, oracle.json, raster.json; with --errors\n"
        "errors.exr; with --frames also oracle.exr, raster.exr and errors.exr; with --junit the JUnit file. Exit 1\n"
        "when a gate fails.",
        "penumbra validate data/default/scenario.json --out run --preset d3d12-textbook --gate gate.json --junit "
        "junit.xml");
    return {cmd, [a] { return run_validate_command(a->scenario, a->common, a->technique, a->validate); }};
}

}  // namespace penumbra::cli
