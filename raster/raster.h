// The raster validator: draws the scenario with a shadow-mapping technique on a Vulkan device
// and returns, per pixel, what the technique decided for every light (docs/raster.md).
#pragma once

#include <string>
#include <vector>

#include "common/frames.h"
#include "common/scenario.h"
#include "raster/light_projection.h"
#include "raster/technique.h"
#include "raster/vulkan_context.h"

namespace penumbra::raster {

struct RasterLightStats {
    LightProjection projection;
    std::uint32_t layers_sampled = 0;  // bit per layer that some receiver samples
    int layers_rendered = 0;
    double shadow_ms = 0, lookup_ms = 0;  // GPU time
};

struct RasterStats {
    DeviceInfo device;
    std::string hw2x2;                                                // "hardware", "emulated" or "unused"
    double camera_ms = 0, shadow_ms = 0, lookup_ms = 0, mask_ms = 0;  // GPU time per pass kind
    double setup_s = 0, render_s = 0;                                 // wall clock: uploads, GPU work
    std::vector<RasterLightStats> lights;
    std::vector<std::string> warnings;
};

struct RasterResult {
    RasterFrame frame;
    RasterStats stats;
};

// Throws InputError for a technique the scene or device cannot run (a map larger
// than the device allows) and EnvironmentError for Vulkan failures.
RasterResult run_raster(const Scenario& scenario, const Technique& technique, const VulkanContext& ctx);

}  // namespace penumbra::raster
