// The raster validator: draws the scenario with a shadow-mapping technique on a Vulkan device
// and returns, per pixel, what the technique decided for every light (docs/raster.md).
#pragma once

#include <memory>
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
    bool map_reused = false;              // the light's map already held what it would draw: no shadow pass
    double shadow_ms = 0, lookup_ms = 0;  // GPU time
};

struct RasterStats {
    DeviceInfo device;
    std::string hw2x2;                                                // "hardware", "emulated" or "unused"
    double camera_ms = 0, shadow_ms = 0, lookup_ms = 0, mask_ms = 0;  // GPU time per pass kind
    double setup_s = 0, render_s = 0;                                 // wall clock: uploads, GPU work
    std::string family;                                               // the technique family that drew
    std::vector<RasterLightStats> lights;
    std::vector<std::string> warnings;
};

struct RasterResult {
    RasterFrame frame;
    RasterStats stats;
};

struct RenderOptions {
    // The depth-map lookups behind V (RasterLightImage::lookups); callers that need only V
    // (tune's and sweep's objective) save their read-back.
    bool lookups = true;
    // Skip a shadow pass whose map is still in place from the previous render with the same
    // inputs (same light, fit, resolution, format, culling and depth bias): a lookup-only change
    // (world bias, normal offset, filter) then costs the lookup alone. Off for timing runs.
    bool reuse_maps = true;
};

// The raster path for one scenario on one device, kept warm: made once, it uploads the scene
// and draws the camera pass; each render(technique) rebuilds only what that technique changes
// (pipelines, maps and per-light buffers are cached) and gives the same frame, bit for bit, as
// a cold run_raster. Not thread-safe; the scenario and context must outlive it.
class RasterSession {
  public:
    // Throws InputError when the image exceeds the device's limits, EnvironmentError for Vulkan failures.
    RasterSession(const Scenario& scenario, const VulkanContext& ctx);
    ~RasterSession();
    RasterSession(const RasterSession&) = delete;
    RasterSession& operator=(const RasterSession&) = delete;

    // Throws InputError for a technique the scene or device cannot run (a map larger than the
    // device allows, a depth format it cannot sample) and EnvironmentError for Vulkan failures.
    RasterResult render(const Technique& technique, const RenderOptions& options = {});

    const Scenario& scenario() const;
    double setup_s() const;  // wall clock of the construction: uploads and the camera pass

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// One cold render: a session made for this technique alone.
RasterResult run_raster(const Scenario& scenario, const Technique& technique, const VulkanContext& ctx);

}  // namespace penumbra::raster
