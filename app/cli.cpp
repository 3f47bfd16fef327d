#include "app/cli.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <optional>
#include <tuple>

#include "common/errors.h"
#include "common/json_reader.h"
#include "common/memory_estimate.h"
#include "common/output_files.h"
#include "oracle/oracle_cache.h"
#include "pipeline/validate.h"
#include "raster/cascades.h"
#include "raster/technique_family.h"

namespace penumbra::cli {

std::string user_path_problem(const std::string& text) {
    return text.empty() ? "empty; expected a value" : std::string();
}

std::string user_name_problem(const std::string& text) {
    return text.empty() ? "empty; expected a value" : utf8_problem(text);
}

// No description: the checks need none in --help.
const CLI::Validator kUserName(user_name_problem, ""), kUserPath(user_path_problem, "");

std::string cache_size_problem(const std::string& text) {
    try {
        parse_cache_size(text, "--cache-max");
        return {};
    } catch (const InputError& e) {
        return e.what();
    }
}

CLI::Validator range(double lo, double hi) {
    return CLI::Validator(
        [lo, hi](std::string& input) -> std::string {
            double v = 0;
            if (!CLI::detail::lexical_cast(input, v)) return fmt::format("{} is not a number", input);
            if (!std::isfinite(v)) return fmt::format("{} is not a finite number", input);
            if (v < lo || v > hi) return fmt::format("{} is not in [{:g}, {:g}]", input, lo, hi);
            return {};
        },
        fmt::format("in [{:g}, {:g}]", lo, hi));
}

CLI::Option* add_scenario(CLI::App* cmd, std::filesystem::path& scenario) {
    return cmd->add_option("SCENARIO", scenario, "Scenario JSON file")->required()->check(kUserPath);
}

void add_common(CLI::App* cmd, Common& c) {
    cmd->add_option("--out", c.out, "Output folder (created if missing)")
        ->required()
        ->check(kUserPath)
        ->check(output_folder_problem);
    cmd->add_flag("--allow-external-paths", c.allow_external_paths,
                  "Let glTF buffer URIs point outside the scene's folder");
    cmd->add_option("--threads", c.threads, "Worker threads (default: all)")->check(CLI::Range(0, 1024));
    cmd->add_flag("-q,--quiet", c.quiet, "Print nothing but errors");
    cmd->add_option("--max-memory", c.max_memory,
                    "Refuse runs estimated to need more memory, e.g. 8G (0: no limit; default 3/4 of the machine's)")
        ->check(kUserName);
}

// "WxH" with both in [1, kMaxImageSide] and at most kMaxImagePixels in all; nullopt and `problem` else.
std::optional<std::pair<int, int>> parse_size(const std::string& text, std::string& problem) {
    const auto x = text.find_first_of("xX");
    int v[2] = {0, 0};
    const std::string parts[2] = {text.substr(0, x), x == std::string::npos ? "" : text.substr(x + 1)};
    for (int i = 0; i < 2; ++i) {
        const auto [end, ec] = std::from_chars(parts[i].data(), parts[i].data() + parts[i].size(), v[i]);
        if (x == std::string::npos || ec != std::errc() || end != parts[i].data() + parts[i].size() || v[i] < 1 ||
            v[i] > kMaxImageSide) {
            problem = fmt::format("\"{}\": expected WIDTHxHEIGHT in pixels, each 1 ... {}, e.g. 640x360",
                                  escape_non_utf8(text), kMaxImageSide);
            return std::nullopt;
        }
    }
    if (static_cast<long long>(v[0]) * v[1] > kMaxImagePixels) {
        problem = fmt::format("{}x{}: more than the {} pixel limit", v[0], v[1], kMaxImagePixels);
        return std::nullopt;
    }
    return std::pair{v[0], v[1]};
}

void add_size(CLI::App* cmd, Common& c) {
    cmd->add_option("--size", c.size,
                    "Image size WIDTHxHEIGHT, e.g. 640x360: replaces the scenario's \"image\" for this run (the "
                    "oracle cache keys the size it traces)")
        ->check(kUserName)
        ->check([](const std::string& text) {
            std::string problem;
            parse_size(text, problem);
            return problem;
        });
}

void add_sampling(CLI::App* cmd, SamplingArgs& a) {
    cmd->add_option("--seed", a.seed, "Area lights: seed of the sampling pattern (default 0)");
    cmd->add_option("--area-target", a.target, "Area lights: 95% half-width E a pixel samples down to (default 1/255)")
        ->check(range(1e-6, 1.0));
    cmd->add_option("--area-max-rays", a.max_rays, "Area lights: most rays per pixel (default 4096)")
        ->check(CLI::Range(16, 1 << 20));
}

ThreadLimit::ThreadLimit(int threads) {
    if (threads > 0) limit_.emplace(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
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

void add_tolerance(CLI::App* cmd, double& tolerance) {
    cmd->add_option("--tolerance", tolerance, "tau: |error| above this plus the oracle's E is wrong")
        ->check(range(0.0, 1.0));
}

void add_visible_threshold(CLI::App* cmd, double& threshold) {
    cmd->add_option("--visible-threshold", threshold,
                    "A wrong pixel is also visible when |error| >= this (counts_visible, rates_visible; default 0.1)")
        ->check(range(0.0, 1.0));
}

void add_verdict_options(CLI::App* cmd, VerdictArgs& v) {
    cmd->add_option("--cache", v.cache_dir,
                    "Oracle cache folder (default: $PENUMBRA_CACHE_DIR, $XDG_CACHE_HOME/penumbra, ~/.cache/penumbra)")
        ->check(kUserPath);
    cmd->add_option("--cache-max", v.cache_max,
                    "Oracle cache size cap, e.g. 2G; least recently used entries go (0: no cap; default: "
                    "$PENUMBRA_CACHE_MAX, else 2G)")
        ->check(cache_size_problem);
    cmd->add_flag("--no-cache", v.no_cache, "Trace the oracle and keep nothing");
    add_tolerance(cmd, v.tolerance);
    add_visible_threshold(cmd, v.visible_threshold);
    add_sampling(cmd, v.sampling);
}

ValidateOptions validate_options(const Common& c, const VerdictArgs& v) {
    ValidateOptions o;
    o.oracle = oracle_settings(c, v.sampling);
    o.use_cache = !v.no_cache;
    o.cache_dir = v.cache_dir;
    if (!v.no_cache)
        o.cache_max_bytes =
            v.cache_max.empty() ? OracleCache::default_max_bytes() : parse_cache_size(v.cache_max, "--cache-max");
    o.tolerance = v.tolerance;
    o.visible_threshold = v.visible_threshold;
    return o;
}

Scenario load_for_command(const std::filesystem::path& scenario_file, const Common& c) {
    ScenarioOptions so;
    so.allow_external_paths = c.allow_external_paths;
    so.max_memory_bytes = memory_budget(c.max_memory);
    Scenario scenario = load_scenario(scenario_file, so);
    if (!c.size.empty()) {  // checked by add_size; before anything keys or sizes the frame
        std::string unused;
        std::tie(scenario.width, scenario.height) = *parse_size(c.size, unused);
    }
    if (!c.quiet) {
        for (const auto& w : scenario.scene.warnings) fmt::print(stderr, "warning: {}\n", w);
        if (auto w = no_lights_warning(scenario)) fmt::print(stderr, "warning: {}\n", *w);
    }
    return scenario;
}

void check_run_memory(const Scenario& s, const Common& c, bool oracle, const raster::Technique* t, bool metrics) {
    RasterMemory rm;
    if (t) rm = raster::family_of(*t).memory(*t);  // the family's own terms
    check_memory(estimate_memory(memory_inputs(s, oracle, t ? &rm : nullptr, metrics)), memory_budget(c.max_memory),
                 s.label);
}

void add_technique(CLI::App* cmd, TechniqueArgs& t) {
    cmd->add_option("--technique", t.file, "Technique JSON file (replaces the scenario's \"technique\")")
        ->check(kUserPath);
    cmd->add_option("--preset", t.preset, "Start from a named preset (see below)")->check(kUserName);
    cmd->add_option("--set", t.sets, "Override one technique key, e.g. --set bias.slope=1.5 (repeatable)")
        ->check(kUserName)
        ->check(set_assignment_problem);
    cmd->add_option("--device", t.device,
                    "Vulkan device index or name part (default: $PENUMBRA_VK_DEVICE, else lavapipe)")
        ->check(kUserName);
    std::string text = "Presets:\n";
    for (const auto& p : raster::presets()) text += fmt::format("  {:<24}{}\n", p.name, p.description);
    cmd->footer(text);
}

void describe_outputs(CLI::App* cmd, std::string_view outputs, std::string_view example) {
    const std::string rest = cmd->get_footer();
    cmd->footer(fmt::format("{}\nExample:\n  {}\n{}{}", outputs, example, rest.empty() ? "" : "\n", rest));
}

nlohmann::json technique_json(const Scenario& scenario, const TechniqueArgs& t, std::string& label) {
    nlohmann::json j = scenario.technique;
    label = scenario.label + ": technique";
    if (!t.file.empty()) {
        j = read_json_file(t.file, kTechniqueJson);
        label = t.file.filename().string();
    }
    if (!t.preset.empty()) j["preset"] = t.preset;
    for (const auto& s : t.sets) {
        // A technique file's null is refused; a null given here would otherwise stand for "the
        // default" on one path and for an error on the other.
        if (const auto eq = s.find('='); eq != std::string::npos) {
            bool is_null = false;
            try {
                is_null = parse_json_strict(s.substr(eq + 1), "--set").is_null();
            } catch (const InputError&) {
            }
            if (is_null)
                throw InputError(fmt::format(
                    "--set {}: null is not a value for a technique key (a technique file's null is refused too); "
                    "leave the key out to keep its default",
                    s));
        }
        raster::apply_override(j, s);
    }
    return j;
}

raster::Technique resolve_technique(const Scenario& scenario, const TechniqueArgs& t) {
    std::string label;
    nlohmann::json j = technique_json(scenario, t, label);
    raster::Technique technique = raster::parse_technique(j, label, scenario.lights);
    // Checked against the scenario's cameras now, not once the oracle has traced (#50).
    if (const raster::Cascades* c = raster::cascades_of(technique); c && c->max_distance) {
        std::vector<const Camera*> cameras{&scenario.camera};
        if (scenario.camera_path)
            for (const CameraKey& k : scenario.camera_path->keys) cameras.push_back(&k.camera);
        for (const Camera* cam : cameras)
            if (!(*c->max_distance > cam->znear))
                throw InputError(
                    fmt::format("{}: cascades.max_distance: {} m is not beyond the camera's znear {} m (scenario {})",
                                label, *c->max_distance, cam->znear, scenario.label));
    }
    return technique;
}

void say_preset_differences(const raster::Technique& t, bool quiet) {
    if (quiet || t.preset.empty()) return;
    const nlohmann::json d = raster::preset_differences(t);
    if (d.empty()) return;
    std::string keys;
    std::size_t shown = 0;
    for (auto it = d.begin(); it != d.end() && shown < 8; ++it, ++shown)
        keys += fmt::format("{}{} {} (preset: {})", keys.empty() ? "" : ", ", it.key(),
                            json_excerpt(it.value()["technique"], 40), json_excerpt(it.value()["preset"], 40));
    if (d.size() > shown) keys += fmt::format(", and {} more (report.json: preset_differences)", d.size() - shown);
    fmt::print(
        "technique: preset {} with {} key{} of the technique object or --set over it (they win over the "
        "preset's defaults): {}\n",
        t.preset, d.size(), d.size() == 1 ? "" : "s", keys);
}

int gate_exit_code(const std::optional<metrics::GateResult>& gate, bool quiet) {
    if (!gate) return kExitSuccess;
    for (const auto& o : gate->outcomes)
        if (!o.passed) fmt::print(stderr, "{}\n", o.failure());
    // Count what failed, not what was checked: "FAILED (3 checks)" read as three failures.
    const auto failed =
        std::count_if(gate->outcomes.begin(), gate->outcomes.end(), [](const auto& o) { return !o.passed; });
    if (!quiet) {
        if (gate->passed)
            fmt::print("gate: passed ({} checks)\n", gate->outcomes.size());
        else
            fmt::print("gate: FAILED ({} of {} checks failed)\n", failed, gate->outcomes.size());
    }
    return gate->passed ? kExitSuccess : kExitGateFailed;
}

}  // namespace penumbra::cli
