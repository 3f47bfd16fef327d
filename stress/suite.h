// The stress suite (docs/stress.md): for every case, (1) the oracle's verdict on the case against
// its canonical version outside uncertain pixels, where any difference is an oracle failure, and
// (2) the technique's verdict on the case (and on the canonical version where that shows where
// its rates explode). Built on penumbra::validate with one Vulkan context for the whole suite.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/frames.h"
#include "metrics/gate.h"
#include "pipeline/validate.h"
#include "raster/technique.h"
#include "stress/cases.h"

namespace penumbra::stress {

// The oracle's two answers for one case, compared pixel by pixel and light by light.
struct OracleInvariant {
    std::size_t compared = 0;                  // (pixel, light) pairs compared: same triangle seen, U in neither
    std::size_t differing = 0;                 // of those, V or lightable differs: an oracle failure
    std::size_t uncertain = 0;                 // (pixel, light) pairs not compared: U in either version
    std::size_t coverage_differs = 0;          // pixels where the two versions see different triangles (silhouettes)
    std::vector<std::size_t> first_differing;  // up to 8 pixel indices, for the message
    bool holds() const { return differing == 0; }
};

// Compares two oracle frames of the same image (same size and lights); std::invalid_argument
// when they are not.
OracleInvariant compare_oracles(const OracleFrame& a, const OracleFrame& b);

// The suite's gate (docs/stress.md, "Gate"): the validate gate's checks applied to every light
// of every case, and the oracle invariant on every case (on unless "oracle_invariant": false).
struct StressGate {
    bool oracle_invariant = true;
    nlohmann::json checks = nlohmann::json::object();  // the metrics gate object, parsed per case
    bool given = false;                                // from --gate
};

// Validates the gate object (InputError naming `label` and the JSON path) against every case.
StressGate parse_stress_gate(const nlohmann::json& value, const std::string& label,
                             const std::vector<StressCase>& cases);

struct SuiteOptions {
    ValidateOptions validate;  // oracle settings, tolerance, device (use_cache is not used: nothing is cached)
    // Called before each case (done = cases finished so far) and once at the end (done = total).
    std::function<void(std::size_t done, std::size_t total, const std::string& name)> progress;
};

struct CaseResult {
    std::string name;
    OracleInvariant invariant;
    std::shared_ptr<const OracleRun> oracle, reference_oracle;
    ValidateResult judged;                    // the technique on the case
    std::optional<ValidateResult> reference;  // ... and on its canonical version (judge_reference)
    std::optional<metrics::GateResult> gate;  // the stress gate's checks on the case
    double seconds = 0;
    bool passed(const StressGate& g) const;
};

struct SuiteResult {
    std::vector<CaseResult> cases;
    double seconds = 0;
    std::string device;
    bool passed = true;  // every case's oracle invariant (when gated) and gate checks
    // Whether a gate judged the technique on some case; else its verdicts are only reported.
    bool technique_gated() const;
};

// Refuses, before any work, a technique some case cannot be drawn with (InputError).
void check_technique_cases(const raster::Technique& technique, const std::vector<StressCase>& cases,
                           const std::string& label);

// Runs every case; throws EnvironmentError for Embree and Vulkan failures.
SuiteResult run_suite(const std::vector<StressCase>& cases, const raster::Technique& technique, const StressGate& gate,
                      const SuiteOptions& options);

// stress.json (docs/stress.md, "Output").
nlohmann::json stress_json(const std::vector<StressCase>& cases, const SuiteResult& result,
                           const raster::Technique& technique, const StressGate& gate, const CaseOptions& case_options);

// The suite as JUnit XML: per case, one testcase for the oracle invariant and one per light x
// gate check.
std::string stress_junit(const std::vector<StressCase>& cases, const SuiteResult& result, const StressGate& gate);

// Lines a person reads when the suite fails: `case far_1e7: oracle invariant: 3 pixels differ
// (first at 12,40)` and `case far_1e7: light 0: rates.acne = 0.2 > 0.01`.
std::vector<std::string> failure_lines(const std::vector<StressCase>& cases, const SuiteResult& result,
                                       const StressGate& gate);

}  // namespace penumbra::stress
