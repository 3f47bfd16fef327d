#include "raster/raster.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "common/camera.h"
#include "common/errors.h"
#include "raster/area_lights.h"
#include "shaders/penumbra_shared.h"
// SPIR-V compiled from shaders/ at build time.
#include "camera_frag.h"
#include "camera_vert.h"
#include "common/stopwatch.h"
#include "lookup_comp.h"
#include "shadow_frag.h"
#include "shadow_vert.h"

namespace penumbra::raster {

static_assert(gpu::kFlagSurface == kRasterSurface && gpu::kFlagBackFacing == kRasterBackFacing &&
              gpu::kFlagOutsideCone == kRasterOutsideCone && gpu::kFlagOutsideMap == kRasterOutsideMap);
static_assert(sizeof(gpu::LookupTexel) == 36);

namespace {

constexpr VkFormat kPrimFormat = VK_FORMAT_R32_UINT;
constexpr VkFormat kCameraDepthFormat = VK_FORMAT_D32_SFLOAT;

VkFormat vk_format(DepthFormat f) {
    switch (f) {
        case DepthFormat::d16: return VK_FORMAT_D16_UNORM;
        case DepthFormat::d24: return VK_FORMAT_X8_D24_UNORM_PACK32;
        case DepthFormat::d32: return VK_FORMAT_D32_SFLOAT;
    }
    return VK_FORMAT_D32_SFLOAT;
}

UniqueShaderModule make_module(const VulkanContext& ctx, const std::uint32_t* code, std::size_t bytes) {
    VkShaderModuleCreateInfo ci{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    ci.codeSize = bytes;
    ci.pCode = code;
    VkShaderModule m;
    VK_CHECK(vkCreateShaderModule(ctx.device(), &ci, nullptr, &m));
    return UniqueShaderModule(ctx.device(), m);
}

GpuBuffer upload(const VulkanContext& ctx, const void* data, std::size_t bytes, VkBufferUsageFlags usage) {
    GpuBuffer staging = create_buffer(ctx, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true);
    if (bytes) std::memcpy(staging.mapped, data, bytes);
    GpuBuffer dst = create_buffer(ctx, bytes, usage | VK_BUFFER_USAGE_TRANSFER_DST_BIT, false);
    ctx.submit_and_wait([&](VkCommandBuffer cmd) {
        VkBufferCopy region{0, 0, std::max<VkDeviceSize>(bytes, 4)};
        vkCmdCopyBuffer(cmd, staging.buffer.get(), dst.buffer.get(), 1, &region);
    });
    return dst;
}

void image_barrier(VkCommandBuffer cmd, VkImage image, VkImageAspectFlags aspect, std::uint32_t layers,
                   VkImageLayout from, VkImageLayout to, VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access,
                   VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access) {
    VkImageMemoryBarrier2 b{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
    b.srcStageMask = src_stage;
    b.srcAccessMask = src_access;
    b.dstStageMask = dst_stage;
    b.dstAccessMask = dst_access;
    b.oldLayout = from;
    b.newLayout = to;
    b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = image;
    b.subresourceRange = {aspect, 0, 1, 0, layers};
    VkDependencyInfo di{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
    di.imageMemoryBarrierCount = 1;
    di.pImageMemoryBarriers = &b;
    vkCmdPipelineBarrier2(cmd, &di);
}

void memory_barrier(VkCommandBuffer cmd, VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access,
                    VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access) {
    VkMemoryBarrier2 b{VK_STRUCTURE_TYPE_MEMORY_BARRIER_2};
    b.srcStageMask = src_stage;
    b.srcAccessMask = src_access;
    b.dstStageMask = dst_stage;
    b.dstAccessMask = dst_access;
    VkDependencyInfo di{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
    di.memoryBarrierCount = 1;
    di.pMemoryBarriers = &b;
    vkCmdPipelineBarrier2(cmd, &di);
}

// A graphics pipeline for the camera and shadow passes: one vec3 stream, one R32_UINT colour
// target (the primitive id) and a depth target, dynamic rendering.
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
};

UniquePipeline make_graphics_pipeline(const VulkanContext& ctx, VkPipelineLayout layout, const GraphicsSetup& g) {
    UniqueShaderModule vs = make_module(ctx, g.vert, g.vert_bytes), fs = make_module(ctx, g.frag, g.frag_bytes);
    VkPipelineShaderStageCreateInfo stages[2] = {{VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO},
                                                 {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO}};
    stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
    stages[0].module = vs.get();
    stages[0].pName = "main";
    stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
    stages[1].module = fs.get();
    stages[1].pName = "main";

    VkVertexInputBindingDescription binding{0, 3 * sizeof(float), VK_VERTEX_INPUT_RATE_VERTEX};
    VkVertexInputAttributeDescription attribute{0, 0, VK_FORMAT_R32G32B32_SFLOAT, 0};
    VkPipelineVertexInputStateCreateInfo vi{VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
    vi.vertexBindingDescriptionCount = 1;
    vi.pVertexBindingDescriptions = &binding;
    vi.vertexAttributeDescriptionCount = 1;
    vi.pVertexAttributeDescriptions = &attribute;
    VkPipelineInputAssemblyStateCreateInfo ia{VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
    ia.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
    VkPipelineViewportStateCreateInfo vp{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
    vp.viewportCount = 1;
    vp.scissorCount = 1;
    VkPipelineRasterizationStateCreateInfo rs{VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
    rs.depthClampEnable = g.depth_clamp;
    rs.polygonMode = VK_POLYGON_MODE_FILL;
    rs.cullMode = g.cull;
    rs.frontFace = g.front_face;
    rs.depthBiasEnable = g.depth_bias;
    rs.lineWidth = 1.0f;
    VkPipelineMultisampleStateCreateInfo ms{VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
    ms.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
    VkPipelineDepthStencilStateCreateInfo ds{VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
    ds.depthTestEnable = VK_TRUE;
    ds.depthWriteEnable = VK_TRUE;
    ds.depthCompareOp = g.depth_compare;
    VkPipelineColorBlendAttachmentState blend{};
    blend.colorWriteMask = VK_COLOR_COMPONENT_R_BIT;
    VkPipelineColorBlendStateCreateInfo cb{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
    cb.attachmentCount = 1;
    cb.pAttachments = &blend;
    VkDynamicState dyn[] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR, VK_DYNAMIC_STATE_DEPTH_BIAS};
    VkPipelineDynamicStateCreateInfo dy{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
    dy.dynamicStateCount = 3;
    dy.pDynamicStates = dyn;
    VkPipelineRenderingCreateInfo ri{VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO};
    ri.colorAttachmentCount = 1;
    VkFormat color = kPrimFormat;
    ri.pColorAttachmentFormats = &color;
    ri.depthAttachmentFormat = g.depth_format;

    VkGraphicsPipelineCreateInfo ci{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO};
    ci.pNext = &ri;
    ci.stageCount = 2;
    ci.pStages = stages;
    ci.pVertexInputState = &vi;
    ci.pInputAssemblyState = &ia;
    ci.pViewportState = &vp;
    ci.pRasterizationState = &rs;
    ci.pMultisampleState = &ms;
    ci.pDepthStencilState = &ds;
    ci.pColorBlendState = &cb;
    ci.pDynamicState = &dy;
    ci.layout = layout;
    VkPipeline p;
    VK_CHECK(vkCreateGraphicsPipelines(ctx.device(), VK_NULL_HANDLE, 1, &ci, nullptr, &p));
    return UniquePipeline(ctx.device(), p);
}

UniquePipelineLayout make_pipeline_layout(const VulkanContext& ctx, VkDescriptorSetLayout set_layout,
                                          std::uint32_t push_bytes, VkShaderStageFlags push_stages) {
    VkPushConstantRange range{push_stages, 0, push_bytes};
    VkPipelineLayoutCreateInfo ci{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    ci.setLayoutCount = set_layout ? 1 : 0;
    ci.pSetLayouts = &set_layout;
    ci.pushConstantRangeCount = push_bytes ? 1 : 0;
    ci.pPushConstantRanges = &range;
    VkPipelineLayout l;
    VK_CHECK(vkCreatePipelineLayout(ctx.device(), &ci, nullptr, &l));
    return UniquePipelineLayout(ctx.device(), l);
}

UniqueDescriptorSetLayout make_set_layout(const VulkanContext& ctx,
                                          const std::vector<VkDescriptorSetLayoutBinding>& bindings) {
    VkDescriptorSetLayoutCreateInfo ci{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    ci.bindingCount = static_cast<std::uint32_t>(bindings.size());
    ci.pBindings = bindings.data();
    VkDescriptorSetLayout l;
    VK_CHECK(vkCreateDescriptorSetLayout(ctx.device(), &ci, nullptr, &l));
    return UniqueDescriptorSetLayout(ctx.device(), l);
}

// One descriptor of a set: an image (ii) or a buffer (bi), the other null.
VkWriteDescriptorSet descriptor_write(VkDescriptorSet set, std::uint32_t binding, VkDescriptorType type,
                                      const VkDescriptorImageInfo* ii, const VkDescriptorBufferInfo* bi) {
    VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w.dstSet = set;
    w.dstBinding = binding;
    w.descriptorCount = 1;
    w.descriptorType = type;
    w.pImageInfo = ii;
    w.pBufferInfo = bi;
    return w;
}

UniqueSampler make_sampler(const VulkanContext& ctx, bool compare, bool linear, bool clamp_to_border) {
    VkSamplerCreateInfo ci{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
    ci.magFilter = ci.minFilter = linear ? VK_FILTER_LINEAR : VK_FILTER_NEAREST;
    ci.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
    ci.addressModeU = ci.addressModeV = ci.addressModeW =
        clamp_to_border ? VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_BORDER : VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    ci.borderColor = VK_BORDER_COLOR_FLOAT_OPAQUE_WHITE;  // outside the map reads as lit
    ci.compareEnable = compare;
    ci.compareOp = VK_COMPARE_OP_LESS_OR_EQUAL;
    ci.maxLod = 0.0f;
    VkSampler s;
    VK_CHECK(vkCreateSampler(ctx.device(), &ci, nullptr, &s));
    return UniqueSampler(ctx.device(), s);
}

// Deterministic Poisson-disk taps in the unit disk: best-candidate dart throwing with a fixed
// integer generator, so every run and every platform uses the same pattern.
std::vector<glm::vec2> poisson_disk(int n) {
    std::uint64_t state = 0x9E3779B97F4A7C15ull;
    auto next = [&] {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        return static_cast<double>(state >> 40) / static_cast<double>(1ull << 24);
    };
    std::vector<glm::vec2> pts;
    while (static_cast<int>(pts.size()) < n) {
        glm::dvec2 best(0.0);
        double best_d = -1;
        for (int c = 0; c < 32; ++c) {
            glm::dvec2 q;
            do q = glm::dvec2(next() * 2 - 1, next() * 2 - 1);
            while (glm::dot(q, q) > 1.0);
            double d = 1e9;
            for (const auto& p : pts) d = std::min(d, glm::length(q - glm::dvec2(p)));
            if (d > best_d) {
                best_d = d;
                best = q;
            }
        }
        pts.emplace_back(best);
    }
    return pts;
}

gpu::uint light_kind(LightType t) {
    switch (t) {
        case LightType::directional: return gpu::kLightDirectional;
        case LightType::spot: return gpu::kLightSpot;
        default: return gpu::kLightPoint;
    }
}

gpu::uint filter_kind(FilterType f) {
    switch (f) {
        case FilterType::none: return gpu::kFilterNone;
        case FilterType::hw2x2: return gpu::kFilterHw2x2;
        case FilterType::pcf: return gpu::kFilterPcf;
        case FilterType::poisson: return gpu::kFilterPoisson;
        case FilterType::pcss: return gpu::kFilterPcss;
    }
    return gpu::kFilterNone;
}

struct SpecData {
    std::array<std::uint32_t, 8> values{};
};

UniquePipeline make_lookup_pipeline(const VulkanContext& ctx, VkPipelineLayout layout, const SpecData& spec) {
    UniqueShaderModule cs = make_module(ctx, kLookupComp, sizeof(kLookupComp));
    std::array<VkSpecializationMapEntry, 8> entries;
    for (std::uint32_t i = 0; i < 8; ++i) entries[i] = {i, i * 4, 4};
    VkSpecializationInfo si{8, entries.data(), sizeof(spec.values), spec.values.data()};
    VkComputePipelineCreateInfo ci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    ci.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
    ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    ci.stage.module = cs.get();
    ci.stage.pName = "main";
    ci.stage.pSpecializationInfo = &si;
    ci.layout = layout;
    VkPipeline p;
    VK_CHECK(vkCreateComputePipelines(ctx.device(), VK_NULL_HANDLE, 1, &ci, nullptr, &p));
    return UniquePipeline(ctx.device(), p);
}

// Camera clip space from camera-relative positions, matching docs/design.md's pixel centres:
// y is flipped so that row 0 is the top row; reversed depth (1 at znear) for precision. The
// far plane is zfar or just beyond the scene, whichever is nearer (glTF allows zfar = inf).
glm::mat4 camera_matrix(const Camera& cam, int w, int h, const Bounds& scene) {
    double near = cam.znear;
    double far = std::max(near * 2, farthest_along(scene, cam.eye, cam.forward) * 1.01 + 1e-6);
    far = std::min(far, std::min(cam.zfar, 3.0e38));
    bool persp = cam.type == ProjectionType::perspective;
    glm::dvec2 plane = ndc_to_image_plane(cam, w, h);
    glm::dmat4 m(0.0);
    for (int c = 0; c < 3; ++c) {
        m[c][0] = cam.right[c] / plane.x;
        m[c][1] = -cam.up[c] / plane.y;
        if (persp) {
            m[c][2] = -cam.forward[c] * near / (far - near);
            m[c][3] = cam.forward[c];
        } else {
            m[c][2] = -cam.forward[c] / (far - near);
        }
    }
    m[3][2] = persp ? near * far / (far - near) : far / (far - near);
    m[3][3] = persp ? 0.0 : 1.0;
    return glm::mat4(m);
}

class Renderer {
  public:
    // `lights` are punctual: area lights arrive expanded (raster/area_lights.h).
    Renderer(const Scenario& s, std::vector<Light> lights, const Technique& t, const VulkanContext& ctx)
        : s_(s), lights_(std::move(lights)), t_(t), ctx_(ctx) {}
    RasterResult run();

  private:
    void check_supported();
    void upload_scene();
    void make_pipelines();
    void make_targets();
    void make_light_resources();
    void record_camera_and_masks(VkCommandBuffer cmd);
    void record_light(VkCommandBuffer cmd, std::size_t li);
    void read_back(RasterResult& out);
    void read_timings();  // all timestamps in one query-pool read

    const Scenario& s_;
    const std::vector<Light> lights_;
    const Technique& t_;
    const VulkanContext& ctx_;
    RasterStats stats_;
    glm::dvec3 origin_{0.0};
    std::uint32_t W_ = 0, H_ = 0;
    std::size_t pixels_ = 0;
    bool hardware_compare_ = false;

    GpuBuffer positions_, indices_, double_sided_;
    std::uint32_t index_count_ = 0;
    GpuImage gbuffer_prim_, gbuffer_depth_;
    GpuImage shadow_depth_, shadow_prim_;
    std::vector<UniqueImageView> shadow_depth_layers_, shadow_prim_layers_;
    GpuBuffer prim_readback_;

    UniqueDescriptorSetLayout camera_set_layout_, lookup_set_layout_;
    UniquePipelineLayout camera_layout_, shadow_layout_, lookup_layout_;
    UniquePipeline camera_pipeline_, shadow_pipeline_;
    std::array<UniquePipeline, 3> lookup_pipelines_;  // indexed by gpu::kLight*
    UniquePipeline mask_pipeline_;                    // point lights' sampled-face pass
    UniqueDescriptorPool pool_;
    VkDescriptorSet camera_set_ = VK_NULL_HANDLE;
    std::vector<VkDescriptorSet> lookup_sets_;
    std::vector<GpuBuffer> params_, outputs_, masks_;
    UniqueSampler nearest_, compare_;
    UniqueQueryPool queries_;
    std::uint32_t query_count_ = 0;
};

void Renderer::check_supported() {
    std::uint32_t max_dim = ctx_.limits().maxImageDimension2D;
    if (static_cast<std::uint32_t>(t_.resolution) > max_dim)
        throw InputError(fmt::format("technique.resolution: {} exceeds the device's maxImageDimension2D {} ({})",
                                     t_.resolution, max_dim, ctx_.info().name));
    if (W_ > max_dim || H_ > max_dim)
        throw InputError(
            fmt::format("{}: image {}x{} exceeds the device's maxImageDimension2D {}", s_.label, W_, H_, max_dim));
    if (!ctx_.supports_depth_attachment(vk_format(t_.depth_format)))
        throw EnvironmentError(fmt::format("Vulkan device '{}' cannot render and sample depth format {}",
                                           ctx_.info().name, to_string(t_.depth_format)));
    bool wants_bilinear =
        t_.filter.type == FilterType::hw2x2 ||
        (t_.filter.bilinear_taps && (t_.filter.type == FilterType::pcf || t_.filter.type == FilterType::poisson));
    hardware_compare_ = wants_bilinear && ctx_.supports_linear_depth_compare(vk_format(t_.depth_format));
    stats_.hw2x2 = !wants_bilinear ? "unused" : hardware_compare_ ? "hardware" : "emulated";
}

void Renderer::upload_scene() {
    const Scene& scene = s_.scene;
    std::vector<float> pos(scene.positions.size() * 3);
    for (std::size_t i = 0; i < scene.positions.size(); ++i) {
        glm::dvec3 p = scene.positions[i] - origin_;  // double subtraction, then float: precision near the camera
        pos[3 * i] = static_cast<float>(p.x);
        pos[3 * i + 1] = static_cast<float>(p.y);
        pos[3 * i + 2] = static_cast<float>(p.z);
    }
    std::vector<std::uint32_t> idx(scene.triangles.size() * 3);
    std::vector<std::uint32_t> bits((scene.triangles.size() + 31) / 32 + 1, 0u);
    for (std::size_t t = 0; t < scene.triangles.size(); ++t) {
        idx[3 * t] = scene.triangles[t].x;
        idx[3 * t + 1] = scene.triangles[t].y;
        idx[3 * t + 2] = scene.triangles[t].z;
        if (scene.double_sided[t]) bits[t / 32] |= 1u << (t % 32);
    }
    index_count_ = static_cast<std::uint32_t>(idx.size());
    positions_ = upload(ctx_, pos.data(), pos.size() * sizeof(float),
                        VK_BUFFER_USAGE_VERTEX_BUFFER_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
    indices_ = upload(ctx_, idx.data(), idx.size() * sizeof(std::uint32_t),
                      VK_BUFFER_USAGE_INDEX_BUFFER_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
    double_sided_ = upload(ctx_, bits.data(), bits.size() * sizeof(std::uint32_t), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
}

void Renderer::make_pipelines() {
    camera_set_layout_ = make_set_layout(
        ctx_, {{gpu::kBindingDoubleSided, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_FRAGMENT_BIT}});
    camera_layout_ =
        make_pipeline_layout(ctx_, camera_set_layout_.get(), sizeof(glm::mat4), VK_SHADER_STAGE_VERTEX_BIT);
    shadow_layout_ = make_pipeline_layout(ctx_, VK_NULL_HANDLE, sizeof(glm::mat4), VK_SHADER_STAGE_VERTEX_BIT);

    // The camera pass culls nothing: the fragment shader drops single-sided back faces using
    // gl_FrontFacing. Front = counter-clockwise as seen, which with camera_matrix's y flip is
    // VK_FRONT_FACE_COUNTER_CLOCKWISE (pinned by the culling and primitive-agreement tests).
    camera_pipeline_ = make_graphics_pipeline(
        ctx_, camera_layout_.get(),
        {kCameraVert, sizeof(kCameraVert), kCameraFrag, sizeof(kCameraFrag), kCameraDepthFormat, VK_COMPARE_OP_GREATER,
         VK_CULL_MODE_NONE, VK_FRONT_FACE_COUNTER_CLOCKWISE, false, false});
    // Light maps have no y flip, which mirrors the winding: counter-clockwise as seen from the
    // light is VK_FRONT_FACE_CLOCKWISE here (pinned by the culling test).
    VkCullModeFlags cull = t_.cull == Cull::none   ? VK_CULL_MODE_NONE
                           : t_.cull == Cull::back ? VK_CULL_MODE_BACK_BIT
                                                   : VK_CULL_MODE_FRONT_BIT;
    bool bias = t_.bias.constant != 0 || t_.bias.slope != 0;
    shadow_pipeline_ = make_graphics_pipeline(
        ctx_, shadow_layout_.get(),
        {kShadowVert, sizeof(kShadowVert), kShadowFrag, sizeof(kShadowFrag), vk_format(t_.depth_format),
         VK_COMPARE_OP_LESS, cull, VK_FRONT_FACE_CLOCKWISE, true, bias});

    auto cs = VK_SHADER_STAGE_COMPUTE_BIT;
    lookup_set_layout_ =
        make_set_layout(ctx_, {{gpu::kBindingGBufferPrim, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, cs},
                               {gpu::kBindingPositions, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, cs},
                               {gpu::kBindingIndices, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, cs},
                               {gpu::kBindingShadowDepth, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs},
                               {gpu::kBindingShadowPrim, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs},
                               {gpu::kBindingShadowCompare, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, cs},
                               {gpu::kBindingLookupParams, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, cs},
                               {gpu::kBindingLookupOut, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, cs},
                               {gpu::kBindingFaceMask, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, cs}});
    lookup_layout_ = make_pipeline_layout(ctx_, lookup_set_layout_.get(), 0, 0);

    // One pipeline per light kind present, not per light: lights of a kind share their variant.
    for (const Light& light : lights_) {
        gpu::uint kind = light_kind(light.type);
        if (lookup_pipelines_[kind]) continue;
        SpecData spec;
        spec.values = {kind,
                       filter_kind(t_.filter.type),
                       static_cast<std::uint32_t>(t_.filter.size),
                       static_cast<std::uint32_t>(t_.filter.taps),
                       t_.filter.bilinear_taps ? 1u : 0u,
                       t_.bias.receiver_plane ? 1u : 0u,
                       hardware_compare_ ? 1u : 0u,
                       gpu::kModeLookup};
        lookup_pipelines_[kind] = make_lookup_pipeline(ctx_, lookup_layout_.get(), spec);
        if (kind == gpu::kLightPoint) {  // only cube maps are worth a pass that finds the sampled faces
            spec.values[7] = gpu::kModeFaceMask;
            mask_pipeline_ = make_lookup_pipeline(ctx_, lookup_layout_.get(), spec);
        }
    }
}

void Renderer::make_targets() {
    VkImageUsageFlags prim_usage =
        VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    gbuffer_prim_ = create_image(ctx_, kPrimFormat, W_, H_, 1, prim_usage, VK_IMAGE_ASPECT_COLOR_BIT, false);
    gbuffer_depth_ = create_image(ctx_, kCameraDepthFormat, W_, H_, 1, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                                  VK_IMAGE_ASPECT_DEPTH_BIT, false);
    prim_readback_ = create_buffer(ctx_, pixels_ * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT, true);

    bool any_point =
        std::any_of(lights_.begin(), lights_.end(), [](const Light& l) { return l.type == LightType::point; });
    std::uint32_t layers = any_point ? 6 : 1;
    // Without lights nothing samples a map: a 1x1 placeholder keeps descriptors valid.
    std::uint32_t res = lights_.empty() ? 1 : static_cast<std::uint32_t>(t_.resolution);
    shadow_depth_ = create_image(ctx_, vk_format(t_.depth_format), res, res, layers,
                                 VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT,
                                 VK_IMAGE_ASPECT_DEPTH_BIT, true);
    shadow_prim_ =
        create_image(ctx_, kPrimFormat, res, res, layers,
                     VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT, VK_IMAGE_ASPECT_COLOR_BIT, true);
    for (std::uint32_t l = 0; l < layers; ++l) {
        shadow_depth_layers_.push_back(create_layer_view(ctx_, shadow_depth_, l, VK_IMAGE_ASPECT_DEPTH_BIT));
        shadow_prim_layers_.push_back(create_layer_view(ctx_, shadow_prim_, l, VK_IMAGE_ASPECT_COLOR_BIT));
    }
    nearest_ = make_sampler(ctx_, false, false, false);  // texelFetch ignores it; depth and prim share it
    // Point lights clamp inside a face; 2D maps read a lit border.
    compare_ = make_sampler(ctx_, true, hardware_compare_, !any_point);
}

void Renderer::make_light_resources() {
    std::size_t n = lights_.size();
    std::uint32_t sets = static_cast<std::uint32_t>(n + 1);
    std::array<VkDescriptorPoolSize, 4> sizes = {{{VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, sets},
                                                  {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 4 * sets},
                                                  {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 3 * sets},
                                                  {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, sets}}};
    VkDescriptorPoolCreateInfo pi{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    pi.maxSets = sets;
    pi.poolSizeCount = static_cast<std::uint32_t>(sizes.size());
    pi.pPoolSizes = sizes.data();
    VkDescriptorPool pool;
    VK_CHECK(vkCreateDescriptorPool(ctx_.device(), &pi, nullptr, &pool));
    pool_ = UniqueDescriptorPool(ctx_.device(), pool);

    auto allocate_set = [&](VkDescriptorSetLayout layout) {
        VkDescriptorSetAllocateInfo ai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
        ai.descriptorPool = pool_.get();
        ai.descriptorSetCount = 1;
        ai.pSetLayouts = &layout;
        VkDescriptorSet set;
        VK_CHECK(vkAllocateDescriptorSets(ctx_.device(), &ai, &set));
        return set;
    };
    camera_set_ = allocate_set(camera_set_layout_.get());
    VkDescriptorBufferInfo ds_info{double_sided_.buffer.get(), 0, VK_WHOLE_SIZE};
    VkWriteDescriptorSet w =
        descriptor_write(camera_set_, gpu::kBindingDoubleSided, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, nullptr, &ds_info);
    vkUpdateDescriptorSets(ctx_.device(), 1, &w, 0, nullptr);

    std::vector<glm::vec2> disk = poisson_disk(t_.filter.taps);
    const Camera& cam = s_.camera;
    bool persp = cam.type == ProjectionType::perspective;
    glm::dvec2 plane = ndc_to_image_plane(cam, s_.width, s_.height);
    for (std::size_t li = 0; li < n; ++li) {
        const Light& light = lights_[li];
        RasterLightStats ls;
        ls.projection =
            fit_light(light, s_.scene, cam, s_.width, s_.height, t_.fit, t_.resolution, origin_, t_.shadow_distance);
        for (const auto& wmsg : ls.projection.warnings) stats_.warnings.push_back(wmsg);

        gpu::LookupParams p{};
        p.cam_forward = glm::vec4(glm::vec3(cam.forward), persp ? 1.0f : 0.0f);
        p.cam_right = glm::vec4(glm::vec3(cam.right), static_cast<float>(plane.x));
        p.cam_up = glm::vec4(glm::vec3(cam.up), static_cast<float>(plane.y));
        p.image = glm::vec4(s_.width, s_.height, 1.0f / s_.width, 1.0f / s_.height);
        p.light_pos = glm::vec4(glm::vec3(light.position - origin_), 0.0f);
        p.light_dir = glm::vec4(glm::vec3(light.direction), static_cast<float>(std::cos(light.outer_cone_rad)));
        p.bias = glm::vec4(t_.bias.world, t_.bias.normal_offset, t_.bias.shader_depth, t_.bias.constant);
        p.bias2 = glm::vec4(t_.bias.slope, t_.bias.clamp, depth_resolution(t_.depth_format), 0.0f);
        p.map = glm::vec4(t_.resolution, 1.0f / t_.resolution, t_.filter.radius_texels,
                          static_cast<float>(ls.projection.view_proj.size()));
        p.footprint = glm::vec4(ls.projection.metres_per_texel, ls.projection.metres_per_texel_per_metre, 0.0f, 0.0f);
        // PCSS reaches here with area lights only (check_technique_lights), which carry a radius.
        p.pcss = glm::vec4(light.radius, ls.projection.near, ls.projection.far, t_.filter.max_radius_texels);
        for (std::size_t l = 0; l < ls.projection.view_proj.size(); ++l) {
            p.view_proj[l] = glm::mat4(ls.projection.view_proj[l]);
            p.light_axis[l] = glm::vec4(glm::vec3(ls.projection.axis[l]), 0.0f);
        }
        for (std::size_t k = 0; k < disk.size(); ++k) {
            if (k % 2 == 0) {
                p.poisson[k / 2].x = disk[k].x;
                p.poisson[k / 2].y = disk[k].y;
            } else {
                p.poisson[k / 2].z = disk[k].x;
                p.poisson[k / 2].w = disk[k].y;
            }
        }
        params_.push_back(upload(ctx_, &p, sizeof(p), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT));
        outputs_.push_back(
            create_buffer(ctx_, pixels_ * sizeof(gpu::LookupTexel), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true));
        masks_.push_back(create_buffer(ctx_, 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true));
        // Only cube maps are worth a mask pass; a single map is rendered whenever the light exists.
        std::uint32_t initial = light.type == LightType::point ? 0u : 1u;
        std::memcpy(masks_.back().mapped, &initial, 4);
        stats_.lights.push_back(std::move(ls));

        VkDescriptorSet set = allocate_set(lookup_set_layout_.get());
        lookup_sets_.push_back(set);
        VkDescriptorImageInfo gb{VK_NULL_HANDLE, gbuffer_prim_.view.get(), VK_IMAGE_LAYOUT_GENERAL};
        VkDescriptorImageInfo depth{nearest_.get(), shadow_depth_.view.get(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
        VkDescriptorImageInfo prim{nearest_.get(), shadow_prim_.view.get(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
        VkDescriptorImageInfo cmp{compare_.get(), shadow_depth_.view.get(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
        VkDescriptorBufferInfo pos{positions_.buffer.get(), 0, VK_WHOLE_SIZE};
        VkDescriptorBufferInfo idx{indices_.buffer.get(), 0, VK_WHOLE_SIZE};
        VkDescriptorBufferInfo par{params_.back().buffer.get(), 0, VK_WHOLE_SIZE};
        VkDescriptorBufferInfo out{outputs_.back().buffer.get(), 0, VK_WHOLE_SIZE};
        VkDescriptorBufferInfo msk{masks_.back().buffer.get(), 0, VK_WHOLE_SIZE};
        auto write = [&](std::uint32_t binding, VkDescriptorType type, const VkDescriptorImageInfo* ii,
                         const VkDescriptorBufferInfo* bi) { return descriptor_write(set, binding, type, ii, bi); };
        std::array<VkWriteDescriptorSet, 9> writes = {
            write(gpu::kBindingGBufferPrim, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, &gb, nullptr),
            write(gpu::kBindingPositions, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, nullptr, &pos),
            write(gpu::kBindingIndices, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, nullptr, &idx),
            write(gpu::kBindingShadowDepth, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, &depth, nullptr),
            write(gpu::kBindingShadowPrim, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, &prim, nullptr),
            write(gpu::kBindingShadowCompare, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, &cmp, nullptr),
            write(gpu::kBindingLookupParams, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, nullptr, &par),
            write(gpu::kBindingLookupOut, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, nullptr, &out),
            write(gpu::kBindingFaceMask, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, nullptr, &msk)};
        vkUpdateDescriptorSets(ctx_.device(), static_cast<std::uint32_t>(writes.size()), writes.data(), 0, nullptr);
    }

    query_count_ = static_cast<std::uint32_t>(4 + 3 * n);
    VkQueryPoolCreateInfo qi{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
    qi.queryCount = query_count_;
    VkQueryPool qp;
    VK_CHECK(vkCreateQueryPool(ctx_.device(), &qi, nullptr, &qp));
    queries_ = UniqueQueryPool(ctx_.device(), qp);
}

void set_viewport(VkCommandBuffer cmd, std::uint32_t w, std::uint32_t h) {
    VkViewport vp{0, 0, static_cast<float>(w), static_cast<float>(h), 0.0f, 1.0f};
    VkRect2D scissor{{0, 0}, {w, h}};
    vkCmdSetViewport(cmd, 0, 1, &vp);
    vkCmdSetScissor(cmd, 0, 1, &scissor);
}

void begin_rendering(VkCommandBuffer cmd, VkImageView color, VkImageView depth, std::uint32_t w, std::uint32_t h,
                     float depth_clear) {
    VkRenderingAttachmentInfo ca{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    ca.imageView = color;
    ca.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    ca.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    ca.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    ca.clearValue.color.uint32[0] = gpu::kNoPrim;
    VkRenderingAttachmentInfo da{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    da.imageView = depth;
    da.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    da.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    da.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    da.clearValue.depthStencil.depth = depth_clear;
    VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
    ri.renderArea = {{0, 0}, {w, h}};
    ri.layerCount = 1;
    ri.colorAttachmentCount = 1;
    ri.pColorAttachments = &ca;
    ri.pDepthAttachment = &da;
    vkCmdBeginRendering(cmd, &ri);
    set_viewport(cmd, w, h);
}

constexpr VkPipelineStageFlags2 kFragmentTests =
    VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;

void Renderer::record_camera_and_masks(VkCommandBuffer cmd) {
    vkCmdResetQueryPool(cmd, queries_.get(), 0, query_count_);
    vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_TOP_OF_PIPE_BIT, queries_.get(), 0);
    image_barrier(cmd, gbuffer_prim_.image.get(), VK_IMAGE_ASPECT_COLOR_BIT, 1, VK_IMAGE_LAYOUT_UNDEFINED,
                  VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE,
                  VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT);
    image_barrier(cmd, gbuffer_depth_.image.get(), VK_IMAGE_ASPECT_DEPTH_BIT, 1, VK_IMAGE_LAYOUT_UNDEFINED,
                  VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE, kFragmentTests,
                  VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT);
    begin_rendering(cmd, gbuffer_prim_.view.get(), gbuffer_depth_.view.get(), W_, H_, 0.0f);
    if (index_count_ > 0) {
        glm::mat4 vp = camera_matrix(s_.camera, s_.width, s_.height, s_.scene.bounds);
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, camera_pipeline_.get());
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, camera_layout_.get(), 0, 1, &camera_set_, 0,
                                nullptr);
        vkCmdPushConstants(cmd, camera_layout_.get(), VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(vp), &vp);
        vkCmdSetDepthBias(cmd, 0.0f, 0.0f, 0.0f);
        VkDeviceSize zero = 0;
        vkCmdBindVertexBuffers(cmd, 0, 1, positions_.buffer.ptr(), &zero);
        vkCmdBindIndexBuffer(cmd, indices_.buffer.get(), 0, VK_INDEX_TYPE_UINT32);
        vkCmdDrawIndexed(cmd, index_count_, 1, 0, 0, 0);
    }
    vkCmdEndRendering(cmd);
    vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, queries_.get(), 1);

    image_barrier(cmd, gbuffer_prim_.image.get(), VK_IMAGE_ASPECT_COLOR_BIT, 1,
                  VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_GENERAL,
                  VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                  VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_COPY_BIT,
                  VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_TRANSFER_READ_BIT);
    // The lookup descriptors name the shadow map in SHADER_READ_ONLY; make that true before the
    // mask dispatches (which never read it).
    image_barrier(cmd, shadow_depth_.image.get(), VK_IMAGE_ASPECT_DEPTH_BIT, shadow_depth_.layers,
                  VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_2_NONE,
                  VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT);
    image_barrier(cmd, shadow_prim_.image.get(), VK_IMAGE_ASPECT_COLOR_BIT, shadow_prim_.layers,
                  VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_2_NONE,
                  VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT);

    vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, queries_.get(), 2);
    std::uint32_t gx = (W_ + 7) / 8, gy = (H_ + 7) / 8;
    for (std::size_t li = 0; li < lights_.size(); ++li) {
        if (lights_[li].type != LightType::point) continue;  // one layer, sampled unless nothing is lit
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, mask_pipeline_.get());
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, lookup_layout_.get(), 0, 1, &lookup_sets_[li], 0,
                                nullptr);
        vkCmdDispatch(cmd, gx, gy, 1);
    }
    vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, queries_.get(), 3);

    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {W_, H_, 1};
    vkCmdCopyImageToBuffer(cmd, gbuffer_prim_.image.get(), VK_IMAGE_LAYOUT_GENERAL, prim_readback_.buffer.get(), 1,
                           &region);
    memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_COPY_BIT,
                   VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                   VK_ACCESS_2_HOST_READ_BIT);
}

void Renderer::record_light(VkCommandBuffer cmd, std::size_t li) {
    std::uint32_t q = static_cast<std::uint32_t>(4 + 3 * li);
    RasterLightStats& ls = stats_.lights[li];
    std::uint32_t res = static_cast<std::uint32_t>(t_.resolution);
    vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, queries_.get(), q);
    if (ls.layers_sampled != 0) {
        // The previous light's lookup read these images; its contents are not needed again.
        image_barrier(cmd, shadow_depth_.image.get(), VK_IMAGE_ASPECT_DEPTH_BIT, shadow_depth_.layers,
                      VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL,
                      VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_NONE, kFragmentTests,
                      VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT);
        image_barrier(cmd, shadow_prim_.image.get(), VK_IMAGE_ASPECT_COLOR_BIT, shadow_prim_.layers,
                      VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                      VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_NONE,
                      VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT);
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, shadow_pipeline_.get());
        VkDeviceSize zero = 0;
        vkCmdBindVertexBuffers(cmd, 0, 1, positions_.buffer.ptr(), &zero);
        vkCmdBindIndexBuffer(cmd, indices_.buffer.get(), 0, VK_INDEX_TYPE_UINT32);
        for (std::uint32_t layer = 0; layer < ls.projection.view_proj.size(); ++layer) {
            if (!(ls.layers_sampled & (1u << layer))) continue;  // no receiver samples this face
            begin_rendering(cmd, shadow_prim_layers_[layer].get(), shadow_depth_layers_[layer].get(), res, res, 1.0f);
            vkCmdSetDepthBias(cmd, static_cast<float>(t_.bias.constant), static_cast<float>(t_.bias.clamp),
                              static_cast<float>(t_.bias.slope));
            glm::mat4 vp = glm::mat4(ls.projection.view_proj[layer]);
            vkCmdPushConstants(cmd, shadow_layout_.get(), VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(vp), &vp);
            if (index_count_ > 0) vkCmdDrawIndexed(cmd, index_count_, 1, 0, 0, 0);
            vkCmdEndRendering(cmd);
            ++ls.layers_rendered;
        }
        image_barrier(cmd, shadow_depth_.image.get(), VK_IMAGE_ASPECT_DEPTH_BIT, shadow_depth_.layers,
                      VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                      kFragmentTests, VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
                      VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT);
        image_barrier(cmd, shadow_prim_.image.get(), VK_IMAGE_ASPECT_COLOR_BIT, shadow_prim_.layers,
                      VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                      VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                      VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT);
    }
    vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, queries_.get(), q + 1);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, lookup_pipelines_[light_kind(lights_[li].type)].get());
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, lookup_layout_.get(), 0, 1, &lookup_sets_[li], 0,
                            nullptr);
    vkCmdDispatch(cmd, (W_ + 7) / 8, (H_ + 7) / 8, 1);
    vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, queries_.get(), q + 2);
    memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
}

void Renderer::read_timings() {
    std::vector<std::uint64_t> t(query_count_);
    VK_CHECK(vkGetQueryPoolResults(ctx_.device(), queries_.get(), 0, query_count_, t.size() * sizeof(std::uint64_t),
                                   t.data(), sizeof(std::uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
    auto ms = [&](std::uint32_t a, std::uint32_t b) {
        return t[b] >= t[a] ? static_cast<double>(t[b] - t[a]) * ctx_.limits().timestampPeriod * 1e-6 : 0.0;
    };
    stats_.camera_ms = ms(0, 1);
    stats_.mask_ms = ms(2, 3);
    for (std::size_t li = 0; li < lights_.size(); ++li) {
        std::uint32_t q = static_cast<std::uint32_t>(4 + 3 * li);
        stats_.lights[li].shadow_ms = ms(q, q + 1);
        stats_.lights[li].lookup_ms = ms(q + 1, q + 2);
        stats_.shadow_ms += stats_.lights[li].shadow_ms;
        stats_.lookup_ms += stats_.lights[li].lookup_ms;
    }
}

void Renderer::read_back(RasterResult& out) {
    RasterFrame& f = out.frame;
    f.width = s_.width;
    f.height = s_.height;
    f.frame_origin = origin_;
    f.prim.resize(pixels_);
    std::memcpy(f.prim.data(), prim_readback_.mapped, pixels_ * 4);
    f.A.resize(pixels_);
    for (std::size_t i = 0; i < pixels_; ++i) f.A[i] = f.prim[i] == kNoPrimitive ? 0.0f : 1.0f;
    for (std::size_t li = 0; li < lights_.size(); ++li) {
        const auto* texels = static_cast<const gpu::LookupTexel*>(outputs_[li].mapped);
        RasterLightImage img;
        img.V.resize(pixels_);
        img.ref_depth.resize(pixels_);
        img.stored_depth.resize(pixels_);
        img.stored_prim.resize(pixels_);
        img.footprint_m.resize(pixels_);
        img.texel_slope.resize(pixels_);
        img.bias_m.resize(pixels_);
        img.depth_to_m.resize(pixels_);
        img.flags.resize(pixels_);
        for (std::size_t i = 0; i < pixels_; ++i) {
            const gpu::LookupTexel& t = texels[i];
            img.V[i] = t.V;
            img.ref_depth[i] = t.ref_depth;
            img.stored_depth[i] = t.stored_depth;
            img.stored_prim[i] = t.stored_prim;
            img.footprint_m[i] = t.footprint_m;
            img.texel_slope[i] = t.texel_slope;
            img.bias_m[i] = t.bias_m;
            img.depth_to_m[i] = t.depth_to_m;
            img.flags[i] = t.flags;
        }
        f.lights.push_back(std::move(img));
    }
}

RasterResult Renderer::run() {
    auto t0 = SteadyClock::now();
    W_ = static_cast<std::uint32_t>(s_.width);
    H_ = static_cast<std::uint32_t>(s_.height);
    pixels_ = static_cast<std::size_t>(W_) * H_;
    origin_ = s_.camera.eye;
    stats_.device = ctx_.info();
    check_supported();
    upload_scene();
    make_pipelines();
    make_targets();
    make_light_resources();
    stats_.setup_s = seconds_since(t0);

    auto t1 = SteadyClock::now();
    ctx_.submit_and_wait([&](VkCommandBuffer cmd) { record_camera_and_masks(cmd); });
    for (std::size_t li = 0; li < lights_.size(); ++li)
        stats_.lights[li].layers_sampled = *static_cast<const std::uint32_t*>(masks_[li].mapped);
    ctx_.submit_and_wait([&](VkCommandBuffer cmd) {
        for (std::size_t li = 0; li < lights_.size(); ++li) record_light(cmd, li);
    });
    stats_.render_s = seconds_since(t1);

    read_timings();
    RasterResult out;
    read_back(out);
    out.stats = std::move(stats_);
    return out;
}

}  // namespace

RasterResult run_raster(const Scenario& scenario, const Technique& technique, const VulkanContext& ctx) {
    check_technique_lights(technique, scenario.lights, scenario.label + ": technique");  // before any work
    ExpandedLights expanded = expand_area_lights(scenario.lights, technique);
    Renderer r(scenario, expanded.lights, technique, ctx);
    RasterResult drawn = r.run();
    return fold_area_lights(expanded, std::move(drawn));
}

}  // namespace penumbra::raster
