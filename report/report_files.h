// The files of validate with images in them: errors.exr, the PNG maps and report.html (which
// embeds them). Apart from report.h, so that what only scores (the pipeline's validate(), the
// tests of the verdict) does not link OpenImageIO (image_io/).
#pragma once

#include "common/frames.h"
#include "common/output_files.h"
#include "metrics/classification.h"
#include "report/report.h"

namespace penumbra::report {

// errors.exr, light<i>.classes.png, light<i>.error.png, light<i>.compare.png, report.json and
// report.html (images embedded), added to the transaction. The page's numbers come from `score`
// and in.gate; `report` is written as report.json and gives the page its timing.
void write_report(OutputTransaction& out, const ReportInputs& in, const OracleFrame& oracle, const RasterFrame& raster,
                  const metrics::FrameScore& score, const nlohmann::json& report);

// One light's class map with its legend (the light<i>.classes.png of write_report) as `name`.
void write_class_map(OutputTransaction& out, const std::string& name, const OracleFrame& oracle,
                     const metrics::FrameScore& score, std::size_t light);

}  // namespace penumbra::report
