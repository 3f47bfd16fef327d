// CI gates (docs/design.md, "Gate"): thresholds on a light's report.json numbers. A gate that
// fails makes validate exit 1; each failure is one line a person reads in a CI log.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace penumbra::metrics {

struct GateCheck {
    std::string metric;                // dotted path into a light's report object, e.g. "rates.acne"
    std::optional<double> max;         // passes when value <= max
    std::optional<double> min;         // passes when value >= min
    std::optional<std::size_t> light;  // one light, or every light when empty
};

struct Gate {
    std::vector<GateCheck> checks;
};

// Validates the gate object; errors (InputError) name `label` and the JSON path: unknown keys,
// a metric that is not a number of the report, a check without max or min, a light that does
// not exist.
Gate parse_gate(const nlohmann::json& gate, const std::string& label, std::size_t light_count);

struct CheckOutcome {
    std::size_t light = 0;
    std::string metric;
    std::string bound;  // "max" or "min"
    double value = 0, limit = 0;
    bool passed = true;
    std::string name() const;     // "rates.acne <= 0.001"
    std::string failure() const;  // "light 0: rates.acne = 0.0123 > 0.001"
};

struct GateResult {
    bool passed = true;
    std::vector<CheckOutcome> outcomes;  // per check, per light, per bound: in gate order
};

// `lights` holds each light's report object (to_json(LightScore) or report.json's entries).
GateResult evaluate_gate(const Gate& gate, const std::vector<nlohmann::json>& lights);

// Every number a check may name, as dotted paths (for error messages and docs).
std::vector<std::string> gate_metrics();

}  // namespace penumbra::metrics
