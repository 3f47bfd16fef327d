// The raster validator: draws the scenario with a shadow-mapping technique on a Vulkan device
// and returns, per pixel, what the technique decided for every light (docs/raster.md).
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "common/frames.h"
#include "common/scenario.h"
#include "raster/light_projection.h"
#include "raster/technique.h"
#include "raster/vulkan_context.h"

namespace penumbra::raster {

// GPU time per pass, by name, in the order first timed. The depth map times "shadow", "lookup"
// and "layer_mask"; a new family's passes (a reduction, a blur, a stencil pass) are new names,
// and raster.json's gpu_ms and sweep's production time take every entry without new fields.
// What each figure includes (which pipeline, which outputs) is said per name in `includes`:
// raster.json's gpu_passes (a production render's shadow pass is depth-only, a diagnostic
// render's also writes the triangle id per texel).
struct PassTimes {
    std::vector<std::pair<std::string, double>> entries;
    std::vector<std::pair<std::string, std::string>> includes;
    void add(std::string_view name, double ms);                         // added to the pass's time so far
    void add(std::string_view name, double ms, std::string_view what);  // and what the pass is (each way once)
    void add(const PassTimes& other);
    double operator[](std::string_view name) const;      // 0 when never timed
    std::string_view what(std::string_view name) const;  // empty when not said
    double total() const;
};

struct RasterLightStats {
    // The depth-map family's fit (the family's own; the views below are what others read).
    LightProjection projection;
    std::vector<ShadowView> views;     // what the light's shadow is drawn from: layer k is views[k]
    std::uint32_t layers_sampled = 0;  // bit per layer that some receiver samples
    int layers_rendered = 0;
    bool map_reused = false;  // the light's map already held what it would draw: no shadow pass
    // The light's map holds the triangle id per texel (a render with lookups needs it for the
    // acne rule); a V-only render draws (or reuses) the depth alone, as an engine does.
    bool map_triangle_ids = false;
    PassTimes gpu_ms;  // this light's passes
    // What the family's renderer says of the light for raster.json (its describe_light may
    // return it): counts a family learns only while drawing, such as a shadow volume's edges.
    nlohmann::json family_keys = nlohmann::json::object();
};

// A light's output left on the device by a render with RenderOptions::read_back off: the
// lookup pass's buffer, LookupTexel per pixel (`lookups`) or V alone (float per pixel). Valid
// until the session's next render; a GPU scorer reads it where it lies (metrics/gpu_classification.h).
struct DeviceLightOutput {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceSize size = 0;
    bool lookups = false;
};

struct RasterStats {
    DeviceInfo device;
    std::string hw2x2;     // "hardware", "emulated" or "unused"
    double camera_ms = 0;  // GPU time of the session's camera pass
    // The camera pass the frame's A and prim come from: an id unique in the process, new with
    // every camera pass drawn (a session's first, set_camera, a new precision).
    std::uint64_t camera_pass = 0;
    PassTimes gpu_ms;                  // GPU time of every other pass, by name, all lights together
    double setup_s = 0, render_s = 0;  // wall clock: uploads, GPU work
    std::string family;                // the technique family that drew
    std::vector<RasterLightStats> lights;
    std::vector<std::string> warnings;
    // read_back off: one entry per light whose family left its output on the device (the
    // frame's light then has no V); empty where the family read back anyway.
    std::vector<DeviceLightOutput> on_device;
};

struct RasterResult {
    RasterFrame frame;
    RasterStats stats;
};

struct RenderOptions {
    // The depth-map lookups behind V (RasterLightImage::lookups); callers that need only V
    // (tune's and sweep's objective) save their read-back. Without them the render is a
    // production one: its shadow passes are depth-only (no triangle-id target), V the same bit
    // for bit (the same vertex shader, depth bias and rasterisation write the same depths).
    bool lookups = true;
    // Skip a shadow pass whose map is still in place from the previous render with the same
    // inputs (same light, fit, resolution, format, culling and depth bias): a lookup-only change
    // (world bias, normal offset, filter) then costs the lookup alone. Off for timing runs.
    bool reuse_maps = true;
    // Off: a family that can leaves each light's output on the device (RasterStats::on_device)
    // and the frame's lights empty, for a scorer on the GPU or a timing run that discards it;
    // a family that cannot reads back as usual.
    bool read_back = true;
    // Off: the frame's A and prim (the camera pass's, the same for every render of a session)
    // are left empty, saving two image copies a render; RasterStats::camera_pass names them.
    // For timing runs, and for a GPU scorer that already has them.
    bool camera_images = true;
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

    // Draws the camera pass again from `camera` (a camera path's frame, pipeline/camera_path.h):
    // the next render is the frame a cold session would give for the scenario with this camera.
    void set_camera(const Camera& camera);

    const Scenario& scenario() const;
    double setup_s() const;  // wall clock of the construction (or of the last set_camera): uploads and the camera pass

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// One cold render: a session made for this technique alone.
RasterResult run_raster(const Scenario& scenario, const Technique& technique, const VulkanContext& ctx);

}  // namespace penumbra::raster
