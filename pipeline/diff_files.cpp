#include "pipeline/diff_files.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <string_view>

#include "common/json_reader.h"
#include "report/html_page.h"
#include "report/report.h"
#include "report/report_files.h"

namespace penumbra::diff {

namespace {

using report::escape_markup;

// Larger class maps are not embedded: the page would be unwieldy (a 16384² map is far below this).
constexpr std::uint64_t kMaxEmbeddedImage = 64ull << 20;
// Nor more than this in all: 300 lights of 60 MB maps would make a 24 GB page (#50).
constexpr std::uint64_t kMaxEmbeddedTotal = 256ull << 20;

// `png` embedded as a data: URI when it is a PNG file of the run's own (a regular file, not a
// symbolic link to something elsewhere) and the page's budget, `budget` bytes, still has room.
std::string class_map(const std::filesystem::path& png, const std::string& alt, std::uint64_t& budget) {
    std::error_code ec;
    const std::filesystem::file_status st = std::filesystem::symlink_status(png, ec);
    if (std::filesystem::is_symlink(st))
        return fmt::format("<p class=\"missing\">no class map: {} is a symbolic link, which is not followed</p>",
                           escape_markup(path_text(png)));
    if (!std::filesystem::is_regular_file(st))
        return fmt::format("<p class=\"missing\">no class map: {} is not there</p>", escape_markup(path_text(png)));
    std::string bytes;
    try {
        bytes = read_regular_file(png, std::min(kMaxEmbeddedImage, budget));
    } catch (const std::exception& e) {
        return fmt::format("<p class=\"missing\">no class map: {}{}</p>", escape_markup(e.what()),
                           budget < kMaxEmbeddedImage ? " (the page's budget for embedded images is spent)" : "");
    }
    constexpr std::string_view kPngSignature = "\x89PNG\r\n\x1a\n";
    if (!std::string_view(bytes).starts_with(kPngSignature))
        return fmt::format("<p class=\"missing\">no class map: {} is not a PNG file</p>",
                           escape_markup(path_text(png)));
    budget -= bytes.size();
    return fmt::format(R"(<img src="data:image/png;base64,{}" alt="{}">)", base64_encode(bytes), escape_markup(alt));
}

std::string pct(double f) {
    return fmt::format("{:.4f}%", 100.0 * f);
}

std::string html_page(const Run& a, const Run& b, const DiffResult& d) {
    std::string h = report::html_page_head("penumbra diff", report::PageKind::diff) + "<h1>penumbra diff</h1>\n";
    h += fmt::format("<p>A: <code>{}</code> ({})<br>B: <code>{}</code> ({})<br>scenario: <code>{}</code></p>\n",
                     escape_markup(path_text(a.file)), escape_markup(a.kind), escape_markup(path_text(b.file)),
                     escape_markup(b.kind), escape_markup(a.scenario));
    if (d.worse()) {
        h += fmt::format("<p class=\"worse\">B is worse than A (tolerance {:.4f} points):</p>\n<ul>\n",
                         100.0 * d.tolerance);
        for (const auto& line : d.worse_lines) h += "<li>" + escape_markup(line) + "</li>\n";
        h += "</ul>\n";
    } else {
        h += fmt::format("<p class=\"better\">B is {} A (no class's rate rose by more than {:.4f} points).</p>\n",
                         d.identical() ? "identical to" : "not worse than", 100.0 * d.tolerance);
    }
    for (const auto& w : d.warnings) h += "<p class=\"missing\">warning: " + escape_markup(w) + "</p>\n";
    std::uint64_t budget = kMaxEmbeddedTotal;
    for (const LightChange& c : d.lights) {
        h += fmt::format("<h2>{}</h2>\n<p>scored {} → {}; wrong {} → {}{}; compared: {}</p>\n",
                         escape_markup(c.a.label()), c.a.scored, c.b.scored, pct(c.a.wrong_fraction),
                         pct(c.b.wrong_fraction), c.identical ? " (identical)" : "",
                         c.visible_basis ? "visible rates" : "rates");
        h += "<div class=\"wrap\"><table><tr><th>class</th><th>visible rate A</th><th>visible rate B</th>"
             "<th>count A</th><th>count B</th><th>rate A</th><th>rate B</th><th>change</th></tr>\n";
        for (std::size_t k = 0; k < kClasses.size(); ++k) {
            const ClassChange& cc = c.classes[k];
            const char* cls = cc.worse ? "worse" : cc.change < 0 ? "better" : "";
            h += fmt::format(
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>"
                "<td class=\"{}\">{:+.4f} pts</td></tr>\n",
                kClasses[k], c.visible_basis ? pct(c.a.rates_visible[k]) : "-",
                c.visible_basis ? pct(c.b.rates_visible[k]) : "-", c.a.counts[k], c.b.counts[k], pct(c.a.rates[k]),
                pct(c.b.rates[k]), cls, 100.0 * cc.change);
        }
        h += "</table></div>\n";
        if (c.a.perceptual_mean && c.b.perceptual_mean)
            h += fmt::format("<p>perceptual error: mean {:.5f} → {:.5f}, max {:.5f} → {:.5f}</p>\n",
                             *c.a.perceptual_mean, *c.b.perceptual_mean, *c.a.perceptual_max, *c.b.perceptual_max);
        h += "<div class=\"grid\"><div><b>A</b>" + class_map(c.a.class_map, "A: " + c.a.label(), budget) +
             "</div><div><b>B</b>" + class_map(c.b.class_map, "B: " + c.b.label(), budget) + "</div></div>\n";
    }
    h += report::image_check_script();
    h += "</body></html>\n";
    return h;
}

}  // namespace

void write_diff_outputs(OutputTransaction& out, const Run& a, const Run& b, const DiffResult& d) {
    out.write_json("diff.json", diff_json(a, b, d));
    out.write_text("diff.html", html_page(a, b, d));
}

}  // namespace penumbra::diff
