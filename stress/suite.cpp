#include "stress/suite.h"

#include <fmt/format.h>

#include <algorithm>
#include <stdexcept>

#include "common/errors.h"
#include "common/stopwatch.h"
#include "common/version.h"
#include "oracle/oracle_output.h"
#include "raster/vulkan_context.h"
#include "report/report.h"

namespace penumbra::stress {

namespace {

std::shared_ptr<const OracleRun> trace(const Scenario& scenario, const OracleSettings& settings) {
    auto t0 = SteadyClock::now();
    OracleResult result = run_oracle(scenario, settings);
    auto run = std::make_shared<OracleRun>();
    run->info = oracle_json(scenario, result, {});
    run->seconds = seconds_since(t0);
    run->frame = std::move(result.frame);
    return run;
}

metrics::Gate case_gate(const StressGate& g, const StressCase& c, const std::string& label) {
    if (!g.given || g.checks.empty()) return {};
    return metrics::parse_gate(g.checks, label + " (" + c.name + ")", c.scenario.lights, metrics::GateOrigin::file);
}

nlohmann::json light_rates(const ValidateResult& r) {
    nlohmann::json lights = nlohmann::json::array();
    for (const auto& l : r.report.at("lights")) {
        nlohmann::json o = {{"index", l.at("index")},   {"type", l.at("type")},
                            {"pixels", l.at("pixels")}, {"counts", l.at("counts")},
                            {"rates", l.at("rates")},   {"wrong_fraction", l.at("wrong_fraction")},
                            {"mae", l.at("mae")}};
        lights.push_back(std::move(o));
    }
    return lights;
}

}  // namespace

OracleInvariant compare_oracles(const OracleFrame& a, const OracleFrame& b) {
    if (a.width != b.width || a.height != b.height || a.lights.size() != b.lights.size())
        throw std::invalid_argument("compare_oracles: the frames describe different images");
    OracleInvariant inv;
    const std::size_t n = a.pixel_count();
    for (std::size_t i = 0; i < n; ++i) {
        if (a.prim[i] != b.prim[i]) {
            ++inv.coverage_differs;
            continue;
        }
        if (a.A[i] == 0) continue;
        for (std::size_t li = 0; li < a.lights.size(); ++li) {
            const OracleLightImage &la = a.lights[li], &lb = b.lights[li];
            if (la.U[i] != 0 || lb.U[i] != 0) {
                ++inv.uncertain;
                continue;
            }
            ++inv.compared;
            // Punctual lights: V is exactly 0 or 1, so equality is the comparison (no tolerance).
            if (la.V[i] != lb.V[i] || la.lightable[i] != lb.lightable[i]) {
                ++inv.differing;
                if (inv.first_differing.size() < 8) inv.first_differing.push_back(i);
            }
        }
    }
    return inv;
}

StressGate parse_stress_gate(const nlohmann::json& value, const std::string& label,
                             const std::vector<StressCase>& cases) {
    StressGate g;
    g.given = true;
    if (!value.is_object()) throw InputError(fmt::format("{}: expected an object", label));
    nlohmann::json checks = nlohmann::json::object();
    for (const auto& [key, v] : value.items()) {
        if (key == "oracle_invariant") {
            if (!v.is_boolean()) throw InputError(fmt::format("{}: oracle_invariant: expected true or false", label));
            g.oracle_invariant = v.get<bool>();
        } else {
            checks[key] = v;  // the metrics gate's own keys, checked by parse_gate
        }
    }
    if (checks.contains("checks") && checks["checks"].is_array())
        for (std::size_t i = 0; i < checks["checks"].size(); ++i)
            if (checks["checks"][i].is_object() && checks["checks"][i].contains("light"))
                throw InputError(fmt::format(
                    "{}: checks[{}].light: a stress gate applies to every light of every case; cases differ in "
                    "their lights",
                    label, i));
    g.checks = checks;
    if (!checks.empty())
        for (const auto& c : cases) case_gate(g, c, label);  // every check against every case, before any work
    if (checks.empty() && !g.oracle_invariant)
        throw InputError(fmt::format("{}: the gate checks nothing (no checks and oracle_invariant false)", label));
    return g;
}

bool SuiteResult::technique_gated() const {
    return std::any_of(cases.begin(), cases.end(),
                       [](const CaseResult& r) { return r.gate && !r.gate->outcomes.empty(); });
}

bool CaseResult::passed(const StressGate& g) const {
    return (!g.oracle_invariant || invariant.holds()) && (!gate || gate->passed);
}

void check_technique_cases(const raster::Technique& technique, const std::vector<StressCase>& cases,
                           const std::string& label) {
    for (const auto& c : cases)
        raster::check_technique_lights(technique, c.scenario.lights, label + " (" + c.name + ")");
}

SuiteResult run_suite(const std::vector<StressCase>& cases, const raster::Technique& technique, const StressGate& gate,
                      const SuiteOptions& options) {
    auto t0 = SteadyClock::now();
    SuiteResult out;
    raster::ContextOptions co;
    co.device = options.validate.device;
    raster::VulkanContext ctx(co);
    out.device = ctx.info().name;
    for (std::size_t k = 0; k < cases.size(); ++k) {
        const StressCase& c = cases[k];
        if (options.progress) options.progress(k, cases.size(), c.name);
        auto t1 = SteadyClock::now();
        CaseResult r;
        r.name = c.name;
        r.oracle = trace(c.scenario, options.validate.oracle);
        r.reference_oracle = trace(c.reference, options.validate.oracle);
        r.invariant = compare_oracles(r.oracle->frame, r.reference_oracle->frame);
        const metrics::Gate g = case_gate(gate, c, "gate");
        {
            raster::RasterSession session(c.scenario, ctx);
            r.judged = validate(c.scenario, technique, g, options.validate, &session, r.oracle);
        }
        if (c.judge_reference) {
            raster::RasterSession session(c.reference, ctx);
            r.reference = validate(c.reference, technique, {}, options.validate, &session, r.reference_oracle);
        }
        r.gate = r.judged.gate;
        r.seconds = seconds_since(t1);
        out.passed = out.passed && r.passed(gate);
        out.cases.push_back(std::move(r));
    }
    if (options.progress) options.progress(cases.size(), cases.size(), "");
    out.seconds = seconds_since(t0);
    return out;
}

nlohmann::json stress_json(const std::vector<StressCase>& cases, const SuiteResult& result,
                           const raster::Technique& technique, const StressGate& gate,
                           const CaseOptions& case_options) {
    nlohmann::json list = nlohmann::json::array();
    std::size_t invariant_failures = 0;
    for (std::size_t k = 0; k < result.cases.size(); ++k) {
        const StressCase& c = cases[k];
        const CaseResult& r = result.cases[k];
        invariant_failures += !r.invariant.holds();
        nlohmann::json first = nlohmann::json::array();
        for (std::size_t i : r.invariant.first_differing)
            first.push_back(
                {i % static_cast<std::size_t>(c.scenario.width), i / static_cast<std::size_t>(c.scenario.width)});
        nlohmann::json lights = light_rates(r.judged);
        for (std::size_t li = 0; li < lights.size(); ++li) lights[li]["name"] = c.scenario.lights[li].origin;
        nlohmann::json o = {{"name", c.name},
                            {"group", c.group},
                            {"stresses", c.stresses},
                            {"canonical", c.canonical},
                            {"oracle_invariant", r.invariant.holds()},
                            {"differing_pixels", r.invariant.differing},
                            {"first_differing", first},
                            {"uncertain_pixels", r.invariant.uncertain},
                            {"compared_pixels", r.invariant.compared},
                            {"coverage_differs", r.invariant.coverage_differs},
                            {"triangles", c.scenario.scene.triangle_count()},
                            {"lights", lights},
                            {"warnings", r.judged.warnings},
                            {"seconds", r.seconds},
                            {"timing",
                             {{"oracle_s", r.oracle->seconds + r.reference_oracle->seconds},
                              {"raster_s", r.judged.raster_s + (r.reference ? r.reference->raster_s : 0.0)},
                              {"metrics_s", r.judged.metrics_s + (r.reference ? r.reference->metrics_s : 0.0)}}}};
        if (r.reference) o["lights_at_canonical"] = light_rates(*r.reference);
        if (r.gate) o["gate"] = r.judged.report.at("gate");
        o["passed"] = r.passed(gate);
        list.push_back(std::move(o));
    }
    // Where the rates explode, class by class: the case and light with the highest rate.
    nlohmann::json highest = nlohmann::json::object();
    for (const char* cls : {"acne", "peter_panning", "aliasing", "false_shadow", "false_lit", "wrong_fraction"}) {
        nlohmann::json best = nullptr;
        double top = 0;  // a class no case has stays null
        for (const auto& c : list)
            for (const auto& l : c.at("lights")) {
                const nlohmann::json& v = std::string(cls) == "wrong_fraction" ? l.at(cls) : l.at("rates").at(cls);
                if (v.is_number() && v.get<double>() > top) {
                    top = v.get<double>();
                    best = {{"case", c.at("name")}, {"light", l.at("index")}, {"rate", top}};
                }
            }
        highest[cls] = best;
    }
    return {{"version", version_string()},
            {"device", result.device},
            {"image", {{"width", case_options.width}, {"height", case_options.height}}},
            {"seed", case_options.seed},
            {"technique", technique.to_json()},
            {"oracle_invariant_gated", gate.oracle_invariant},
            {"cases_run", result.cases.size()},
            {"oracle_invariant_failures", invariant_failures},
            {"passed", result.passed},
            {"seconds", result.seconds},
            {"highest_rates", highest},
            {"cases", list}};
}

std::vector<std::string> failure_lines(const std::vector<StressCase>& cases, const SuiteResult& result,
                                       const StressGate& gate) {
    std::vector<std::string> lines;
    for (std::size_t k = 0; k < result.cases.size(); ++k) {
        const CaseResult& r = result.cases[k];
        const int w = cases[k].scenario.width;
        if (gate.oracle_invariant && !r.invariant.holds()) {
            std::size_t i = r.invariant.first_differing.front();
            lines.push_back(fmt::format(
                "case {}: oracle invariant: {} pixel-lights differ from the canonical version outside U (first at "
                "{},{})",
                r.name, r.invariant.differing, i % w, i / w));
        }
        if (r.gate)
            for (const auto& o : r.gate->outcomes)
                if (!o.passed) lines.push_back(fmt::format("case {}: {}", r.name, o.failure()));
    }
    return lines;
}

std::string stress_junit(const std::vector<StressCase>& cases, const SuiteResult& result, const StressGate& gate) {
    using report::escape_markup;
    std::string body;
    std::size_t tests = 0, failures = 0;
    for (std::size_t k = 0; k < result.cases.size(); ++k) {
        const CaseResult& r = result.cases[k];
        const std::string cls = "stress." + escape_markup(r.name);
        if (gate.oracle_invariant) {
            ++tests;
            body += fmt::format("    <testcase classname=\"{}\" name=\"oracle invariant\" time=\"{:.3f}\">\n", cls,
                                r.oracle->seconds + r.reference_oracle->seconds);
            if (!r.invariant.holds()) {
                ++failures;
                std::size_t i = r.invariant.first_differing.front();
                const int w = cases[k].scenario.width;
                std::string msg =
                    fmt::format("{} pixel-lights differ from the canonical version outside U (first at {},{})",
                                r.invariant.differing, i % w, i / w);
                body +=
                    fmt::format("      <failure message=\"{0}\" type=\"oracle\">{0}</failure>\n", escape_markup(msg));
            }
            body += "    </testcase>\n";
        }
        if (r.gate)
            for (const auto& o : r.gate->outcomes) {
                ++tests;
                body += fmt::format("    <testcase classname=\"{}.light{}\" name=\"{}\" time=\"0\">\n", cls, o.light,
                                    escape_markup(o.name()));
                if (!o.passed) {
                    ++failures;
                    body += fmt::format("      <failure message=\"{0}\" type=\"gate\">{0}</failure>\n",
                                        escape_markup(o.failure()));
                }
                body += "    </testcase>\n";
            }
    }
    return fmt::format(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites name=\"penumbra\" tests=\"{0}\" failures=\"{1}\" "
        "errors=\"0\">\n  <testsuite name=\"penumbra stress\" tests=\"{0}\" failures=\"{1}\" errors=\"0\" "
        "skipped=\"0\" time=\"{2:.3f}\">\n{3}  </testsuite>\n</testsuites>\n",
        tests, failures, result.seconds, body);
}

}  // namespace penumbra::stress
