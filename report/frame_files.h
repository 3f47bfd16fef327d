// The oracle's and the rasterizer's files: oracle.exr, oracle.png, oracle.json and raster.exr,
// raster.png, raster.json (docs/outputs.md). Here rather than in the oracle and raster
// libraries, so that those libraries and their tests do not link the image libraries (image_io/).
#pragma once

#include <future>

#include "common/output_files.h"
#include "common/scenario.h"
#include "oracle/oracle.h"
#include "oracle/oracle_output.h"
#include "raster/raster.h"
#include "raster/raster_output.h"

namespace penumbra::report {

// Starts oracle.exr from a frame whose channels are final but each light's U and boundary_m,
// which the boundary phase is writing (run_oracle's trace_done, #39): those two are written from
// a constant (the arrays are never read here) and write_oracle_images fills them in afterwards.
// On a thread of its own. Returns the write (a write error is thrown by its get()); its own
// seconds go to `seconds` when it ends.
std::shared_future<void> start_oracle_exr(OutputTransaction& out, const OracleFrame& frame, double& seconds);

// oracle.exr and oracle.png; returns the seconds they took, and each file's own in `parts`
// (write_s, write_exr_s, write_png_s) where it is given. With `early_exr` (start_oracle_exr's),
// oracle.exr is that write's, waited for and completed in place (each light's U and boundary_m);
// the file is the same as the one written here without it.
double write_oracle_images(OutputTransaction& out, const OracleFrame& frame, OracleTimings* parts = nullptr,
                           const std::shared_future<void>& early_exr = {});

// Adds oracle.exr, oracle.png and oracle.json to the transaction (nothing is visible until it
// commits); `early_exr` as write_oracle_images'.
void write_oracle_outputs(OutputTransaction& out, const Scenario& scenario, const OracleResult& result,
                          const OracleTimings& timings, const std::shared_future<void>& early_exr = {});

// Adds raster.exr, raster.png and raster.json to the transaction.
void write_raster_outputs(OutputTransaction& out, const Scenario& scenario, const raster::Technique& technique,
                          const raster::RasterResult& result, const raster::RasterTimings& timings);

}  // namespace penumbra::report
