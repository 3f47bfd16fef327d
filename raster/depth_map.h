// The depth-map core (docs/raster.md, "Adding a depth-map variant"): one depth map per light (six
// cube faces for a point light) drawn with the technique's fit, format, culling and hardware depth
// bias, then one compute lookup per light. The families that draw depth maps (depth_map, cascaded,
// the moment families; averaged_area by composition) are this core plus variants: each variant
// lives in its family's file and plugs into the hooks below, so the core names no family.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "raster/gpu_passes.h"
#include "raster/light_projection.h"
#include "raster/technique_family.h"
#include "shaders/penumbra_shared.h"

namespace penumbra::raster {

// A light's map (or every light's, when they share one) as the core allocated it.
struct MapShape {
    VkFormat format = VK_FORMAT_UNDEFINED;
    std::uint32_t resolution = 0, layers = 0;
    bool operator==(const MapShape&) const = default;
};

// What a variant's passes draw from and into for one light: the core's map of that light.
struct MapTargets {
    std::size_t map_index = 0;
    const GpuImage* depth = nullptr;                // the map the lookup reads
    std::span<const UniqueImageView> depth_layers;  // one view per layer of `depth`
    const LightProjection* projection = nullptr;    // the light's layers
    std::uint32_t layers_sampled = 0;               // bit l: layer l is drawn
    bool redrawn = false;                           // drawn in this render (not reused)
};

// A lookup shader of a variant: its SPIR-V and the value of specialisation constant kSpecFilter.
struct LookupShader {
    const std::uint32_t* code = nullptr;
    std::size_t bytes = 0;
    std::uint32_t filter = 0;
    std::uint32_t pcf_size = 0;
};

// Named GPU timestamps a variant writes between the shadow pass and the lookup (the core's timer).
class PassMarks {
  public:
    PassMarks(const GpuTimestamps& timer, std::uint32_t first) : timer_(timer), next_(first) {}
    void mark(VkCommandBuffer cmd) { timer_.write(cmd, next_++); }

  private:
    const GpuTimestamps& timer_;
    std::uint32_t next_;
};

// The hooks of a depth-map variant. Every hook has the core's behaviour by default; a variant
// overrides those it changes, and decides from the technique whether it applies (a family's one
// core may draw techniques its variant leaves alone, e.g. depth_layer "first").
class DepthMapVariant {
  public:
    virtual ~DepthMapVariant() = default;

    // Refuses (EnvironmentError) a technique the device cannot draw with this variant.
    virtual void check_supported(const Technique&) {}
    // Layers and their fit. The layers of light `l` (unset: the core's, one, six for a point light).
    virtual std::optional<std::uint32_t> layers(const Technique&, const Light&) const { return std::nullopt; }
    // Once per render, before any light is fitted (SDSM's reduction).
    virtual void begin_render(const Technique&, std::span<const Light>, RasterStats&) {}
    // The fit of light `l` (unset: the core's fit_light), with the render's origin for the fit.
    virtual std::optional<LightProjection> fit(const Technique&, const Light&, const glm::dvec3& /*fit_origin*/) const {
        return std::nullopt;
    }
    // Whether every layer of light `l` is drawn (else the core draws what receivers sample).
    virtual bool draws_every_layer(const Technique&, const Light&) const { return false; }
    // The hardware constant bias of `layer` as a multiple of the technique's (cascades scale it).
    virtual double constant_scale(const Technique&, const Light&, const LightProjection&,
                                  std::uint32_t /*layer*/) const {
        return 1.0;
    }
    // The copies of a map texel's bytes this variant keeps (midpoint depth: two layers).
    virtual int map_copies(const Technique&) const { return 1; }

    // Resources beside the core's maps, made for the core's `maps` (kept while they fit), and
    // their first layout transition (recorded before any pass of a render reads them).
    // `remade`: the core's maps are new (views into them must be made again).
    virtual void ensure_map_resources(const Technique&, std::span<const MapShape> /*maps*/,
                                      std::span<const GpuImage* const> /*depth*/, bool /*remade*/) {}
    virtual void record_layouts(VkCommandBuffer) {}
    // Where the shadow pass draws layer `layer` of map `map` (null: the map itself), after any
    // barrier recorded by before_shadow.
    virtual VkImageView shadow_target(const Technique&, std::size_t /*map*/, std::uint32_t /*layer*/) const {
        return VK_NULL_HANDLE;
    }
    virtual void before_shadow(VkCommandBuffer, const Technique&, std::size_t /*map*/) {}
    // A pass into the map just drawn, while it is still a depth attachment (midpoint's second pass).
    virtual void record_map_pass(VkCommandBuffer, const Technique&, const MapTargets&) {}
    // Passes over the readable map, for one light, drawn or reused: exactly timed_passes() marks,
    // whether or not it draws (a pass it skips marks at once). Pass k is timed from the mark
    // before it (the first from the end of the shadow pass).
    virtual std::uint32_t timed_passes() const { return 0; }
    virtual void record_after_map(VkCommandBuffer, const Technique&, const MapTargets&, PassMarks&) {}
    // The GPU times of those passes, from `ms(k)`: pass k's milliseconds.
    virtual void add_times(const Technique&, const std::function<double(std::uint32_t)>& /*ms*/,
                           PassTimes& /*times*/) const {}

    // The lookup: its shader for light `l` (unset: the depth map's), its parameters, and the
    // image bound at kBindingMoments (unset: the map, never read).
    virtual std::optional<LookupShader> lookup_shader(const Technique&, const Light&) const { return std::nullopt; }
    virtual void fill_params(gpu::LookupParams&, const Technique&, const Light&, const LightProjection&) const {}
    virtual std::optional<VkDescriptorImageInfo> family_image(const Technique&, std::size_t /*map*/) const {
        return std::nullopt;
    }
};

// The variants of one family's core, made per session from the scene.
using DepthMapVariants = std::vector<std::unique_ptr<DepthMapVariant>>;

// A family drawn by the depth-map core with `variants` (none: the plain depth map).
std::unique_ptr<TechniqueFamily> make_depth_map_core(const SceneOnGpu& scene, DepthMapVariants variants);

// The depth_map family's own variant: midpoint depth's second pass (raster/depth_layers.cpp).
std::unique_ptr<DepthMapVariant> make_midpoint_variant(const SceneOnGpu& scene);

// Building blocks the core and its variants share.
VkFormat vk_format(DepthFormat f);
std::uint64_t depth_texel_bytes(DepthFormat f);
VkCullModeFlags vk_cull(Cull c);
// Draws the scene's triangles (vertex and index buffers bound) with the pipeline
// `pipeline(cull, cutout)` returns: one draw for the technique's culling; with cull material or
// cut-outs one per run of SceneOnGpu::sided_runs (double-sided runs with none and the others with
// single_sided_cull under cull material; the cut-outs' runs with the alpha test), as an engine
// switches state per material. Triangle ids stay the scene's (shaders/shadow.vert).
void draw_casters(VkCommandBuffer cmd, const SceneOnGpu& scene, const Technique& t,
                  const std::function<VkPipeline(Cull, bool cutout)>& pipeline);
// The lookup's kSpecFilter for a depth-compare filter (kFilter*).
gpu::uint filter_kind(FilterType f);
// A compute pipeline of `code` whose specialisation constants 0, 1, ... take `spec` in order.
UniquePipeline make_compute_pipeline(const VulkanContext& ctx, VkPipelineLayout layout, const std::uint32_t* code,
                                     std::size_t bytes, std::span<const std::uint32_t> spec);

}  // namespace penumbra::raster
