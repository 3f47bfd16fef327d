// `penumbra compare`: judge an engine's own shadow image against the oracle (docs/compare.md).
#include <fmt/format.h>

#include <map>
#include <memory>

#include "app/cli.h"
#include "common/errors.h"
#include "common/json_reader.h"
#include "common/output_files.h"
#include "common/ranges.h"
#include "common/stopwatch.h"
#include "metrics/gate.h"
#include "metrics/metric_table.h"
#include "pipeline/compare.h"
#include "pipeline/compare_files.h"
#include "pipeline/validate_files.h"

namespace penumbra::cli {
namespace {

struct CompareArgs {
    std::filesystem::path image;
    std::filesystem::path depth;
    DepthSpace depth_space = DepthSpace::linear;
    bool depth_space_given = false;
    int light = -1;
    double texel_m = 0;
    double bias_m = -1;
    int shadow_map = 0;
    double filter_reach = 1.0;
    bool moments = false;
    int band_px = 1;
    std::filesystem::path gate_file;
    std::filesystem::path junit_file;
    VerdictArgs verdict;
};

int run_compare_command(const std::filesystem::path& scenario_file, const Common& c, const CompareArgs& a) {
    const ThreadLimit limit(c);
    if (!a.junit_file.empty()) check_output_file(a.junit_file, c.out, "--junit");
    if (!a.depth.empty() && !a.depth_space_given)
        throw InputError(
            fmt::format("{}: --depth needs --depth-space (linear, ndc or ndc-gl): say how the engine "
                        "stored depth",
                        path_text(a.depth)));
    if (a.depth.empty() && a.depth_space_given)
        throw InputError(fmt::format("--depth-space {} without --depth: give the depth buffer it describes",
                                     to_string(a.depth_space)));
    Scenario scenario = load_for_command(scenario_file, c);
    std::vector<std::size_t> lights;
    if (a.light >= 0) {
        if (static_cast<std::size_t>(a.light) >= scenario.lights.size())
            throw InputError(
                fmt::format("--light {}: {} has {} lights", a.light, scenario.label, scenario.lights.size()));
        // The frame holds one light: the verdict is on a scenario of that light alone.
        lights = {static_cast<std::size_t>(a.light)};
        scenario.lights = {scenario.lights[a.light]};
    } else {
        for (std::size_t li = 0; li < scenario.lights.size(); ++li) lights.push_back(li);
    }
    const nlohmann::json gate_json = a.gate_file.empty() ? scenario.gate : read_json_file(a.gate_file, kGateJson);
    const std::string gate_label = a.gate_file.empty() ? scenario.label + ": gate" : path_text(a.gate_file.filename());
    const metrics::Gate gate =
        metrics::parse_gate(gate_json, gate_label, scenario.lights,
                            a.gate_file.empty() ? metrics::GateOrigin::scenario : metrics::GateOrigin::file);
    check_run_memory(scenario, c, true, nullptr, true);
    EngineFrame frame = load_engine_frame(scenario, a.image, lights,
                                          a.depth.empty() ? std::nullopt : std::optional(a.depth), a.depth_space);
    check_engine_frame(scenario, frame);

    CompareOptions options;
    options.validate = validate_options(c, a.verdict);
    if (a.texel_m > 0) options.texel_footprint_m = static_cast<float>(a.texel_m);
    if (a.shadow_map > 0) options.shadow_map_resolution = a.shadow_map;
    if (a.bias_m >= 0) options.bias_reach_m = static_cast<float>(a.bias_m);
    options.filter_reach_texels = static_cast<float>(a.filter_reach);
    options.moments = a.moments;
    options.silhouette_band_px = a.band_px;
    const ValidateResult r = compare(scenario, frame, options, gate);

    OutputTransaction out(c.out);
    auto t0 = SteadyClock::now();
    write_validate_outputs(out, scenario, r, {.errors = true});
    out.commit();
    const double write_s = seconds_since(t0);
    if (!a.junit_file.empty()) {
        std::filesystem::path dir = a.junit_file.parent_path();
        OutputTransaction junit(dir.empty() ? std::filesystem::path(".") : dir);
        junit.write_text(a.junit_file.filename().string(), validate_junit(scenario, r));
        junit.commit();
    }
    if (!c.quiet) {
        for (const auto& w : r.warnings) fmt::print(stderr, "warning: {}\n", w);
        const auto& cov = r.report["coverage"];
        fmt::print("compare: {}x{} px, {} lights; oracle {} ({:.3f} s), metrics {:.3f} s, writing {:.3f} s\n",
                   scenario.width, scenario.height, scenario.lights.size(), r.oracle->cached ? "from cache" : "traced",
                   r.oracle->seconds, r.metrics_s, write_s);
        fmt::print("  coverage from {}: {:.2f}% of the surface not scored{}\n", cov["source"].get<std::string>(),
                   100.0 * cov["mismatch_fraction"].get<double>(),
                   frame.depth ? "" : " (no engine depth: a silhouette band is left out)");
        for (std::size_t k = 0; k < r.score.lights.size(); ++k)
            fmt::print("  light {} ({}): {}\n", lights[k], to_string(scenario.lights[k].type),
                       metrics::summary_line(r.score.lights[k]));
        fmt::print("results: {}/report.html, report.json, errors.exr\n", path_text(c.out));
    }
    return gate_exit_code(r.gate, c.quiet);
}

}  // namespace

Subcommand add_compare_command(CLI::App& parent) {
    struct Args {
        std::filesystem::path scenario;
        Common common;
        CompareArgs compare;
    };
    auto a = std::make_shared<Args>();
    CompareArgs& v = a->compare;
    CLI::App* cmd = parent.add_subcommand(
        "compare", "Judge an engine's own shadow image against the oracle: the verdict per pixel, reports and gates");
    add_scenario(cmd, a->scenario);
    add_common(cmd, a->common);
    cmd->add_option("--image", v.image,
                    "The engine's shadow factor (1 = lit), the scenario's camera and size: light<i>.V channels, one "
                    "channel per light, or one for --light")
        ->required()
        ->check(kUserPath);
    cmd->add_option("--light", v.light, "The image holds this light only (index into the scenario's lights)")
        ->check(CLI::Range(0, 1 << 20));
    cmd->add_option("--depth", v.depth, "The engine's depth buffer (finds where it saw another surface)")
        ->check(kUserPath);
    const std::map<std::string, DepthSpace> spaces = {
        {"linear", DepthSpace::linear}, {"ndc", DepthSpace::ndc}, {"ndc-gl", DepthSpace::ndc_gl}};
    cmd->add_option("--depth-space", v.depth_space,
                    "How --depth stores depth: linear (view depth, m), ndc (depth buffer in [0, 1]), ndc-gl ([-1, 1])")
        ->transform(CLI::CheckedTransformer(spaces))
        ->each([&v](const std::string&) { v.depth_space_given = true; });
    // Metres, as every length a scenario gives (common/ranges.h); beyond, float overflows.
    auto* texel = cmd->add_option("--texel-m", v.texel_m, "The engine's shadow-map texel at the receivers, metres")
                      ->check(range(kMinExtent, kMaxExtent));
    cmd->add_option("--shadow-map", v.shadow_map, "Or the engine's shadow-map resolution, texels per side")
        ->check(CLI::Range(1, 65536))
        ->excludes(texel);
    cmd->add_option("--bias-m", v.bias_m,
                    "The engine's biases together as metres along the light ray (peter-panning reach; default: "
                    "estimated)")
        ->check(range(0.0, 1e6));
    cmd->add_option("--filter-reach", v.filter_reach, "The engine's filter reach in texels (aliasing band, default 1)")
        ->check(range(0.0, 64.0));
    cmd->add_flag("--moments", v.moments,
                  "The engine filters moments (VSM, ESM, EVSM, MSM): light in a true umbra beyond the filter's reach "
                  "is light_bleeding");
    cmd->add_option("--silhouette-band", v.band_px,
                    "Without --depth: pixels this close to the oracle's silhouettes are not scored (default 1)")
        ->check(CLI::Range(0, 16));
    cmd->add_option("--gate", v.gate_file, "Gate JSON file (replaces the scenario's \"gate\")")->check(kUserPath);
    cmd->add_option("--junit", v.junit_file, "Write the gate's checks as JUnit XML to this file")->check(kUserPath);
    add_verdict_options(cmd, v.verdict);
    describe_outputs(cmd,
                     "Outputs (in --out): as validate's (report.json with coverage and engine, report.html, "
                     "errors.exr, class\nmaps), with engine.json in place of raster.json. Exit 1 when a gate fails.",
                     "penumbra compare data/default/scenario.json --image engine-shadow.exr --out judged --light 0");
    return {cmd, [a] { return run_compare_command(a->scenario, a->common, a->compare); }};
}

}  // namespace penumbra::cli
