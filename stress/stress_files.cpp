#include "stress/stress_files.h"

#include <fmt/format.h>

#include "report/html_page.h"
#include "report/report.h"
#include "report/report_files.h"

namespace penumbra::stress {

namespace {

using report::escape_markup;

std::string percent(const nlohmann::json& v) {
    return v.is_number() ? fmt::format("{:.2f}%", 100.0 * v.get<double>()) : "-";
}

std::string rate_cells(const nlohmann::json& light) {
    std::string s = fmt::format("<td>{}</td>", percent(light.at("wrong_fraction")));
    for (const char* k : {"acne", "peter_panning", "aliasing", "false_shadow", "false_lit", "light_bleeding"})
        s += fmt::format("<td>{}</td>", percent(light.at("rates").value(k, nlohmann::json())));
    return s;
}

std::string html_page(const std::vector<StressCase>& cases, const SuiteResult& result, const nlohmann::json& stress,
                      const OutputTransaction& out) {
    std::string rows;
    for (std::size_t k = 0; k < result.cases.size(); ++k) {
        const StressCase& c = cases[k];
        const nlohmann::json& j = stress.at("cases")[k];
        const CaseResult& r = result.cases[k];
        const auto& lights = j.at("lights");
        const std::size_t span = std::max<std::size_t>(1, lights.size());
        const bool holds = r.invariant.holds();
        for (std::size_t li = 0; li < span; ++li) {
            rows += "<tr>";
            if (li == 0)
                rows += fmt::format(
                    "<td rowspan=\"{0}\"><b>{1}</b><br><small>{2}</small><br><small>canonical: {3}</small></td>"
                    "<td rowspan=\"{0}\" class=\"{4}\">{5}<br><small>{6} differ, {7} uncertain, {8} compared, {9} "
                    "coverage differs</small></td>",
                    span, escape_markup(c.name), escape_markup(c.stresses), escape_markup(c.canonical),
                    holds ? "ok" : "bad", holds ? "holds" : "FAILS", r.invariant.differing, r.invariant.uncertain,
                    r.invariant.compared, r.invariant.coverage_differs);
            if (li < lights.size()) {
                const auto& l = lights[li];
                rows += fmt::format("<td>{} {}</td>", li, escape_markup(l.value("name", "")));
                rows += rate_cells(l);
                rows += j.contains("lights_at_canonical")
                            ? fmt::format("<td>{}</td>", percent(j["lights_at_canonical"][li].at("wrong_fraction")))
                            : "<td>-</td>";
                const std::string png = fmt::format("{}.light{}.classes.png", c.name, li);
                rows += fmt::format("<td><img src=\"data:image/png;base64,{}\" alt=\"{}\"></td>",
                                    base64_encode(out.written_bytes(png)), escape_markup(png));
            } else {
                rows += "<td colspan=\"9\">no lights</td>";
            }
            rows += "</tr>\n";
        }
    }
    // "Suite passed" must say what passed: the oracle's invariance, and the technique's gate
    // only when one was given (the technique's rates are otherwise reported, not judged).
    const bool gated = result.technique_gated();
    const std::string verdict = fmt::format(
        "Suite {}: {}.", result.passed ? "passed" : "FAILED",
        gated ? "the oracle's invariance and the technique's gate"
              : "the oracle's invariance only; no gate was given, so the technique's verdicts below are reported, "
                "not judged (give one with --gate)");
    std::string highest;
    for (const auto& [cls, best] : stress.at("highest_rates").items())
        if (best.is_object())
            highest += fmt::format("{}<b>{}</b>: {} light {} ({})", highest.empty() ? "" : "; ", escape_markup(cls),
                                   escape_markup(best.at("case").get<std::string>()), best.at("light").get<int>(),
                                   percent(best.at("rate")));
    return report::html_page_head("penumbra stress", report::PageKind::stress) +
           fmt::format(R"(<h1>penumbra stress</h1>
<p>{} cases, {}x{} px, on {}; {:.1f} s. Oracle invariant: {} of {} cases hold. {}</p>
<p>Technique: <code>{}</code></p>
<p>Highest rate per class: {}</p>
<p>Rates are fractions of scored pixels (docs/metrics.md); "at canonical" is the technique's wrong fraction on the
canonical version (far and scale cases). The oracle invariant compares the case's oracle with its canonical
version's outside uncertain pixels (docs/stress.md).</p>
<table>
<tr><th>case</th><th>oracle invariant</th><th>light</th><th>wrong</th><th>acne</th><th>peter-panning</th>
<th>aliasing</th><th>false shadow</th><th>false lit</th><th>light bleeding</th><th>wrong at canonical</th><th>class map</th></tr>
{}</table>
<p><small>penumbra {}</small></p>
</body></html>
)",
                       result.cases.size(), stress.at("image").at("width").get<int>(),
                       stress.at("image").at("height").get<int>(), escape_markup(result.device), result.seconds,
                       result.cases.size() - stress.at("oracle_invariant_failures").get<std::size_t>(),
                       result.cases.size(), escape_markup(verdict), escape_markup(stress.at("technique").dump()),
                       highest, rows, escape_markup(stress.at("version").get<std::string>()));
}

}  // namespace

void write_stress_outputs(OutputTransaction& out, const std::vector<StressCase>& cases, const SuiteResult& result,
                          const nlohmann::json& stress) {
    for (std::size_t k = 0; k < result.cases.size(); ++k) {
        const CaseResult& r = result.cases[k];
        for (std::size_t li = 0; li < r.judged.score.lights.size(); ++li)
            report::write_class_map(out, fmt::format("{}.light{}.classes.png", cases[k].name, li), r.oracle->frame, li,
                                    r.judged.score.images[li], r.judged.score.lights[li]);
    }
    out.write_json("stress.json", stress);
    out.write_text("report.html", html_page(cases, result, stress, out));
}

}  // namespace penumbra::stress
