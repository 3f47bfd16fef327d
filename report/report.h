// What validate leaves behind for people and CI (docs/design.md, "Output directory"):
// report.json, errors.exr, the PNG maps, report.html and the JUnit file.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/frames.h"
#include "common/output_files.h"
#include "common/scenario.h"
#include "metrics/classification.h"
#include "metrics/gate.h"
#include "metrics/metric_table.h"

namespace penumbra::report {

struct ReportInputs {
    std::string version;  // penumbra's
    const Scenario* scenario = nullptr;
    std::filesystem::path scenario_file;
    nlohmann::json technique;                      // resolved, every key
    nlohmann::json raster;                         // raster.json: device, gpu_ms, per-light projections
    nlohmann::json oracle;                         // oracle.json of the oracle run the verdict used
    std::vector<metrics::ScoringOptions> scoring;  // per light
    nlohmann::json timing;                         // report.json's "timing"
    const metrics::GateResult* gate = nullptr;     // null: no gate given
};

// report.json (docs/design.md's keys, and more): each light's object is metrics::to_json, built from
// the metrics table.
nlohmann::json report_json(const ReportInputs& in, const metrics::FrameScore& score);

// errors.exr, light<i>.classes.png, light<i>.error.png, light<i>.compare.png, report.json and
// report.html (images embedded), added to the transaction. The page's numbers come from `score`
// and in.gate; `report` is written as report.json and gives the page its timing.
void write_report(OutputTransaction& out, const ReportInputs& in, const OracleFrame& oracle, const RasterFrame& raster,
                  const metrics::FrameScore& score, const nlohmann::json& report);

// JUnit XML of in.gate's outcomes: one testsuite (named after in.scenario_file), one testcase per
// light x check; no testcase without a gate.
std::string junit_xml(const ReportInputs& in);

}  // namespace penumbra::report
