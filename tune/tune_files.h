// tune's files (docs/outputs.md, "tune"): technique.json, tune.json, pareto.csv, pareto.svg,
// pareto.png and report.html with before/after class maps. Apart from tune_report.h so the
// search does not link OpenImageIO.
#pragma once

#include "common/output_files.h"
#include "tune/tune_report.h"

namespace penumbra::tune {

void write_tune_outputs(OutputTransaction& out, const TuneReport& r);

}  // namespace penumbra::tune
