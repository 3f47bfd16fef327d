#include "metrics/gate.h"

#include <fmt/format.h>

#include <cmath>

#include "common/errors.h"
#include "common/json_reader.h"

namespace penumbra::metrics {

namespace {

// Whether a check of metric `m` applies to `light` at all (evaluate_gate skips it otherwise).
bool applies(const Metric& m, const Light& light) {
    return m.scope != MetricScope::area_lights || is_soft_light(light);
}

// Whether outcome a is worse than b (the same check on another frame): failing beats passing; then
// the value further past (or nearer to) the limit; a value that is not measured is the worst.
bool worse(const CheckOutcome& a, const CheckOutcome& b) {
    if (a.passed != b.passed) return !a.passed;
    if (!std::isfinite(a.value) || !std::isfinite(b.value)) return !std::isfinite(a.value) && std::isfinite(b.value);
    return a.bound == "max" ? a.value > b.value : a.value < b.value;
}

}  // namespace

Gate parse_gate(const nlohmann::json& gate, const std::string& label, std::span<const Light> lights, GateOrigin origin,
                bool camera_path) {
    Gate g;
    JsonObject top(gate, label, "");
    if (origin == GateOrigin::scenario && gate.empty()) return g;  // no "gate" in the scenario
    if (!top.has("checks")) {
        top.finish();
        throw InputError(fmt::format("{}: the gate checks nothing: it has no \"checks\"", label));
    }
    const nlohmann::json& checks = top.get("checks");
    if (!checks.is_array()) top.fail("checks", "expected an array of checks");
    top.finish();
    std::size_t outcomes = 0;
    for (std::size_t k = 0; k < checks.size(); ++k) {
        JsonObject c(checks[k], label, fmt::format("checks[{}]", k));
        GateCheck check;
        const std::string metric = c.string("metric");
        check.metric = find_metric(metric);
        if (!check.metric)
            c.fail("metric",
                   fmt::format("unknown metric \"{}\"; a light's metrics are:\n{}", metric, metric_table_text()));
        if (c.has("max")) check.max = c.number("max");
        if (c.has("min")) check.min = c.number("min");
        if (!check.max && !check.min) c.fail_here("a check needs \"max\" or \"min\"");
        if (check.metric->scope == MetricScope::camera_paths && !camera_path)
            c.fail("metric", fmt::format("{} is measured over a camera path only, and the scenario has no "
                                         "\"camera_path\"",
                                         metric));
        if (c.has("light")) {
            if (lights.empty()) c.fail("light", "the scenario has no lights");
            check.light = static_cast<std::size_t>(c.integer("light", 0, static_cast<long long>(lights.size()) - 1));
            const Light& light = lights[*check.light];
            if (!applies(*check.metric, light))
                c.fail("light", fmt::format("{} applies to {} only, and light {} is a {} light", metric,
                                            to_string(check.metric->scope), *check.light, to_string(light.type)));
        }
        c.finish();
        for (std::size_t li = 0; li < lights.size(); ++li)
            outcomes += (!check.light || *check.light == li) && applies(*check.metric, lights[li]);
        g.checks.push_back(check);
    }
    if (outcomes == 0) {
        const char* why = g.checks.empty() ? "its \"checks\" are empty"
                          : lights.empty() ? "the scenario has no lights"
                                           : "its checks apply to area lights only, and the scenario has none";
        throw InputError(fmt::format("{}: the gate checks nothing: {}", label, why));
    }
    return g;
}

std::string CheckOutcome::name() const {
    return fmt::format("{} {} {}", metric, bound == "max" ? "<=" : ">=", limit);
}

std::string CheckOutcome::failure() const {
    const std::string where = frame ? fmt::format(" in frame {}", *frame) : "";
    if (!std::isfinite(value))
        return fmt::format("light {}: {} is not measured for this light (needs {} {}){}", light, metric,
                           bound == "max" ? "<=" : ">=", limit, where);
    return fmt::format("light {}: {} = {} {} {}{}", light, metric, value, bound == "max" ? ">" : "<", limit, where);
}

GateResult evaluate_gate(const Gate& gate, std::span<const LightScore> lights) {
    GateResult r;
    for (const GateCheck& check : gate.checks) {
        for (std::size_t li = 0; li < lights.size(); ++li) {
            if (check.light && *check.light != li) continue;
            // soft.* numbers exist for area lights only; elsewhere the check does not apply.
            if (check.metric->scope == MetricScope::area_lights && !lights[li].soft) continue;
            // temporal.* numbers exist over a camera path only: a single frame skips them.
            if (check.metric->scope == MetricScope::camera_paths && !lights[li].temporal) continue;
            const double value = value_of(*check.metric, lights[li]).value_or(std::nan(""));
            auto add = [&](const char* bound, double limit, bool ok) {
                CheckOutcome o{li,    std::string(check.metric->path), bound,       value,
                               limit, ok && std::isfinite(value),      std::nullopt};
                r.passed = r.passed && o.passed;
                r.outcomes.push_back(std::move(o));
            };
            if (check.max) add("max", *check.max, value <= *check.max);
            if (check.min) add("min", *check.min, value >= *check.min);
        }
    }
    return r;
}

void fold_worst_frame(GateResult& worst, const GateResult& frame_result, int frame) {
    const bool first = worst.outcomes.empty();
    for (std::size_t k = 0; k < frame_result.outcomes.size(); ++k) {
        CheckOutcome o = frame_result.outcomes[k];
        o.frame = frame;
        if (first)
            worst.outcomes.push_back(std::move(o));
        else if (k < worst.outcomes.size() && worse(o, worst.outcomes[k]))
            worst.outcomes[k] = std::move(o);
    }
    worst.passed = worst.passed && frame_result.passed;
}

GateResult camera_path_gate(const GateResult& last, const GateResult& worst) {
    GateResult r;
    std::size_t next = 0;  // worst's outcomes are last's, in order, less the temporal ones
    for (const CheckOutcome& o : last.outcomes) {
        const Metric* m = find_metric(o.metric);
        const bool temporal = m && m->scope == MetricScope::camera_paths;
        r.outcomes.push_back(!temporal && next < worst.outcomes.size() ? worst.outcomes[next++] : o);
        r.passed = r.passed && r.outcomes.back().passed;
    }
    return r;
}

}  // namespace penumbra::metrics
