// Vulkan building blocks the raster path's passes share: pipelines, barriers, dynamic
// rendering, samplers, and descriptor sets declared once as a table of bindings (the set
// layout, the pool sizes and the writes all come from the same table).
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <span>
#include <vector>

#include "raster/vulkan_context.h"

namespace penumbra::raster {

// The primitive-id colour target of the camera and shadow passes.
inline constexpr VkFormat kPrimFormat = VK_FORMAT_R32_UINT;

inline constexpr VkPipelineStageFlags2 kFragmentTests =
    VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;

UniqueShaderModule make_module(const VulkanContext& ctx, const std::uint32_t* code, std::size_t bytes);
// A device-local buffer holding `bytes` of `data` (through a staging copy).
GpuBuffer upload(const VulkanContext& ctx, const void* data, std::size_t bytes, VkBufferUsageFlags usage);

void image_barrier(VkCommandBuffer cmd, VkImage image, VkImageAspectFlags aspect, std::uint32_t layers,
                   VkImageLayout from, VkImageLayout to, VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access,
                   VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access);
void memory_barrier(VkCommandBuffer cmd, VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access,
                    VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access);

// How a graphics pipeline reads its vertices: one vec3 stream (the scene), one vec4 stream
// (homogeneous points, w = 0 at infinity: shadow volumes), or none (a full-screen triangle).
enum class VertexInput { vec3, vec4, none };

// A graphics pipeline of any pass: by default the camera and shadow passes' (one vec3 stream, one
// R32_UINT colour target for the primitive id, a depth target, depth test and write), with
// dynamic rendering, dynamic viewport, scissor and depth bias. Without a fragment shader (frag
// null) it is depth-only, with no colour target. The fields after `geom` serve the passes that
// differ (shadow volumes: a vec4 stream, another colour target or none, a stencil test).
struct GraphicsSetup {
    const std::uint32_t* vert;
    std::size_t vert_bytes;
    const std::uint32_t* frag;
    std::size_t frag_bytes;
    VkFormat depth_format;
    VkCompareOp depth_compare;
    VkCullModeFlags cull;
    VkFrontFace front_face;
    bool depth_clamp;
    bool depth_bias;
    // A geometry shader between the two (null: none), e.g. the shadow pass's caster offsets.
    const std::uint32_t* geom = nullptr;
    std::size_t geom_bytes = 0;
    VertexInput vertex_input = VertexInput::vec3;
    VkFormat colour_format = kPrimFormat;  // with a fragment shader; VK_FORMAT_UNDEFINED: no colour target
    bool depth_test = true, depth_write = true;
    // The depth target's stencil aspect is attached (a depth-stencil format), and tested with
    // `front` and `back` when stencil_test.
    bool stencil_attachment = false, stencil_test = false;
    VkStencilOpState front{}, back{};
    // The fragment shader's specialisation constants, ids 0, 1, ... (4 bytes each).
    std::vector<std::uint32_t> frag_spec;
};
UniquePipeline make_graphics_pipeline(const VulkanContext& ctx, VkPipelineLayout layout, const GraphicsSetup& g);
UniquePipelineLayout make_pipeline_layout(const VulkanContext& ctx, VkDescriptorSetLayout set_layout,
                                          std::uint32_t push_bytes, VkShaderStageFlags push_stages);
// A compare sampler compares LESS_OR_EQUAL against a border of 1, GREATER_OR_EQUAL against 0 when
// `reversed_z` (the map stores 1 - z).
UniqueSampler make_sampler(const VulkanContext& ctx, bool compare, bool linear, bool clamp_to_border,
                           bool reversed_z = false);

void set_viewport(VkCommandBuffer cmd, std::uint32_t w, std::uint32_t h);
// Clears the R32_UINT colour target to "no primitive" and the depth target to `depth_clear`.
// A null `color` begins a depth-only pass (for a pipeline made without a fragment shader).
void begin_rendering(VkCommandBuffer cmd, VkImageView color, VkImageView depth, std::uint32_t w, std::uint32_t h,
                     float depth_clear);

// GPU timestamps in one query pool, grown on demand and read back in one call: the timer every
// pass shares (raster.json's gpu_ms). Ticks become milliseconds by the device's timestampPeriod.
class GpuTimestamps {
  public:
    explicit GpuTimestamps(const VulkanContext& ctx) : ctx_(&ctx) {}
    // At least `count` queries (a larger pool replaces the old one: only between submissions).
    void ensure(std::uint32_t count);
    void reset(VkCommandBuffer cmd, std::uint32_t first, std::uint32_t count) const;
    void write(VkCommandBuffer cmd, std::uint32_t query,
               VkPipelineStageFlags2 stage = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT) const;
    // Queries [first, first + count), after the submission that wrote them has completed.
    void read(std::uint32_t first, std::uint32_t count);
    // Milliseconds from query a to query b (as read), 0 when b's ticks precede a's.
    double ms(std::uint32_t a, std::uint32_t b) const;

  private:
    const VulkanContext* ctx_;
    UniqueQueryPool pool_;
    std::uint32_t capacity_ = 0;
    std::vector<std::uint64_t> ticks_;
};
// Milliseconds between two timestamps of `ctx`, 0 when b precedes a.
double ticks_to_ms(const VulkanContext& ctx, std::uint64_t a, std::uint64_t b);

// Dynamic rendering into a depth-stencil target (its depth and its stencil each cleared to 0 or
// loaded), and into `colour` cleared to 0 when given: the shadow volumes' passes.
void begin_depth_stencil_rendering(VkCommandBuffer cmd, VkImageView colour, VkImageView depth_stencil, std::uint32_t w,
                                   std::uint32_t h, bool clear_depth, bool clear_stencil);

// One binding of a descriptor set (one descriptor each).
struct BindingDecl {
    std::uint32_t binding;
    VkDescriptorType type;
};
// What one binding points at: `image` for image types, `buffer` for buffer types.
struct DescriptorResource {
    VkDescriptorImageInfo image{};
    VkDescriptorBufferInfo buffer{};
};
UniqueDescriptorSetLayout make_set_layout(const VulkanContext& ctx, std::span<const BindingDecl> decls,
                                          VkShaderStageFlags stages);

// Sets of one layout, grown on demand; `write` takes one resource per declared binding, in
// the table's order.
class DescriptorSets {
  public:
    DescriptorSets(const VulkanContext& ctx, std::span<const BindingDecl> decls, VkShaderStageFlags stages);
    void reserve(std::size_t count);  // may reallocate: sets must be written again after growing
    void write(std::size_t index, std::span<const DescriptorResource> resources) const;
    VkDescriptorSetLayout layout() const { return layout_.get(); }
    VkDescriptorSet operator[](std::size_t index) const { return sets_[index]; }
    std::size_t size() const { return sets_.size(); }

  private:
    const VulkanContext* ctx_;
    std::vector<BindingDecl> decls_;
    UniqueDescriptorSetLayout layout_;
    UniqueDescriptorPool pool_;
    std::vector<VkDescriptorSet> sets_;
};

}  // namespace penumbra::raster
