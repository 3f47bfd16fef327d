// The validate pipeline, the one place that composes the modules: the oracle (from the cache
// when an earlier run traced the same thing), the raster path, the metrics and the gate. The
// CLI's validate, tune, sweep and the tests call it; report files are written separately
// (validate_files.h: write_validate_outputs), so a loop can score without writing anything.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/frames.h"
#include "common/output_files.h"
#include "common/progress.h"
#include "common/scenario.h"
#include "metrics/classification.h"
#include "metrics/gate.h"
#include "oracle/oracle.h"
#include "pipeline/facing.h"
#include "raster/raster.h"
#include "raster/raster_output.h"
#include "raster/technique.h"
#include "report/report.h"

namespace penumbra {

struct ValidateOptions {
    OracleSettings oracle;                         // threads, progress, area-light sampling
    bool use_cache = true;                         // false: trace and keep nothing (--no-cache)
    std::filesystem::path cache_dir;               // empty: OracleCache::default_dir()
    std::optional<std::uint64_t> cache_max_bytes;  // the cache's size cap (0: none); empty: default_max_bytes()
    bool keep_oracle_frame = false;                // trace (never from the cache) and keep P, N, depth (--frames)
    double tolerance = 1.0 / 255.0;                // tau (docs/metrics.md)
    double visible_threshold = 0.1;                // |error| from which a wrong pixel is also visible (docs/metrics.md)
    std::string device;                            // Vulkan device when no session is given
    raster::RenderOptions render;                  // lookups on for reports; V only for objectives
    ProgressLine* progress = nullptr;              // the phases on a terminal (common/progress.h), if any
};

// The oracle's frame for a scenario, with the oracle.json of the run that produced it.
struct OracleRun {
    OracleFrame frame;
    nlohmann::json info;
    bool cached = false;
    double seconds = 0;
    std::optional<std::string> warning;  // the cache could not store it (the run is unaffected)
};

struct ValidateResult {
    raster::Technique technique;
    std::vector<metrics::ScoringOptions> scoring;  // per light
    std::shared_ptr<const OracleRun> oracle;       // shared with the caller that held it: never copied
    raster::RasterResult raster;
    raster::RasterTimings raster_timings;
    double raster_s = 0, metrics_s = 0;
    metrics::FrameScore score;
    std::optional<metrics::GateResult> gate;  // empty when the gate has no checks
    nlohmann::json raster_info;               // raster.json (compare: {"engine": engine})
    nlohmann::json engine;                    // compare only: the engine frame (reported instead of the technique)
    nlohmann::json timing;                    // report.json's "timing"
    nlohmann::json report;                    // report.json
    std::vector<std::string> warnings;  // from the run: the cache's, the raster path's (the scene's are on Scenario)
    FacingReport facing;                // what the camera saw from behind (make_report)
    metrics::RunFacts facts;            // what the hints name first (make_report)
    bool passed() const { return !gate || gate->passed; }
};

// How each light is judged under a technique (docs/metrics.md): tau, the filter's reach, the
// depth format's quantum, soft scoring for area lights. The one derivation of these options.
std::vector<metrics::ScoringOptions> scoring_options(const Scenario& scenario, const raster::Technique& technique,
                                                     double tolerance, double visible_threshold = 0.1);

// The warning every command gives for a scenario without lights (nothing is scored), or none.
// Nothing here prints: warnings are returned, and the caller shows them.
std::optional<std::string> no_lights_warning(const Scenario& scenario);

// The oracle's frame from the cache or traced (and stored in the cache).
OracleRun oracle_for(const Scenario& scenario, const ValidateOptions& options);

// Oracle + raster + metrics + gate. `session`, when given, draws the technique (it must be a
// session of this scenario); otherwise a context on options.device and a cold session are made.
// `oracle`, when given, is used instead of oracle_for (tune and sweep hold it: a loop shares one
// frame rather than copying it per evaluation).
ValidateResult validate(const Scenario& scenario, const raster::Technique& technique, const metrics::Gate& gate,
                        const ValidateOptions& options, raster::RasterSession* session = nullptr,
                        std::shared_ptr<const OracleRun> oracle = nullptr);

// r.report from r's score, gate and timings (report.json's object, with each cascaded light's
// `cascades` and `sdsm`): validate calls it, and a camera path again once its gate and temporal
// numbers are known.
void make_report(const Scenario& scenario, ValidateResult& r);

// What the report files are made from; pointers into `scenario` and `r`, valid while both are.
// `oracle_info` is the oracle.json the report names.
report::ReportInputs report_inputs(const Scenario& scenario, const ValidateResult& r,
                                   const nlohmann::json& oracle_info);

// The gate's checks as JUnit XML: one testcase per light x check.
std::string validate_junit(const Scenario& scenario, const ValidateResult& result);

}  // namespace penumbra
