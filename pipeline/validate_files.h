// validate's files (docs/outputs.md). Apart from validate.h, in its own library, so that what
// only scores (the tests of the verdict, tune's loop) does not link the image libraries (image_io/).
#pragma once

#include "common/output_files.h"
#include "pipeline/validate.h"

namespace penumbra {

// report.html, report.json, errors.exr, the PNG maps, raster.json and oracle.json into `out`;
// with `frames`, oracle.exr/png and raster.exr/png too (the oracle frame must then hold P, N,
// depth: ValidateOptions::keep_oracle_frame). `tint_cascades`: validate --class-map-tint cascade.
void write_validate_outputs(OutputTransaction& out, const Scenario& scenario, const ValidateResult& result, bool frames,
                            bool tint_cascades = false);

}  // namespace penumbra
