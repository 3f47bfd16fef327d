// validate's files (docs/outputs.md). Apart from validate.h, in its own library, so that what
// only scores (the tests of the verdict, tune's loop) does not link the image libraries (image_io/).
#pragma once

#include "common/output_files.h"
#include "pipeline/validate.h"

namespace penumbra {

// Which of validate's files beyond the verdict's are written.
struct ValidateFiles {
    // --frames: oracle.exr/png and raster.exr/png, and errors.exr (the oracle frame must then
    // hold P, N, depth: ValidateOptions::keep_oracle_frame).
    bool frames = false;
    // --errors (or --frames): errors.exr, the per-pixel error, class and perceptual error. Off
    // by default: its ZIP compression was two thirds of validate's writing on data/default.
    bool errors = false;
    bool tint_cascades = false;  // validate --class-map-tint cascade
};

// report.html, report.json, the PNG maps, raster.json and oracle.json into `out`, and what
// `files` asks for.
void write_validate_outputs(OutputTransaction& out, const Scenario& scenario, const ValidateResult& result,
                            const ValidateFiles& files);

}  // namespace penumbra
