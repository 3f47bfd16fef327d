// The oracle's files: oracle.exr, oracle.json, oracle.png (docs/outputs.md).
#pragma once

#include "common/output_files.h"
#include "common/scenario.h"
#include "oracle/oracle.h"

namespace penumbra {

struct OracleTimings {
    double load_s = 0;   // scenario + glTF
    double write_s = 0;  // oracle.exr and oracle.png
};

// oracle.json's content.
nlohmann::json oracle_json(const Scenario& scenario, const OracleResult& result, const OracleTimings& timings);

// oracle.exr and oracle.png; returns the seconds they took.
double write_oracle_images(OutputTransaction& out, const OracleFrame& frame);

// Adds oracle.exr, oracle.png and oracle.json to the transaction (nothing is visible until it
// commits).
void write_oracle_outputs(OutputTransaction& out, const Scenario& scenario, const OracleResult& result,
                          const OracleTimings& timings);

}  // namespace penumbra
