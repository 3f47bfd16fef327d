// What validate leaves behind for people and CI (docs/design.md, "Output directory"):
// report.json, errors.exr, the PNG maps, report.html and the JUnit file. This header has the
// JSON and XML; report_files.h writes the image files and the page.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "common/frames.h"
#include "common/output_files.h"
#include "common/scenario.h"
#include "metrics/classification.h"
#include "metrics/gate.h"
#include "metrics/metric_table.h"

namespace penumbra::report {

struct ReportInputs {
    std::string version;       // penumbra's
    std::string command_line;  // the run's, shown at the top of report.html; empty: not shown
    const Scenario* scenario = nullptr;
    std::filesystem::path scenario_file;
    nlohmann::json technique;                      // resolved, every key
    nlohmann::json raster;                         // raster.json: device, gpu_ms, per-light projections
    nlohmann::json oracle;                         // oracle.json of the oracle run the verdict used
    std::vector<metrics::ScoringOptions> scoring;  // per light
    nlohmann::json timing;                         // report.json's "timing"
    const metrics::GateResult* gate = nullptr;     // null: no gate given
    nlohmann::json fingerprint;                    // report.json's "fingerprint" (scene, camera, lights); null: none
    // validate --class-map-tint cascade: a cascaded light's class map tinted by the cascade each
    // pixel's lookup used (the raster lookups' layer), with the tints in its legend.
    bool tint_cascades = false;
    bool errors_exr = true;  // write_report writes errors.exr (validate: only with --errors or --frames)
    metrics::RunFacts facts;  // what the readings' hints name first (facing, culling)
};

// report.json (docs/design.md's keys, and more): each light's object is metrics::to_json, built from
// the metrics table.
nlohmann::json report_json(const ReportInputs& in, const metrics::FrameScore& score);

// JUnit XML of in.gate's outcomes: one testsuite (named after in.scenario_file), one testcase per
// light x check; no testcase without a gate.
std::string junit_xml(const ReportInputs& in);

// Escapes text for HTML and XML content and attribute values alike.
std::string escape_markup(std::string_view s);

}  // namespace penumbra::report
