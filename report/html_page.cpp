#include "report/html_page.h"

namespace penumbra::report {

namespace {

// The report and diff share their dark base (class "dark"); every other rule is its page's own.
constexpr std::string_view kPageStyle = R"(
body.dark{font-family:system-ui,sans-serif;background:#16181d;color:#e6e6e6;margin:2em;max-width:1400px}
.dark h1,.dark h2{font-weight:600} .dark table{border-collapse:collapse;margin:.5em 0 1em} .dark td,.dark th{padding:.25em .8em;border-bottom:1px solid #333;text-align:right}
.dark th:first-child,.dark td:first-child{text-align:left} .dark img{max-width:100%;display:block;margin:.5em 0;image-rendering:pixelated}
.report pre{background:#0e0f12;padding:1em;overflow:auto;white-space:pre-wrap;word-break:break-all} .report .pass{color:#4caf50} .report .fail{color:#ff5252} .report .swatch{display:inline-block;width:.9em;height:.9em;margin-right:.4em;vertical-align:middle}
.report .grid{display:grid;grid-template-columns:minmax(0,1fr) minmax(0,1fr);gap:1em} .report .scroll{overflow-x:auto;max-width:100%}
.report a{color:#8ab4f8} .report nav{margin:.5em 0 1em} .report td.reading{text-align:left;max-width:36em}
.report .strip{display:flex;flex-wrap:wrap;gap:1em} .report .strip a{color:#e6e6e6;text-decoration:none;width:min(24em,100%)} .report .strip img{margin:.2em 0}
.report .classmap{display:grid;grid-template-columns:minmax(0,3fr) minmax(0,1fr);gap:1em} .report dl.classes dt{font-weight:600;margin-top:.5em} .report dl.classes dd{margin:0 0 0 1.3em;color:#bbb}
.diff .worse{color:#ff5252;font-weight:bold} .diff .better{color:#4caf50} .diff .missing{color:#999}
.diff .grid{display:grid;grid-template-columns:1fr 1fr;gap:1em} .diff .wrap{overflow-x:auto}
body.tune{font-family:sans-serif;margin:24px;max-width:1200px}.tune table{border-collapse:collapse}
.tune td,.tune th{border:1px solid #ccc;padding:4px 8px;text-align:left}.tune .fail{color:#b00}
.tune .maps{display:flex;gap:12px;flex-wrap:wrap}.tune .maps figure{margin:0;flex:1 1 560px;max-width:800px}
.tune .maps img{width:100%;height:auto}
body.sweep{font-family:sans-serif;margin:24px;max-width:1300px}.sweep table{border-collapse:collapse}
.sweep td,.sweep th{border:1px solid #ccc;padding:3px 6px;text-align:right}.sweep th{text-align:left}
.sweep .scroll{overflow-x:auto;max-width:100%}.sweep svg{max-width:100%;height:auto}.sweep .note{color:#a60}
body.stress{font-family:sans-serif;background:#111;color:#ddd;margin:1.5em}
.stress table{border-collapse:collapse} .stress td,.stress th{border:1px solid #333;padding:4px 6px;vertical-align:top}
.stress th{background:#222} .stress .ok{color:#6d6} .stress .bad{color:#f55;font-weight:bold} .stress small{color:#999}
.stress img{image-rendering:pixelated}
)";

std::string_view body_classes(PageKind kind) {
    switch (kind) {
        case PageKind::report: return "dark report";
        case PageKind::diff: return "dark diff";
        case PageKind::tune: return "tune";
        case PageKind::sweep: return "sweep";
        case PageKind::stress: return "stress";
    }
    return "";
}

}  // namespace

std::string_view page_style() {
    return kPageStyle;
}

std::string html_page_head(std::string_view title, PageKind kind) {
    std::string h = R"(<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>)";
    h += title;
    h += "</title>\n<style>";
    h += kPageStyle;
    h += "</style></head><body class=\"";
    h += body_classes(kind);
    h += "\">\n";
    return h;
}

}  // namespace penumbra::report
