#include "metrics/gate.h"

#include <fmt/format.h>

#include <cmath>

#include "common/json_reader.h"
#include "metrics/classification.h"

namespace penumbra::metrics {

namespace {

void collect_paths(const nlohmann::json& j, const std::string& prefix, std::vector<std::string>& out) {
    for (const auto& [key, value] : j.items()) {
        std::string path = prefix.empty() ? key : prefix + "." + key;
        if (value.is_object()) {
            collect_paths(value, path, out);
        } else if (value.is_number()) {
            out.push_back(path);
        }
    }
}

const nlohmann::json* find_path(const nlohmann::json& j, const std::string& dotted) {
    const nlohmann::json* at = &j;
    std::size_t start = 0;
    while (start <= dotted.size()) {
        std::size_t dot = dotted.find('.', start);
        std::string key = dotted.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
        if (!at->is_object() || !at->contains(key)) return nullptr;
        at = &(*at)[key];
        if (dot == std::string::npos) break;
        start = dot + 1;
    }
    return at;
}

// Every number a light's object can hold: an area light's carries "soft" as well.
nlohmann::json template_light() {
    LightScore s;
    s.soft.emplace();
    return to_json(s);
}

}  // namespace

std::vector<std::string> gate_metrics() {
    std::vector<std::string> paths;
    collect_paths(template_light(), "", paths);
    return paths;
}

Gate parse_gate(const nlohmann::json& gate, const std::string& label, std::size_t light_count) {
    Gate g;
    JsonObject top(gate, label, "");
    if (!top.has("checks")) {
        top.finish();
        return g;
    }
    const nlohmann::json& checks = top.get("checks");
    if (!checks.is_array()) top.fail("checks", "expected an array of checks");
    top.finish();
    const nlohmann::json every_number = template_light();
    for (std::size_t k = 0; k < checks.size(); ++k) {
        JsonObject c(checks[k], label, fmt::format("checks[{}]", k));
        GateCheck check;
        check.metric = c.string("metric");
        const nlohmann::json* known = find_path(every_number, check.metric);
        if (!known || !known->is_number()) {
            std::string list;
            for (const auto& p : gate_metrics()) list += (list.empty() ? "" : ", ") + p;
            c.fail("metric", fmt::format("unknown metric \"{}\" (a light's numbers: {})", check.metric, list));
        }
        if (c.has("max")) check.max = c.number("max");
        if (c.has("min")) check.min = c.number("min");
        if (!check.max && !check.min) c.fail_here("a check needs \"max\" or \"min\"");
        if (c.has("light")) {
            if (light_count == 0) c.fail("light", "the scenario has no lights");
            check.light = static_cast<std::size_t>(c.integer("light", 0, static_cast<long long>(light_count) - 1));
        }
        c.finish();
        g.checks.push_back(std::move(check));
    }
    return g;
}

std::string CheckOutcome::name() const {
    return fmt::format("{} {} {}", metric, bound == "max" ? "<=" : ">=", limit);
}

std::string CheckOutcome::failure() const {
    return fmt::format("light {}: {} = {} {} {}", light, metric, value, bound == "max" ? ">" : "<", limit);
}

GateResult evaluate_gate(const Gate& gate, const std::vector<nlohmann::json>& lights) {
    GateResult r;
    for (const GateCheck& check : gate.checks) {
        for (std::size_t li = 0; li < lights.size(); ++li) {
            if (check.light && *check.light != li) continue;
            const nlohmann::json* v = find_path(lights[li], check.metric);
            // "soft.*" numbers exist for area lights only; elsewhere the check does not apply.
            if (!v && check.metric.starts_with("soft.") && !lights[li].contains("soft")) continue;
            const double value = v && v->is_number() ? v->get<double>() : std::nan("");
            auto add = [&](const char* bound, double limit, bool ok) {
                CheckOutcome o{li, check.metric, bound, value, limit, ok && std::isfinite(value)};
                r.passed = r.passed && o.passed;
                r.outcomes.push_back(std::move(o));
            };
            if (check.max) add("max", *check.max, value <= *check.max);
            if (check.min) add("min", *check.min, value >= *check.min);
        }
    }
    return r;
}

}  // namespace penumbra::metrics
