#include "tune/tune_files.h"

#include <fmt/format.h>

#include <algorithm>

#include "image_io/image_io.h"
#include "metrics/metric_table.h"
#include "report/pareto_plot.h"
#include "report/report.h"
#include "report/report_files.h"

namespace penumbra::tune {
namespace {

report::ScatterPlot pareto_plot(const TuneReport& r) {
    const TuneResult& res = r.result;
    const std::size_t chosen = res.winner ? *res.winner : res.best_reachable;
    report::ScatterPlot p;
    p.title = fmt::format("tune: worst acne rate against {} ({} evaluations)", r.options.objective.minimize,
                          res.evaluations.size());
    p.x_label = "worst acne rate over scenarios and lights";
    p.y_label = r.options.objective.minimize;
    p.log_x = true;
    p.x_limit = r.options.objective.max_acne;
    p.x_limit_label = fmt::format("acne limit {}", r.options.objective.max_acne);
    // A log scale when the objective spans more than two decades (0 is drawn at the low end).
    double lo = 0, hi = 0;
    for (const auto& e : res.evaluations)
        if (e.minimized > 0) {
            lo = lo == 0 ? e.minimized : std::min(lo, e.minimized);
            hi = std::max(hi, e.minimized);
        }
    p.log_y = lo > 0 && hi > 100 * lo;
    for (std::size_t i = 0; i < res.evaluations.size(); ++i) {
        const Evaluation& e = res.evaluations[i];
        report::PlotPoint q;
        // An acne rate of 0 has no place on a log axis: it is drawn at the axis' low end.
        q.x = e.worst_acne;
        q.y = e.minimized;
        q.on_front = std::find(res.front.begin(), res.front.end(), i) != res.front.end();
        q.chosen = i == chosen;
        q.label = describe(e.setting, r.options.knobs);
        p.points.push_back(q);
    }
    return p;
}

std::string rate_cells(const metrics::LightScore& l) {
    return fmt::format("<td>{:.4f}</td><td>{:.4f}</td><td>{:.4f}</td><td>{:.4f}</td>",
                       l.rate(metrics::PixelClass::acne), l.rate(metrics::PixelClass::peter_panning),
                       l.peter_panning_gap_p95, l.wrong_fraction);
}

// A table row and class maps per scenario and light, before and after.
std::string revalidation_section(OutputTransaction& out, const char* title, const char* prefix,
                                 std::span<const Revalidation> rs, std::span<const std::string> files) {
    if (rs.empty()) return "";
    std::string h = fmt::format(
        "<h2>{}</h2>\n<table><tr><th>scenario</th><th>light</th><th></th><th>acne</th>"
        "<th>peter-panning</th><th>gap p95 (m)</th><th>wrong</th><th>class map</th></tr>\n",
        title);
    for (std::size_t k = 0; k < rs.size(); ++k) {
        const Revalidation& rv = rs[k];
        const std::string name = k < files.size() ? files[k] : rv.scenario->label;
        for (std::size_t li = 0; li < rv.after.score.lights.size(); ++li) {
            for (int which = 0; which < 2; ++which) {
                const ValidateResult& v = which == 0 ? rv.before : rv.after;
                const std::string file =
                    fmt::format("{}{}.light{}.{}.classes.png", prefix, k, li, which == 0 ? "before" : "after");
                report::write_class_map(out, file, v.oracle->frame, li, v.score.images[li], v.score.lights[li]);
                h += fmt::format(
                    "<tr><td>{}</td><td>{}</td><td>{}</td>{}<td><img src=\"data:image/png;base64,{}\" "
                    "alt=\"{}\" width=\"320\"></td></tr>\n",
                    report::escape_markup(name), li, which == 0 ? "before" : "after", rate_cells(v.score.lights[li]),
                    base64_encode(out.written_bytes(file)), file);
            }
        }
    }
    return h + "</table>\n";
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
            b.scenario, b.light, b.vk_constant, b.vk_slope, b.vk_clamp, b.d3d12_depth_bias_d24, b.d3d12_depth_bias_d32,
            b.d3d12_slope, b.d3d12_clamp, b.gl_factor, b.gl_units, b.constant_m, b.world_m, b.normal_offset_texels,
            b.normal_offset_m);
    return h + "</table>\n";
}

std::string html_page(OutputTransaction& out, const TuneReport& r, const std::string& svg) {
    const TuneResult& res = r.result;
    std::string h = R"(<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>penumbra tune</title>
<style>body{font-family:sans-serif;margin:24px;max-width:1200px}table{border-collapse:collapse}
td,th{border:1px solid #ccc;padding:4px 8px;text-align:left}.fail{color:#b00}</style></head><body>
<h1>penumbra tune</h1>
)";
    const std::size_t chosen = res.winner ? *res.winner : res.best_reachable;
    if (res.winner)
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
