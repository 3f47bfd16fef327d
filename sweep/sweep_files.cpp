#include "sweep/sweep_files.h"

#include <fmt/format.h>

#include <algorithm>

#include "image_io/image_io.h"
#include "report/html_page.h"
#include "report/pareto_plot.h"
#include "report/report.h"
#include "report/report_files.h"

namespace penumbra::sweep {
namespace {

std::string label_of(const Table& t, const Row& r) {
    std::string l;
    for (std::size_t k = 0; k < r.values.size(); ++k) {
        if (!l.empty()) l += " ";
        l += t.keys.size() == 1 && t.keys[0] == "configuration" ? r.values[k] : t.keys[k] + "=" + r.values[k];
    }
    return l;
}

// Pareto front of (production ms, wrong_fraction): no other configuration is at least as fast
// and as right, and better in one.
std::vector<bool> front(const Table& t) {
    std::vector<bool> on(t.rows.size(), true);
    for (std::size_t i = 0; i < t.rows.size(); ++i)
        for (std::size_t j = 0; j < t.rows.size() && on[i]; ++j) {
            if (i == j) continue;
            const double ti = median(t.rows[i].production_ms), tj = median(t.rows[j].production_ms);
            const double ei = t.rows[i].verdict[0], ej = t.rows[j].verdict[0];
            const bool no_worse = tj <= ti && ej <= ei, strictly = tj < ti || ej < ei;
            on[i] = !(no_worse && (strictly || j < i));
        }
    return on;
}

report::ScatterPlot plot_of(const Table& t) {
    report::ScatterPlot p;
    p.title = fmt::format("sweep: error against production GPU time ({} configurations, {})", t.rows.size(),
                          t.device.value("name", std::string("device")));
    p.x_label = "production GPU ms (median of " + std::to_string(t.repeat) + ")";
    p.y_label = "wrong_fraction";
    const std::vector<bool> on = front(t);
    double lo = 0, hi = 0;
    for (std::size_t i = 0; i < t.rows.size(); ++i) {
        report::PlotPoint q;
        q.x = median(t.rows[i].production_ms);
        q.y = t.rows[i].verdict[0];
        q.on_front = on[i];
        q.label = label_of(t, t.rows[i]);
        p.points.push_back(q);
        if (q.x > 0) {
            lo = lo == 0 ? q.x : std::min(lo, q.x);
            hi = std::max(hi, q.x);
        }
    }
    p.log_x = lo > 0 && hi > 20 * lo;
    return p;
}

std::string html_page(const Table& t, const std::string& svg, const std::string& csv_table) {
    std::string h = report::html_page_head("penumbra sweep", report::PageKind::sweep) + "<h1>penumbra sweep</h1>\n";
    h += fmt::format(
        "<p>{} on {} ({}): {} configurations; GPU times are medians of {} renders. Production: the "
        "shadow pass and V alone, as an engine draws it; diagnostic: the same with every depth-map "
        "lookup penumbra reads back. Blue: the Pareto front of error against production time.</p>\n",
        report::escape_markup(t.scenario), report::escape_markup(t.device.value("name", std::string())),
        report::escape_markup(t.device.value("driver", std::string())), t.rows.size(), t.repeat);
    // lavapipe's "GPU" times are a CPU's: they rank configurations on this machine only.
    if (t.device.value("type", std::string()) == "cpu")
        h += "<p class=\"note\">This device is a CPU (lavapipe): its \"GPU\" times are the CPU's time to "
             "rasterise, which rank configurations on this machine and say little about a GPU's cost. Run the "
             "sweep with <code>--device</code> on a GPU for engine costs.</p>\n";
    // Timings to trust: repeats that disagree say the device's speed changed during the run.
    std::string disagree;
    std::size_t n_disagree = 0;
    for (const Row& r : t.rows)
        if (repeats_disagree(r) && n_disagree++ < 20)
            disagree += fmt::format("{}{} (production {:.3f}&ndash;{:.3f} ms, diagnostic {:.3f}&ndash;{:.3f} ms)",
                                    disagree.empty() ? "" : "; ", report::escape_markup(label_of(t, r)),
                                    minimum(r.production_ms), maximum(r.production_ms), minimum(r.diagnostic_ms),
                                    maximum(r.diagnostic_ms));
    if (n_disagree > 0)
        h += fmt::format(
            "<p class=\"note\">The repeats of {} configuration{} disagree by more than {:.0f}% of their median "
            "((max &minus; min) / median, after {} discarded warm-up render{} of each kind): read their times "
            "as uncertain. {}{}</p>\n",
            n_disagree, n_disagree == 1 ? "" : "s", kRepeatSpreadMargin * 100, kWarmUpRenders,
            kWarmUpRenders == 1 ? "" : "s", disagree,
            n_disagree > 20 ? "; &hellip; (sweep.json: repeats_disagree)" : "");
    h += svg;
    // Every point of the front, by name: the plot's labels may overlap.
    const std::vector<bool> on = front(t);
    h += "<h2>Pareto front</h2>\n<ol>\n";
    for (std::size_t i = 0; i < t.rows.size(); ++i)
        if (on[i])
            h += fmt::format("<li>{}: wrong {:.5f}, production {:.3f} ms</li>\n",
                             report::escape_markup(label_of(t, t.rows[i])), t.rows[i].verdict[0],
                             median(t.rows[i].production_ms));
    h += "</ol>\n" + csv_table;
    h += report::image_check_script();
    h += "</body></html>\n";
    return h;
}

std::string table_html(const Table& t) {
    const std::vector<bool> on = front(t);
    // The table scrolls inside its own box: a sweep over many keys is wider than the page.
    std::string h = "<h2>Configurations</h2>\n<div class=\"scroll\"><table><tr>";
    for (const auto& k : t.keys) h += "<th>" + report::escape_markup(k) + "</th>";
    for (const auto& c : t.columns) h += "<th>" + report::escape_markup(c) + "</th>";
    h += "<th>production ms</th><th>diagnostic ms</th><th>front</th></tr>\n";
    for (std::size_t i = 0; i < t.rows.size(); ++i) {
        const Row& r = t.rows[i];
        h += "<tr>";
        for (const auto& v : r.values) h += "<th>" + report::escape_markup(v) + "</th>";
        for (double v : r.verdict) h += fmt::format("<td>{:.5f}</td>", v);
        h += fmt::format("<td>{:.3f}</td><td>{:.3f}</td><td>{}</td></tr>\n", median(r.production_ms),
                         median(r.diagnostic_ms), on[i] ? "&#9679;" : "");
    }
    return h + "</table></div>\n";
}

}  // namespace

void write_sweep_outputs(OutputTransaction& out, const Table& t) {
    out.write_text("sweep.csv", sweep_csv(t));
    out.write_json("sweep.json", to_json(t));
    const report::ScatterPlot plot = plot_of(t);
    const std::string svg = report::plot_svg(plot, 900, 560);
    out.write_text("pareto.svg", svg);
    write_png(out, "pareto.png", 900, 560, report::plot_rgb(plot, 900, 560));
    out.write_text("report.html", html_page(t, svg, table_html(t)));
}

}  // namespace penumbra::sweep
