// `penumbra tune`: the bias that removes acne with the least peter-panning, found against the
// oracle on one or more scenarios (docs/tune.md).
#include <fmt/format.h>

#include <memory>
#include <optional>
#include <span>

#include "app/cli.h"
#include "common/errors.h"
#include "common/json_reader.h"
#include "common/output_files.h"
#include "common/progress.h"
#include "common/stopwatch.h"
#include "engines/engine_units.h"
#include "metrics/metric_table.h"
#include "raster/vulkan_context.h"
#include "tune/tune_files.h"

namespace penumbra::cli {
namespace {

// The most evaluations tune takes (docs/tune.md): each one renders and scores every scenario
// (about a second on a CPU at 1280x720), so this is days of work, and tune keeps every evaluation.
constexpr int kMaxBudget = 10000;

struct TuneArgs {
    std::vector<std::filesystem::path> scenarios, holdout;
    Common common;
    TechniqueArgs technique;
    std::string knobs;  // empty: tune::default_knobs of the technique's family
    double max_acne = 0.001;
    int budget = 80;
    double precision = 0.05;
    std::string minimize = tune::kVisibleBiasError, then = "peter_panning_gap.p95";
    double tie = 0.01;
    VerdictArgs verdict;
    bool gate = false;
    bool visibility_only = false;
    bool shared_bias = false;
    std::string units;  // --units ENGINE: the recommendation in that engine's parameters too
};

// What `--units ENGINE` converts at, per scenario and light: the reference receiver and the maps
// (penumbra's fit of the technique; tune moves the bias only, so the start's maps are the
// recommendation's).
struct EngineUnitsPlan {
    std::string engine;
    std::vector<std::vector<std::vector<engines::MapContext>>> maps;  // [scenario][light][map]
};

EngineUnitsPlan plan_engine_units(const std::string& engine, std::span<const Scenario> scenarios,
                                  const raster::Technique& t) {
    if (engines::engine_info(engine, "--units").name == "penumbra")
        throw InputError(
            "--units: penumbra's own keys are technique.json; give an engine (bevy, godot, unity-urp, "
            "unreal, three, filament, babylon)");
    EngineUnitsPlan plan{engine, {}};
    for (const Scenario& s : scenarios) {
        auto& per_light = plan.maps.emplace_back();
        for (std::size_t li = 0; li < s.lights.size(); ++li)
            per_light.push_back(engines::map_contexts(
                s, t, li,
                engines::reference_receiver(
                    s, s.lights[li], std::nullopt,
                    "tune --units needs a receiver plane that faces the light; `penumbra units` converts this "
                    "light's bias at an angle you give")));
    }
    return plan;
}

// The recommended bias of each light in the plan's engine: at the first map (split 0: the
// nearest cascade, where acne shows most), with every cascade's values alongside. An engine that
// cannot carry the bias at the reference angle gets an "error" instead of its parameters.
void add_engine_units(const EngineUnitsPlan& plan, const raster::Technique& recommended,
                      std::vector<tune::ApiBias>& units) {
    for (tune::ApiBias& u : units) {
        const auto& maps = plan.maps.at(u.scenario).at(u.light);
        const engines::EngineBias from = engines::penumbra_bias(recommended.bias_for(u.light));
        nlohmann::json per_map = nlohmann::json::array();
        for (const engines::MapContext& m : maps) {
            nlohmann::json j = engines::to_json(m);
            try {
                const engines::EngineBias b = engines::convert(from, plan.engine, m);
                j["parameters"] = b.values;
                j["engine_assumptions"] = b.assumptions;
            } catch (const InputError& e) {
                j["error"] = e.what();
            }
            per_map.push_back(j);
        }
        if (per_map.empty()) continue;
        const nlohmann::json& first = per_map.front();
        nlohmann::json assumptions = first.value("engine_assumptions", nlohmann::json::object());
        assumptions["reference_angle_deg"] = first["reference_angle_deg"];
        assumptions["split"] = first["cascade"];
        assumptions["reference_receiver"] = "the scene's largest plane";
        u.engine = {{"name", plan.engine}, {"assumptions", assumptions}, {"map", first}, {"maps", per_map}};
        if (first.contains("parameters"))
            u.engine["parameters"] = first["parameters"];
        else
            u.engine["error"] = first["error"];
    }
}

int run_tune_command(const TuneArgs& a) {
    const auto t0 = SteadyClock::now();
    const Common& c = a.common;
    const ThreadLimit limit(c);
    // Everything the user wrote is checked before any work starts.
    tune::TuneOptions options;
    // The names first (unknown, repeated, none that adds bias), the technique's family's after.
    std::vector<std::string> knobs;
    if (!a.knobs.empty()) knobs = tune::parse_knobs(a.knobs, "--knobs");
    options.budget = a.budget;
    options.precision = a.precision;
    options.lookups = !a.visibility_only;
    options.shared_bias = a.shared_bias;
    options.objective = {a.max_acne, a.minimize, a.then, a.tie};
    if (a.budget < 1 || a.budget > kMaxBudget)
        throw InputError(fmt::format("--budget: {} evaluations; give 1 to {}", a.budget, kMaxBudget));
    for (const auto& [option, path] : {std::pair{"--minimize", &a.minimize}, std::pair{"--then", &a.then}})
        if (!metrics::find_metric(*path) && !(path == &a.minimize && *path == tune::kVisibleBiasError))
            throw InputError(fmt::format("{}: no metric \"{}\" (see docs/metrics.md for the paths)", option, *path));
    std::vector<Scenario> scenarios, holdout;
    for (const auto& f : a.scenarios) scenarios.push_back(load_for_command(f, c));
    for (const auto& f : a.holdout) holdout.push_back(load_for_command(f, c));
    const raster::Technique start = resolve_technique(scenarios.front(), a.technique);
    say_preset_differences(start, c.quiet);
    if (a.knobs.empty()) knobs = tune::parse_knobs(tune::default_knobs(start), "--knobs");
    options.knobs = tune::knob_set(start, knobs, "--knobs");
    std::optional<EngineUnitsPlan> engine_units;
    if (!a.units.empty()) engine_units = plan_engine_units(a.units, scenarios, start);
    for (const auto* list : {&scenarios, &holdout})
        for (const Scenario& s : *list) {
            raster::check_technique_lights(start, s.lights, s.label + ": technique");
            check_run_memory(s, c, true, &start, true);
        }

    options.validate = validate_options(c, a.verdict);
    options.validate.oracle.progress = false;
    const auto tune_start = SteadyClock::now();
    if (!c.quiet)
        options.progress = [&](const tune::Evaluation& e, std::size_t i) {
            const std::string left = time_left(seconds_since(tune_start), i + 1, options.budget);
            fmt::print(stderr, "tune: [{}/{}] {}: worst acne {:.5f}, {} {:.5f}{}{}\n", i + 1, options.budget,
                       tune::describe(e.setting, options.knobs), e.worst_acne, options.objective.minimize, e.minimized,
                       e.feasible ? "" : " (acne too high)", left.empty() ? "" : "; " + left);
        };

    raster::ContextOptions co;
    co.device = a.technique.device;
    raster::VulkanContext ctx(co);
    tune::TuneReport report;
    for (const auto& f : a.scenarios) report.scenario_files.push_back(path_text(f));
    for (const auto& f : a.holdout) report.holdout_files.push_back(path_text(f));
    report.start = start;
    tune::Evaluator evaluator(scenarios, start, options, ctx);
    report.result = tune::tune(evaluator, options);
    options.progress = nullptr;
    report.options = options;
    const tune::TuneResult& res = report.result;
    // Never worse than the start, now with the perceptual error too: a light that re-validates
    // worse keeps the start's bias (all of them with a shared bias).
    report.tuned = tune::revalidate_never_worse(evaluator, start, report.result, options, report.scenario_files);
    report.holdout = tune::revalidate(holdout, start, res.recommended, options.validate, ctx);
    report.units = tune::api_units(report.tuned);
    if (engine_units) add_engine_units(*engine_units, res.recommended, report.units);
    report.seconds = seconds_since(t0);

    OutputTransaction out(c.out);
    tune::write_tune_outputs(out, report);
    out.commit();

    const std::size_t chosen = res.chosen();
    const tune::Evaluation& e = res.evaluations[chosen];
    // Per-light mode: no light without a feasible setting (the gate's question).
    bool feasible = res.per_light.empty() ? res.winner.has_value() : true;
    for (const auto& rl : res.per_light) feasible = feasible && rl.winner.has_value();
    if (!c.quiet) {
        fmt::print(
            "tune: {} evaluations in {:.1f} s ({:.3f} s each on average){}\n", res.evaluations.size(), report.seconds,
            [&] {
                double s = 0;
                for (const auto& x : res.evaluations) s += x.seconds;
                return s / static_cast<double>(res.evaluations.size());
            }(),
            res.budget_exhausted ? "; the budget ran out" : "");
        auto print_choice = [&](const tune::TuneResult& r, const std::string& who) {
            const tune::Evaluation& x = r.evaluations[r.chosen()];
            if (r.kept_start)
                fmt::print("{}keeps the start: {}: the best setting found was worse than the start ({})\n", who,
                           tune::describe(x.setting, options.knobs), r.why);
            else
                fmt::print("{}{}: {}: worst acne {:.5f}, {} {:.5f}, {} {:.4g}\n", who,
                           r.winner ? "recommended" : "no setting meets the acne limit; best reachable",
                           tune::describe(x.setting, options.knobs), x.worst_acne, options.objective.minimize,
                           x.minimized, options.objective.then, x.then);
        };
        if (res.per_light.empty()) print_choice(res, "");
        for (std::size_t li = 0; li < res.per_light.size(); ++li)
            print_choice(res.per_light[li], fmt::format("light {}: ", li));
        for (const auto& u : report.units) {
            if (u.scenario != 0) continue;  // the bias is the same on every scenario
            fmt::print("  light {}:\n", u.light);
            fmt::print(
                "  Vulkan ({}): depthBiasConstantFactor {:.4g}, depthBiasSlopeFactor {:.4g}, depthBiasClamp {:.4g}\n"
                "  D3D12: DepthBias {} (D24) / {} (D32), SlopeScaledDepthBias {:.4g}, DepthBiasClamp {:.4g}\n"
                "  OpenGL: glPolygonOffset({:.4g}, {:.4g}); constant = {:.4g} m; world {:.4g} m; normal offset "
                "{:.4g} texels = {:.4g} m\n",
                raster::to_string(res.recommended.depth_format), u.vk_constant, u.vk_slope, u.vk_clamp,
                u.d3d12_depth_bias_d24, u.d3d12_depth_bias_d32, u.d3d12_slope, u.d3d12_clamp, u.gl_factor, u.gl_units,
                u.constant_m, u.world_m, u.normal_offset_texels, u.normal_offset_m);
            if (!u.engine.is_null()) {
                std::string values;
                const nlohmann::json params = u.engine.value("parameters", nlohmann::json::object());
                for (auto it = params.begin(); it != params.end(); ++it)
                    values += fmt::format("{}{} = {:.6g}", values.empty() ? "" : ", ", it.key(), it->get<double>());
                if (u.engine.contains("error")) values = u.engine["error"].get<std::string>();
                fmt::print(
                    "  {}: {} (split {}, reference angle {:.1f} deg; tune.json has every cascade and the "
                    "assumptions)\n",
                    a.units, values, u.engine["assumptions"]["split"].dump(),
                    u.engine["assumptions"]["reference_angle_deg"].get<double>());
            }
        }
        for (const tune::Revalidation& rv : report.tuned)
            for (std::size_t li = 0; li < rv.after.score.lights.size(); ++li) {
                const auto vb = tune::visible_bias_error(rv.before.score.lights[li]);
                const auto va = tune::visible_bias_error(rv.after.score.lights[li]);
                fmt::print("  {} light {}: {} {:.5f} -> {:.5f}, perceptual error {:.5f} -> {:.5f}\n",
                           rv.scenario->label, li, tune::VisibleBiasError::label(vb, va), vb.sum(), va.sum(),
                           rv.before.score.lights[li].perceptual.mean, rv.after.score.lights[li].perceptual.mean);
            }
        for (std::size_t k = 0; k < report.holdout.size(); ++k)
            for (const auto& l : report.holdout[k].after.score.lights)
                fmt::print("  hold-out {}: acne {:.5f}, peter-panning {:.5f}\n", report.holdout_files[k],
                           l.rate(metrics::PixelClass::acne), l.rate(metrics::PixelClass::peter_panning));
        fmt::print("results: {}/technique.json, tune.json, pareto.csv, pareto.svg, report.html\n", path_text(c.out));
    }
    if (a.gate && !feasible) {
        fmt::print(stderr, "gate: FAILED: no setting keeps acne <= {}; the best reachable has {:.5f}\n",
                   options.objective.max_acne, e.worst_acne);
        return kExitGateFailed;
    }
    return kExitSuccess;
}

}  // namespace

Subcommand add_tune_command(CLI::App& parent) {
    auto a = std::make_shared<TuneArgs>();
    CLI::App* cmd = parent.add_subcommand(
        "tune", "Find the bias that removes acne with the least peter-panning, against the oracle");
    cmd->add_option("SCENARIO", a->scenarios, "Scenario JSON files; one recommendation holds for all")
        ->required()
        ->check(kUserPath);
    add_common(cmd, a->common);
    add_size(cmd, a->common);
    add_technique(cmd, a->technique);
    cmd->add_option(
           "--knobs", a->knobs,
           "Bias knobs to tune, from constant,slope,clamp,world,normal_offset,receiver_plane; a moment "
           "family's from min_variance,light_bleed,exponent,moment_bias (default constant,slope; a moment family's "
           "own knobs for it)")
        ->check(kUserName);
    cmd->add_option("--max-acne", a->max_acne,
                    "Cap on the acne rate of every scenario and light (visible acne under the default objective; "
                    "default 0.001)")
        ->check(range(0.0, 1.0));
    cmd->add_option("--budget", a->budget, fmt::format("Most evaluations (default 80, at most {})", kMaxBudget));
    cmd->add_option("--precision", a->precision, "Bisection stops at this relative step (default 0.05)")
        ->check(range(1e-4, 1.0));
    cmd->add_option("--minimize", a->minimize,
                    "Metric minimised (default visible_bias_error: visible acne + visible peter-panning)")
        ->check(kUserName);
    cmd->add_option("--then", a->then, "Metric that breaks ties (default peter_panning_gap.p95)")->check(kUserName);
    cmd->add_option("--tie", a->tie, "Values of --minimize within this fraction of each other are ties (default 0.01)")
        ->check(range(0.0, 1.0));
    cmd->add_option("--holdout", a->holdout, "Scenarios to re-validate the recommendation on, not tuned on")
        ->check(kUserPath);
    cmd->add_flag("--visibility-only", a->visibility_only,
                  "Evaluate from V alone, classified from the oracle's geometry (faster on GPUs; docs/tune.md)");
    cmd->add_flag("--shared-bias", a->shared_bias,
                  "One bias for every light (default: each light's own, in technique.json's \"lights\")");
    cmd->add_option("--units", a->units,
                    "Also give the recommendation in an engine's parameters: bevy, godot, unity-urp, unreal, three, "
                    "filament, babylon (docs/units.md)")
        ->check(kUserName);
    cmd->add_flag("--gate", a->gate, "Exit 1 when no setting meets --max-acne (on some light)");
    add_verdict_options(cmd, a->verdict);
    describe_outputs(
        cmd,
        "Outputs (in --out): technique.json (the recommendation; validate --technique takes it), tune.json "
        "(every\nevaluation and the re-validation), pareto.csv/.svg/.png, the before/after class maps and report.html.",
        "penumbra tune data/default/scenario.json --out tuned --preset d3d12-textbook --budget 40");
    return {cmd, [a] { return run_tune_command(*a); }};
}

}  // namespace penumbra::cli
