// The files of validate with images in them: errors.exr, the PNG maps and report.html (which
// embeds them). Apart from report.h, so that what only scores (the pipeline's validate(), the
// tests of the verdict) does not link the image libraries (image_io/).
#pragma once

#include "common/frames.h"
#include "common/output_files.h"
#include "metrics/classification.h"
#include "report/report.h"

namespace penumbra::report {

// errors.exr (unless in.errors_exr is off), light<i>.classes.png, light<i>.error.png, light<i>.compare.png, report.json
// and report.html (images embedded), added to the transaction. The page's numbers come from `score` and in.gate;
// `report` is written as report.json and gives the page its timing.
void write_report(OutputTransaction& out, const ReportInputs& in, const OracleFrame& oracle, const RasterFrame& raster,
                  const metrics::FrameScore& score, const nlohmann::json& report);

// A page's check of its own images: a broken embedded image is a console error and the body's
// data-images attribute says "ok" or "broken", so a headless browser test notices it.
const char* image_check_script();

// The class map of light `li` with its legend (each class's rate), as a PNG named `name`. With
// `cascade_layer` (a cascaded light's lookups' layer per pixel) each surface pixel is tinted by
// its cascade and the legend names the tints. With `light` (the scenario's light li) and
// `scenario` (the frame's), a spot light's outside is drawn and named apart from back faces.
void write_class_map(OutputTransaction& out, const std::string& name, const OracleFrame& oracle, std::size_t li,
                     const metrics::LightErrorImage& e, const metrics::LightScore& l, const Light* light = nullptr,
                     const Scenario* scenario = nullptr, const std::vector<std::uint32_t>* cascade_layer = nullptr);

}  // namespace penumbra::report
