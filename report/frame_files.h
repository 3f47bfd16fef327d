// The oracle's and the rasterizer's files: oracle.exr, oracle.png, oracle.json and raster.exr,
// raster.png, raster.json (docs/outputs.md). Here rather than in the oracle and raster
// libraries, so that those libraries and their tests do not link the image libraries (image_io/).
#pragma once

#include "common/output_files.h"
#include "common/scenario.h"
#include "oracle/oracle.h"
#include "oracle/oracle_output.h"
#include "raster/raster.h"
#include "raster/raster_output.h"

namespace penumbra::report {

// oracle.exr and oracle.png; returns the seconds they took, and each file's own in `parts`
// (write_s, write_exr_s, write_png_s) where it is given.
double write_oracle_images(OutputTransaction& out, const OracleFrame& frame, OracleTimings* parts = nullptr);

// Adds oracle.exr, oracle.png and oracle.json to the transaction (nothing is visible until it
// commits).
void write_oracle_outputs(OutputTransaction& out, const Scenario& scenario, const OracleResult& result,
                          const OracleTimings& timings);

// Adds raster.exr, raster.png and raster.json to the transaction.
void write_raster_outputs(OutputTransaction& out, const Scenario& scenario, const raster::Technique& technique,
                          const raster::RasterResult& result, const raster::RasterTimings& timings);

}  // namespace penumbra::report
