// The files of validate over a camera path (docs/outputs.md): validate's, for the last frame, and
// flicker.exr. Apart from camera_path.h for the reason validate_files.h is.
#pragma once

#include "common/output_files.h"
#include "pipeline/camera_path.h"
#include "pipeline/validate_files.h"

namespace penumbra {

// write_validate_outputs of the last frame, and flicker.exr: per light a channel
// light<i>.flicker, the number of frame pairs in which the point seen at the pixel flickered.
void write_camera_path_outputs(OutputTransaction& out, const Scenario& scenario, const CameraPathResult& result,
                               const ValidateFiles& files);

}  // namespace penumbra
