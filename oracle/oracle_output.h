// oracle.json (docs/outputs.md). report/frame_files.h writes it with oracle.exr and oracle.png,
// so that the oracle library does not link OpenImageIO.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>

#include "common/scenario.h"
#include "oracle/oracle.h"

namespace penumbra {

struct OracleTimings {
    double load_s = 0;   // scenario + glTF
    double write_s = 0;  // oracle.exr and oracle.png
    // The two files are written side by side; each one's own time (oracle.json's write_seconds).
    double write_exr_s = 0, write_png_s = 0;
    // `penumbra oracle` writes oracle.exr during the boundary phase (#39): that write's own time;
    // write_exr_s is then the wait for it and the U and boundary_m channels filled in after.
    std::optional<double> write_exr_early_s;  // oracle.exr written during the boundary phase: its own time
};

// oracle.json's content.
nlohmann::json oracle_json(const Scenario& scenario, const OracleResult& result, const OracleTimings& timings);

}  // namespace penumbra
