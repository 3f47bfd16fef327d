// raster.json (docs/outputs.md). report/frame_files.h writes it with raster.exr and raster.png,
// so that the raster library does not link OpenImageIO.
#pragma once

#include <nlohmann/json.hpp>

#include "common/scenario.h"
#include "raster/raster.h"

namespace penumbra::raster {

struct RasterTimings {
    double load_s = 0;
    double device_s = 0;  // creating the Vulkan context
    int threads = 0;      // the worker threads the command ran under (--threads; 0: not recorded)
};

// The clocks behind the GPU times (DeviceInfo): raster.json's and sweep.json's device.timestamps.
nlohmann::json timestamps_json(const DeviceInfo& device);

nlohmann::json raster_json(const Scenario& scenario, const Technique& technique, const RasterResult& result,
                           const RasterTimings& timings);

}  // namespace penumbra::raster
