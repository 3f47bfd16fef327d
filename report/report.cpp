#include "report/report.h"

#include <fmt/format.h>

#include <cmath>

namespace penumbra::report {

std::string escape_markup(std::string_view s) {
    std::string out;
    for (char c : s) {
        switch (c) {
            case '&': out += "&amp;"; break;
            case '<': out += "&lt;"; break;
            case '>': out += "&gt;"; break;
            case '"': out += "&quot;"; break;
            case '\'': out += "&#39;"; break;
            default: out += c;
        }
    }
    return out;
}

nlohmann::json report_json(const ReportInputs& in, const metrics::FrameScore& score) {
    const Scenario& sc = *in.scenario;
    nlohmann::json lights = nlohmann::json::array();
    nlohmann::json scoring = nlohmann::json::array();
    for (std::size_t li = 0; li < score.lights.size(); ++li) {
        nlohmann::json l = {{"index", li}, {"type", to_string(sc.lights[li].type)}};
        if (const double d = sc.lights[li].angular_diameter_rad; d > 0) l["angular_diameter_deg"] = d * 180 / M_PI;
        l.update(metrics::to_json(score.lights[li]));
        lights.push_back(std::move(l));
        const auto& o = in.scoring.size() == 1 ? in.scoring[0] : in.scoring.at(li);
        nlohmann::json so = {{"light", li},
                             {"tolerance", o.tolerance},
                             {"visible_threshold", o.visible_threshold},
                             {"filter_reach_texels", o.filter_reach_texels},
                             {"depth_quantum", o.depth_quantum},
                             {"pixels_per_degree", o.pixels_per_degree}};
        if (o.texel_footprint_m) so["texel_footprint_m"] = *o.texel_footprint_m;
        if (o.bias_reach_m) so["bias_reach_m"] = *o.bias_reach_m;
        scoring.push_back(std::move(so));
    }
    nlohmann::json r = {{"version", in.version},
                        {"scenario", in.scenario_file.string()},
                        {"image", {{"width", sc.width}, {"height", sc.height}}},
                        {"technique", in.technique},
                        {"lights", lights},
                        {"scoring", scoring},
                        {"timing", in.timing}};
    if (!in.command_line.empty()) r["command_line"] = in.command_line;
    if (in.raster.contains("device")) r["device"] = in.raster["device"];
    if (!in.fingerprint.is_null()) r["fingerprint"] = in.fingerprint;
    if (in.gate) {
        nlohmann::json checks = nlohmann::json::array();
        for (const auto& o : in.gate->outcomes) {
            checks.push_back({{"name", o.name()},
                              {"light", o.light},
                              {"metric", o.metric},
                              {"bound", o.bound},
                              {"value", std::isfinite(o.value) ? nlohmann::json(o.value) : nlohmann::json(nullptr)},
                              {"limit", o.limit},
                              {"passed", o.passed},
                              {"message", o.passed ? "" : o.failure()}});
            if (o.frame) checks.back()["frame"] = *o.frame;  // over a camera path: the worst frame
        }
        r["gate"] = {{"passed", in.gate->passed}, {"checks", checks}};
    }
    return r;
}

std::string junit_xml(const ReportInputs& in) {
    const std::string suite =
        "penumbra." + (in.scenario_file.empty() ? std::string("scenario") : in.scenario_file.stem().string());
    std::string cases;
    int tests = 0, failures = 0;
    if (in.gate)
        for (const auto& c : in.gate->outcomes) {
            ++tests;
            cases += fmt::format("    <testcase classname=\"{}.light{}\" name=\"{}\" time=\"0\">\n",
                                 escape_markup(suite), c.light, escape_markup(c.name()));
            if (!c.passed) {
                ++failures;
                const std::string msg = c.failure();
                cases += fmt::format("      <failure message=\"{}\" type=\"gate\">{}</failure>\n", escape_markup(msg),
                                     escape_markup(msg));
            }
            cases += "    </testcase>\n";
        }
    return fmt::format(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites name=\"penumbra\" tests=\"{0}\" failures=\"{1}\" "
        "errors=\"0\">\n  <testsuite name=\"{2}\" tests=\"{0}\" failures=\"{1}\" errors=\"0\" skipped=\"0\" "
        "time=\"{3}\">\n{4}  </testsuite>\n</testsuites>\n",
        tests, failures, escape_markup(suite), in.timing.value("metrics_s", 0.0), cases);
}

}  // namespace penumbra::report
