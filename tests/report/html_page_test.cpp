// The one stylesheet of every HTML page (report/html_page.h): each rule belongs to one page kind
// (or the dark pages' shared base), so no page picks up another's look.
#include "report/html_page.h"

#include <gtest/gtest.h>

#include <regex>
#include <string>

namespace penumbra::report {
namespace {

TEST(HtmlPage, EveryRuleIsScopedToAPageKind) {
    const std::string css(page_style());
    const std::regex scoped(R"(^(body\.(dark|tune|sweep|stress)|\.(dark|report|diff|tune|sweep|stress) \S.*)$)");
    std::size_t rules = 0;
    for (std::size_t at = 0;;) {
        const std::size_t open = css.find('{', at);
        if (open == std::string::npos) break;
        const std::size_t close = css.find('}', open);
        ASSERT_NE(close, std::string::npos) << "a rule without its end at " << open;
        std::string selectors = css.substr(at, open - at);
        for (std::size_t from = 0; from <= selectors.size();) {
            std::size_t comma = selectors.find(',', from);
            if (comma == std::string::npos) comma = selectors.size();
            std::string s = selectors.substr(from, comma - from);
            s.erase(0, s.find_first_not_of(" \n"));
            s.erase(s.find_last_not_of(" \n") + 1);
            EXPECT_TRUE(std::regex_match(s, scoped)) << "unscoped selector: " << s;
            from = comma + 1;
        }
        ++rules;
        at = close + 1;
    }
    EXPECT_GT(rules, 40u);
}

TEST(HtmlPage, HeadCarriesTheStylesheetAndTheBodyClasses) {
    const std::string head = html_page_head("penumbra tune", PageKind::tune);
    EXPECT_EQ(
        head.rfind("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>penumbra tune</title>", 0),
        0u);
    EXPECT_NE(head.find(std::string("<style>") + std::string(page_style()) + "</style></head>"), std::string::npos);
    EXPECT_TRUE(head.ends_with("</head><body class=\"tune\">\n"));
    EXPECT_TRUE(html_page_head("penumbra report", PageKind::report).ends_with("<body class=\"dark report\">\n"));
    EXPECT_TRUE(html_page_head("penumbra diff", PageKind::diff).ends_with("<body class=\"dark diff\">\n"));
}

}  // namespace
}  // namespace penumbra::report
