// raster.exr, raster.json and raster.png (docs/outputs.md).
#pragma once

#include "common/output_files.h"
#include "common/scenario.h"
#include "raster/raster.h"

namespace penumbra::raster {

struct RasterTimings {
    double load_s = 0;
    double device_s = 0;  // creating the Vulkan context
};

nlohmann::json raster_json(const Scenario& scenario, const Technique& technique, const RasterResult& result,
                           const RasterTimings& timings);
void write_raster_outputs(OutputTransaction& out, const Scenario& scenario, const Technique& technique,
                          const RasterResult& result, const RasterTimings& timings);

}  // namespace penumbra::raster
