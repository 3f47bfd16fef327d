// The head of every HTML page penumbra writes (validate's and compare's report.html, diff.html,
// tune's, sweep's and stress's report.html): one stylesheet for all of them, so a rule is written
// once. Each page is self-contained (no file beside it), so the stylesheet is embedded in each.
#pragma once

#include <string>
#include <string_view>

namespace penumbra::report {

// Which page: its rules of the stylesheet apply under the <body> class of that name.
enum class PageKind {
    report,  // validate's and compare's report.html (dark)
    diff,    // diff.html (dark, as the report)
    tune,    // tune's report.html
    sweep,   // sweep's report.html
    stress,  // stress's report.html
};

// The one stylesheet (CSS, no <style> tag). A page's rules are scoped by its body's classes
// (html_page_head), so that each page looks as it did when every writer carried its own sheet:
// every selector of a page gained the same one class, so which of its rules wins is unchanged.
std::string_view page_style();

// "<!DOCTYPE html>…<title>TITLE</title><style>…</style></head><body class=…>\n": the start of a
// page of kind `kind`. `title` is plain text without markup characters (a literal of the writer).
std::string html_page_head(std::string_view title, PageKind kind);

}  // namespace penumbra::report
