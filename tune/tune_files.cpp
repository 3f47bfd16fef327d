#include "tune/tune_files.h"

#include <fmt/format.h>

#include <algorithm>

#include "image_io/image_io.h"
#include "metrics/metric_table.h"
#include "report/html_page.h"
#include "report/pareto_plot.h"
#include "report/report.h"
#include "report/report_files.h"

namespace penumbra::tune {
namespace {

// The searches shown: the shared one, or each light's (its points labelled with the light).
std::vector<std::pair<const TuneResult*, std::string>> searches(const TuneResult& res) {
    std::vector<std::pair<const TuneResult*, std::string>> out;
    if (res.per_light.empty()) out.emplace_back(&res, "");
    for (std::size_t li = 0; li < res.per_light.size(); ++li)
        out.emplace_back(&res.per_light[li], fmt::format("light {}: ", li));
    return out;
}

report::ScatterPlot pareto_plot(const TuneReport& r) {
    const TuneResult& res = r.result;
    report::ScatterPlot p;
    p.title = fmt::format("tune: {} against {} ({} renders{})", r.options.objective.visible() ? "visible acne" : "acne",
                          r.options.objective.minimize, res.evaluations.size(),
                          res.per_light.empty() ? "" : ", each light's search");
    p.x_label = res.per_light.empty() ? "worst acne rate over scenarios and lights"
                                      : "each light's acne rate (worst over scenarios)";
    p.y_label = r.options.objective.minimize;
    p.log_x = true;
    p.x_limit = r.options.objective.max_acne;
    p.x_limit_label = fmt::format("acne limit {}", r.options.objective.max_acne);
    // A log scale when the objective spans more than two decades (0 is drawn at the low end).
    double lo = 0, hi = 0;
    for (const auto& [sr, who] : searches(res))
        for (const auto& e : sr->evaluations)
            if (e.minimized > 0) {
                lo = lo == 0 ? e.minimized : std::min(lo, e.minimized);
                hi = std::max(hi, e.minimized);
            }
    p.log_y = lo > 0 && hi > 100 * lo;
    for (const auto& [sr, who] : searches(res))
        for (std::size_t i = 0; i < sr->evaluations.size(); ++i) {
            const Evaluation& e = sr->evaluations[i];
            report::PlotPoint q;
            // An acne rate of 0 has no place on a log axis: it is drawn at the axis' low end.
            q.x = e.worst_acne;
            q.y = e.minimized;
            // One front line joins points of one search: with several lights' searches on one plot
            // a line would join different lights (each light's front is in pareto.csv).
            q.on_front = res.per_light.empty() && std::find(sr->front.begin(), sr->front.end(), i) != sr->front.end();
            q.chosen = i == sr->chosen();
            q.start = sr->start && i == *sr->start;
            q.label = who + (q.start ? "start " : "") + describe(e.setting, r.options.knobs);
            p.points.push_back(q);
        }
    return p;
}

// What is compared before and after, per light: every error class as a rate, the visible error
// tune's rule compares, the perceptual error, the gap. Lower is better for each.
struct Row {
    std::string name;
    double before, after;
};
std::vector<Row> compared(const ValidateResult& b, const ValidateResult& a, std::size_t li) {
    const metrics::LightScore &lb = b.score.lights[li], &la = a.score.lights[li];
    std::vector<Row> rows;
    for (metrics::PixelClass c : metrics::kErrorClasses)
        rows.push_back({std::string(metrics::to_string(c)) + " rate", lb.rate(c), la.rate(c)});
    const VisibleBiasError vb = visible_bias_error(lb);
    const VisibleBiasError va = visible_bias_error(la);
    rows.push_back({"visible acne rate", vb.acne, va.acne});
    rows.push_back({"visible peter-panning rate", vb.peter_panning, va.peter_panning});
    if (vb.light_bleeding > 0 || va.light_bleeding > 0)
        rows.push_back({"visible light bleeding rate", vb.light_bleeding, va.light_bleeding});
    rows.push_back({VisibleBiasError::label(vb, va), vb.sum(), va.sum()});
    rows.push_back({"perceptual error mean", lb.perceptual.mean, la.perceptual.mean});
    rows.push_back({"wrong fraction", lb.wrong_fraction, la.wrong_fraction});
    rows.push_back({"peter-panning gap p95 (m)", lb.peter_panning_gap_p95, la.peter_panning_gap_p95});
    return rows;
}

// Per scenario and light: before and after for every class and the perceptual error, a warning
// where anything got worse, and the two class maps side by side at a size their legends read.
std::string revalidation_section(OutputTransaction& out, const char* title, const char* prefix,
                                 std::span<const Revalidation> rs, std::span<const std::string> files) {
    if (rs.empty()) return "";
    std::string h = fmt::format("<h2>{}</h2>\n", title);
    for (std::size_t k = 0; k < rs.size(); ++k) {
        const Revalidation& rv = rs[k];
        const std::string name = k < files.size() ? files[k] : rv.scenario->label;
        for (std::size_t li = 0; li < rv.after.score.lights.size(); ++li) {
            const std::vector<Row> rows = compared(rv.before, rv.after, li);
            std::string worse;
            std::string table = "<table><tr><th></th><th>start</th><th>recommended</th><th>change</th></tr>\n";
            for (const Row& r : rows) {
                const bool got_worse = r.after > r.before + 1e-12;
                if (got_worse) worse += (worse.empty() ? "" : ", ") + r.name;
                table += fmt::format("<tr{}><td>{}</td><td>{:.6f}</td><td>{:.6f}</td><td>{:+.6f}</td></tr>\n",
                                     got_worse ? " class=\"fail\"" : "", r.name, r.before, r.after, r.after - r.before);
            }
            table += "</table>\n";
            h += fmt::format("<h3>{}, light {}</h3>\n", report::escape_markup(name), li);
            if (!worse.empty()) h += fmt::format("<p class=\"fail\">&#9888; Worse than the start: {}.</p>\n", worse);
            h += table + "<div class=\"maps\">";
            for (int which = 0; which < 2; ++which) {
                const ValidateResult& v = which == 0 ? rv.before : rv.after;
                const std::string file =
                    fmt::format("{}{}.light{}.{}.classes.png", prefix, k, li, which == 0 ? "before" : "after");
                const Light* light =
                    rv.scenario && li < rv.scenario->lights.size() ? &rv.scenario->lights[li] : nullptr;
                report::write_class_map(out, file, v.oracle->frame, li, v.score.images[li], v.score.lights[li], light,
                                        rv.scenario);
                h += fmt::format(
                    "<figure><img src=\"data:image/png;base64,{}\" alt=\"{}\"><figcaption>{}: {}</figcaption>"
                    "</figure>",
                    base64_encode(out.written_bytes(file)), file, which == 0 ? "start" : "recommended", file);
            }
            h += "</div>\n";
        }
    }
    return h;
}

std::string units_table(const TuneReport& r) {
    std::string h =
        "<h2>The recommended bias in API units</h2>\n<table><tr><th>scenario</th><th>light</th><th>Vulkan "
        "constant / slope / clamp</th><th>D3D12 DepthBias D24 / D32, SlopeScaled, Clamp</th>"
        "<th>glPolygonOffset(factor, units)</th><th>constant in metres</th><th>world (m)</th>"
        "<th>normal offset (texels / m)</th></tr>\n";
    for (const ApiBias& b : r.units)
        h += fmt::format(
            "<tr><td>{}</td><td>{}</td><td>{:.4g} / {:.4g} / {:.4g}</td><td>{} / {}, {:.4g}, {:.4g}</td>"
            "<td>({:.4g}, {:.4g})</td><td>{:.4g}</td><td>{:.4g}</td><td>{:.4g} / {:.4g}</td></tr>\n",
            report::escape_markup(b.scenario < r.scenario_files.size() ? r.scenario_files[b.scenario]
                                                                       : std::to_string(b.scenario)),
            b.light, b.vk_constant, b.vk_slope, b.vk_clamp, b.d3d12_depth_bias_d24, b.d3d12_depth_bias_d32,
            b.d3d12_slope, b.d3d12_clamp, b.gl_factor, b.gl_units, b.constant_m, b.world_m, b.normal_offset_texels,
            b.normal_offset_m);
    return h + "</table>\n";
}

std::string html_page(OutputTransaction& out, const TuneReport& r, const std::string& svg) {
    const TuneResult& res = r.result;
    std::string h = report::html_page_head("penumbra tune", report::PageKind::tune) + "<h1>penumbra tune</h1>\n";
    const std::size_t chosen = res.chosen();
    for (std::size_t li = 0; li < res.per_light.size(); ++li) {
        const TuneResult& rl = res.per_light[li];
        const Evaluation& e = rl.evaluations[rl.chosen()];
        h += rl.kept_start
                 ? fmt::format(
                       "<p class=\"fail\">Light {}: keeps the start (<b>{}</b>): the best setting found was "
                       "worse ({}).</p>\n",
                       li, report::escape_markup(describe(e.setting, r.options.knobs)), report::escape_markup(rl.why))
                 : fmt::format("<p>Light {}: {} <b>{}</b>, {} = {:.6f}, {} {:.6f} (cap {}).</p>\n", li,
                               rl.winner ? "recommended" : "no setting met the cap; the best reachable:",
                               report::escape_markup(describe(e.setting, r.options.knobs)),
                               report::escape_markup(r.options.objective.minimize), e.minimized,
                               r.options.objective.visible() ? "visible acne" : "acne", e.worst_acne,
                               r.options.objective.max_acne);
    }
    if (!res.per_light.empty())
        h += "";  // each light said so above
    else if (res.kept_start)
        h += fmt::format("<p class=\"fail\">Keeps the start: the best setting found was worse ({}).</p>\n",
                         report::escape_markup(res.why));
    else if (res.winner)
        h += fmt::format(
            "<p>Recommended: <b>{}</b> (evaluation {} of {}), {} = {:.5f}, worst acne {:.5f} "
            "&le; {}.</p>\n",
            report::escape_markup(describe(res.evaluations[chosen].setting, r.options.knobs)), chosen,
            res.evaluations.size(), report::escape_markup(r.options.objective.minimize),
            res.evaluations[chosen].minimized, res.evaluations[chosen].worst_acne, r.options.objective.max_acne);
    else
        h += fmt::format(
            "<p class=\"fail\">No setting met acne &le; {}; the best reachable: <b>{}</b>, worst acne "
            "{:.5f}.</p>\n",
            r.options.objective.max_acne,
            report::escape_markup(describe(res.evaluations[chosen].setting, r.options.knobs)),
            res.evaluations[chosen].worst_acne);
    h += "<h2>Acne against peter-panning</h2>\n" + svg;
    h += units_table(r);
    h += revalidation_section(out, "Re-validated on the tuning scenarios", "tuned", r.tuned, r.scenario_files);
    h += revalidation_section(out, "Hold-out scenarios (not tuned on)", "holdout", r.holdout, r.holdout_files);
    h += "<p>Every evaluation is in tune.json and pareto.csv; technique.json is the recommendation, for "
         "<code>penumbra validate --technique</code>.</p>\n";
    h += report::image_check_script();
    h += "</body></html>\n";
    return h;
}

}  // namespace

void write_tune_outputs(OutputTransaction& out, const TuneReport& r) {
    out.write_json("technique.json", r.result.recommended.to_json());
    out.write_json("tune.json", tune_json(r));
    out.write_text("pareto.csv", pareto_csv(r));
    const report::ScatterPlot plot = pareto_plot(r);
    const std::string svg = report::plot_svg(plot);
    out.write_text("pareto.svg", svg);
    const int W = 720, H = 480;
    write_png(out, "pareto.png", W, H, report::plot_rgb(plot, W, H));
    out.write_text("report.html", html_page(out, r, svg));
}

}  // namespace penumbra::tune
