// The files of `penumbra stress` (docs/stress.md, "Output"): stress.json, report.html (a row per
// case with its class maps embedded) and the class maps as PNG. Apart from suite.h so that
// running the suite does not link OpenImageIO.
#pragma once

#include <vector>

#include "common/output_files.h"
#include "stress/suite.h"

namespace penumbra::stress {

// stress.json, report.html and <case>.light<i>.classes.png, added to the transaction.
void write_stress_outputs(OutputTransaction& out, const std::vector<StressCase>& cases, const SuiteResult& result,
                          const nlohmann::json& stress);

}  // namespace penumbra::stress
