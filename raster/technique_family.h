// Technique families as plug-ins (docs/raster.md, "Adding a technique family"). A family is
// one way of turning the scene into a shadow factor per pixel and light (depth maps with
// their filters and biases; averaged hard shadows for area lights; next: cascades, moment
// maps, shadow volumes). It owns its passes, GPU resources, lookup and diagnostics, builds
// them on first use and keeps them for the session's next render, redoing only what a new
// technique changes. The session owns what every family shares (SceneOnGpu).
#pragma once

#include <functional>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "common/frames.h"
#include "common/scene.h"
#include "raster/gpu_passes.h"
#include "raster/raster.h"
#include "raster/technique.h"

namespace penumbra::raster {

// What every family draws from, made once per session: the scene in the camera-centred frame
// on the GPU and the camera pass (the triangle seen per pixel) that the lookups start from.
struct SceneOnGpu {
    const Scenario& scenario;
    const VulkanContext& ctx;
    glm::dvec3 origin{0.0};                            // world position of the frame (the camera eye)
    Precision precision = Precision::camera_relative;  // of the uploaded positions (Technique::precision)
    std::uint32_t width = 0, height = 0;
    std::size_t pixels = 0;
    // float3 per vertex (camera-relative; world_float32: rounded to float in world space first),
    // uint3 per triangle, bits
    GpuBuffer positions, indices, double_sided;
    std::uint32_t index_count = 0;
    GpuImage gbuffer_prim;  // R32_UINT, GENERAL layout after the camera pass: triangle per pixel
    std::vector<float> A;   // 1 where a triangle covers the pixel
    std::vector<std::uint32_t> prim;
    double camera_ms = 0;  // GPU time of the camera pass
};

class TechniqueFamily {
  public:
    virtual ~TechniqueFamily() = default;
    // Draws every light of `lights` (the scenario's, in order) with `technique` into
    // frame.lights and stats.lights (one entry per light each), adding GPU times to `stats`.
    virtual void render(const Technique& technique, std::span<const Light> lights, const RenderOptions& options,
                        RasterFrame& frame, RasterStats& stats) = 0;
};

// A registered family: the first whose `accepts` holds draws the technique.
struct FamilyEntry {
    std::string_view name;
    std::string_view description;
    std::function<bool(const Technique&)> accepts;
    std::function<std::unique_ptr<TechniqueFamily>(const SceneOnGpu&)> make;
};
const std::vector<FamilyEntry>& technique_families();

// The built-in families (each in its own file).
std::unique_ptr<TechniqueFamily> make_depth_map_family(const SceneOnGpu& scene);
std::unique_ptr<TechniqueFamily> make_averaged_area_family(const SceneOnGpu& scene);

}  // namespace penumbra::raster
