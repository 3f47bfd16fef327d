#include "raster/gpu_passes.h"

#include <algorithm>
#include <cstring>

#include "shaders/penumbra_shared.h"

namespace penumbra::raster {

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
        // A fence wait orders later submissions but makes no device write visible to them.
        memory_barrier(
            cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
            VK_PIPELINE_STAGE_2_VERTEX_ATTRIBUTE_INPUT_BIT | VK_PIPELINE_STAGE_2_INDEX_INPUT_BIT |
                VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT |
                VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
            VK_ACCESS_2_VERTEX_ATTRIBUTE_READ_BIT | VK_ACCESS_2_INDEX_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
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
    b.subresourceRange = {aspect, 0, VK_REMAINING_MIP_LEVELS, 0, layers};
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

UniquePipeline make_graphics_pipeline(const VulkanContext& ctx, VkPipelineLayout layout, const GraphicsSetup& g) {
    // No fragment shader: a depth-only pass without a colour target.
    const bool colour = g.frag != nullptr && g.colour_format != VK_FORMAT_UNDEFINED;
    UniqueShaderModule vs = make_module(ctx, g.vert, g.vert_bytes);
    UniqueShaderModule fs = g.frag ? make_module(ctx, g.frag, g.frag_bytes) : UniqueShaderModule();
    UniqueShaderModule gs = g.geom ? make_module(ctx, g.geom, g.geom_bytes) : UniqueShaderModule();
    VkPipelineShaderStageCreateInfo stages[3] = {{VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO},
                                                 {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO},
                                                 {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO}};
    std::uint32_t stage_count = 0;
    auto add_stage = [&](VkShaderStageFlagBits stage, VkShaderModule module) {
        stages[stage_count].stage = stage;
        stages[stage_count].module = module;
        stages[stage_count].pName = "main";
        ++stage_count;
    };
    add_stage(VK_SHADER_STAGE_VERTEX_BIT, vs.get());
    if (g.geom) add_stage(VK_SHADER_STAGE_GEOMETRY_BIT, gs.get());
    if (g.frag) add_stage(VK_SHADER_STAGE_FRAGMENT_BIT, fs.get());
    std::vector<VkSpecializationMapEntry> entries(g.frag_spec.size());
    for (std::uint32_t i = 0; i < entries.size(); ++i) entries[i] = {i, i * 4, 4};
    const VkSpecializationInfo spec{static_cast<std::uint32_t>(entries.size()), entries.data(),
                                    g.frag_spec.size() * sizeof(std::uint32_t), g.frag_spec.data()};
    if (g.frag && !g.frag_spec.empty()) stages[stage_count - 1].pSpecializationInfo = &spec;

    const bool vec4 = g.vertex_input == VertexInput::vec4;
    VkVertexInputBindingDescription binding{0, (vec4 ? 4 : 3) * static_cast<std::uint32_t>(sizeof(float)),
                                            VK_VERTEX_INPUT_RATE_VERTEX};
    VkVertexInputAttributeDescription attribute{0, 0, vec4 ? VK_FORMAT_R32G32B32A32_SFLOAT : VK_FORMAT_R32G32B32_SFLOAT,
                                                0};
    VkPipelineVertexInputStateCreateInfo vi{VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
    if (g.vertex_input != VertexInput::none) {
        vi.vertexBindingDescriptionCount = 1;
        vi.pVertexBindingDescriptions = &binding;
        vi.vertexAttributeDescriptionCount = 1;
        vi.pVertexAttributeDescriptions = &attribute;
    }
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
    ds.depthTestEnable = g.depth_test;
    ds.depthWriteEnable = g.depth_write;
    ds.depthCompareOp = g.depth_compare;
    ds.stencilTestEnable = g.stencil_test;
    ds.front = g.front;
    ds.back = g.back;
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
    ri.colorAttachmentCount = colour ? 1 : 0;
    ri.pColorAttachmentFormats = &g.colour_format;
    ri.depthAttachmentFormat = g.depth_format;
    if (g.stencil_attachment) ri.stencilAttachmentFormat = g.depth_format;

    VkGraphicsPipelineCreateInfo ci{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO};
    ci.pNext = &ri;
    ci.stageCount = stage_count;
    ci.pStages = stages;
    ci.pVertexInputState = &vi;
    ci.pInputAssemblyState = &ia;
    ci.pViewportState = &vp;
    ci.pRasterizationState = &rs;
    ci.pMultisampleState = &ms;
    ci.pDepthStencilState = &ds;
    ci.pColorBlendState = colour ? &cb : nullptr;
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

UniqueSampler make_sampler(const VulkanContext& ctx, bool compare, bool linear, bool clamp_to_border, bool reversed_z) {
    VkSamplerCreateInfo ci{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
    ci.magFilter = ci.minFilter = linear ? VK_FILTER_LINEAR : VK_FILTER_NEAREST;
    ci.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
    ci.addressModeU = ci.addressModeV = ci.addressModeW =
        clamp_to_border ? VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_BORDER : VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    // Outside the map reads as lit: the far plane, 1 (0 with reversed Z, compared greater-or-equal).
    ci.borderColor = reversed_z ? VK_BORDER_COLOR_FLOAT_TRANSPARENT_BLACK : VK_BORDER_COLOR_FLOAT_OPAQUE_WHITE;
    ci.compareEnable = compare;
    ci.compareOp = reversed_z ? VK_COMPARE_OP_GREATER_OR_EQUAL : VK_COMPARE_OP_LESS_OR_EQUAL;
    ci.maxLod = 0.0f;
    VkSampler s;
    VK_CHECK(vkCreateSampler(ctx.device(), &ci, nullptr, &s));
    return UniqueSampler(ctx.device(), s);
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
    ri.colorAttachmentCount = color != VK_NULL_HANDLE ? 1 : 0;  // none: a depth-only pass
    ri.pColorAttachments = &ca;
    ri.pDepthAttachment = &da;
    vkCmdBeginRendering(cmd, &ri);
    set_viewport(cmd, w, h);
}

UniqueDescriptorSetLayout make_set_layout(const VulkanContext& ctx, std::span<const BindingDecl> decls,
                                          VkShaderStageFlags stages) {
    std::vector<VkDescriptorSetLayoutBinding> bindings;
    for (const BindingDecl& d : decls) bindings.push_back({d.binding, d.type, 1, stages, nullptr});
    VkDescriptorSetLayoutCreateInfo ci{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    ci.bindingCount = static_cast<std::uint32_t>(bindings.size());
    ci.pBindings = bindings.data();
    VkDescriptorSetLayout l;
    VK_CHECK(vkCreateDescriptorSetLayout(ctx.device(), &ci, nullptr, &l));
    return UniqueDescriptorSetLayout(ctx.device(), l);
}

DescriptorSets::DescriptorSets(const VulkanContext& ctx, std::span<const BindingDecl> decls, VkShaderStageFlags stages)
    : ctx_(&ctx), decls_(decls.begin(), decls.end()), layout_(make_set_layout(ctx, decls, stages)) {}

void DescriptorSets::reserve(std::size_t count) {
    if (count <= sets_.size()) return;
    const std::size_t capacity = std::max<std::size_t>(count, 2 * sets_.size());
    std::vector<VkDescriptorPoolSize> sizes;
    for (const BindingDecl& d : decls_) {
        auto it = std::find_if(sizes.begin(), sizes.end(), [&](const auto& s) { return s.type == d.type; });
        if (it == sizes.end()) it = sizes.insert(sizes.end(), {d.type, 0});
        it->descriptorCount += static_cast<std::uint32_t>(capacity);
    }
    VkDescriptorPoolCreateInfo pi{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    pi.maxSets = static_cast<std::uint32_t>(capacity);
    pi.poolSizeCount = static_cast<std::uint32_t>(sizes.size());
    pi.pPoolSizes = sizes.data();
    VkDescriptorPool pool;
    VK_CHECK(vkCreateDescriptorPool(ctx_->device(), &pi, nullptr, &pool));
    pool_ = UniqueDescriptorPool(ctx_->device(), pool);  // frees the sets of the old pool
    std::vector<VkDescriptorSetLayout> layouts(capacity, layout_.get());
    sets_.assign(capacity, VK_NULL_HANDLE);
    VkDescriptorSetAllocateInfo ai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    ai.descriptorPool = pool_.get();
    ai.descriptorSetCount = static_cast<std::uint32_t>(capacity);
    ai.pSetLayouts = layouts.data();
    VK_CHECK(vkAllocateDescriptorSets(ctx_->device(), &ai, sets_.data()));
}

void DescriptorSets::write(std::size_t index, std::span<const DescriptorResource> resources) const {
    std::vector<VkWriteDescriptorSet> writes;
    for (std::size_t k = 0; k < decls_.size(); ++k) {
        VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
        w.dstSet = sets_[index];
        w.dstBinding = decls_[k].binding;
        w.descriptorCount = 1;
        w.descriptorType = decls_[k].type;
        w.pImageInfo = &resources[k].image;
        w.pBufferInfo = &resources[k].buffer;
        writes.push_back(w);
    }
    vkUpdateDescriptorSets(ctx_->device(), static_cast<std::uint32_t>(writes.size()), writes.data(), 0, nullptr);
}

void begin_depth_stencil_rendering(VkCommandBuffer cmd, VkImageView colour, VkImageView depth_stencil, std::uint32_t w,
                                   std::uint32_t h, bool clear_depth, bool clear_stencil) {
    VkRenderingAttachmentInfo ca{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    ca.imageView = colour;
    ca.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    ca.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    ca.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    VkRenderingAttachmentInfo da{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    da.imageView = depth_stencil;
    da.imageLayout = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
    da.loadOp = clear_depth ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD;
    da.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    da.clearValue.depthStencil = {0.0f, 0};
    VkRenderingAttachmentInfo sa = da;
    sa.loadOp = clear_stencil ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD;
    VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
    ri.renderArea = {{0, 0}, {w, h}};
    ri.layerCount = 1;
    ri.colorAttachmentCount = colour != VK_NULL_HANDLE ? 1 : 0;
    ri.pColorAttachments = &ca;
    ri.pDepthAttachment = &da;
    ri.pStencilAttachment = &sa;
    vkCmdBeginRendering(cmd, &ri);
    set_viewport(cmd, w, h);
}

void GpuTimestamps::ensure(std::uint32_t count) {
    if (pool_ && capacity_ >= count) return;
    VkQueryPoolCreateInfo qi{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
    qi.queryCount = std::max(count, 1u);
    VkQueryPool qp;
    VK_CHECK(vkCreateQueryPool(ctx_->device(), &qi, nullptr, &qp));
    pool_ = UniqueQueryPool(ctx_->device(), qp);
    capacity_ = qi.queryCount;
    ticks_.assign(capacity_, 0);
}

void GpuTimestamps::reset(VkCommandBuffer cmd, std::uint32_t first, std::uint32_t count) const {
    if (count > 0) vkCmdResetQueryPool(cmd, pool_.get(), first, count);
}

void GpuTimestamps::write(VkCommandBuffer cmd, std::uint32_t query, VkPipelineStageFlags2 stage) const {
    vkCmdWriteTimestamp2(cmd, stage, pool_.get(), query);
}

void GpuTimestamps::read(std::uint32_t first, std::uint32_t count) {
    if (count == 0) return;
    VK_CHECK(vkGetQueryPoolResults(ctx_->device(), pool_.get(), first, count, count * sizeof(std::uint64_t),
                                   ticks_.data() + first, sizeof(std::uint64_t),
                                   VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
}

double GpuTimestamps::ms(std::uint32_t a, std::uint32_t b) const {
    return ticks_to_ms(*ctx_, ticks_[a], ticks_[b]);
}

double ticks_to_ms(const VulkanContext& ctx, std::uint64_t a, std::uint64_t b) {
    return b >= a ? static_cast<double>(b - a) * ctx.limits().timestampPeriod * 1e-6 : 0.0;
}

}  // namespace penumbra::raster
