// CI gates (docs/design.md, "Gate"): thresholds on a light's metrics (metric_table.h). A gate that
// fails makes validate exit 1; each failure is one line a person reads in a CI log.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "common/scene.h"
#include "metrics/metric_table.h"

namespace penumbra::metrics {

struct GateCheck {
    const Metric* metric = nullptr;    // a row of metric_table()
    std::optional<double> max;         // passes when value <= max
    std::optional<double> min;         // passes when value >= min
    std::optional<std::size_t> light;  // one light, or every light when empty
};

struct Gate {
    std::vector<GateCheck> checks;
};

// Where the gate came from. A scenario without "gate" reads as an empty object, which is no
// gate; a --gate file, or a scenario gate with any key, is given explicitly.
enum class GateOrigin { scenario, file };

// Validates the gate object against the metrics table and the scenario's lights; errors
// (InputError) name `label` and the JSON path: unknown keys, a metric not in the table (the
// message lists the table), a check without max or min, a light that does not exist, a check
// naming a light its metric does not apply to (soft.* and a punctual light). A gate given
// explicitly must check something: one that would evaluate no (light x check) outcome (no
// checks, no lights, or soft.* checks only and no area light) is an InputError naming `label`.
// temporal.* metrics need `camera_path` (the scenario has one): without it they are an InputError.
Gate parse_gate(const nlohmann::json& gate, const std::string& label, std::span<const Light> lights, GateOrigin origin,
                bool camera_path = false);

struct CheckOutcome {
    std::size_t light = 0;
    std::string metric;
    std::string bound;  // "max" or "min"
    double value = 0;   // NaN where the light does not measure the metric (acne_depth with V only)
    double limit = 0;
    bool passed = true;
    std::optional<int> frame;     // over a camera path: the frame the value is from (the worst)
    std::string name() const;     // "rates.acne <= 0.001"
    std::string failure() const;  // "light 0: rates.acne = 0.0123 > 0.001" (+ " in frame 7")
};

struct GateResult {
    bool passed = true;
    std::vector<CheckOutcome> outcomes;  // per check, per light, per bound: in gate order
};

// Evaluates every check on every light it names, reading the values from the table. A soft.*
// check skips punctual lights, a temporal.* check a light without a camera path's numbers; a
// metric a light does not measure fails the check.
GateResult evaluate_gate(const Gate& gate, std::span<const LightScore> lights);

// A camera path is gated on every frame, not on the last one alone (docs/metrics.md, "Gates"):
// `worst` (empty at first) takes frame `frame`'s result (evaluated without temporal numbers), and
// keeps per outcome the frame whose value fails, or comes nearest to failing.
void fold_worst_frame(GateResult& worst, const GateResult& frame_result, int frame);
// The path's gate: `last` evaluated on the last frame with the temporal numbers, each of its other
// outcomes replaced by `worst`'s (the same checks in the same order, less the temporal ones).
GateResult camera_path_gate(const GateResult& last, const GateResult& worst);

}  // namespace penumbra::metrics
