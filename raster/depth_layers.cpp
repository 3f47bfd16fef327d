// Midpoint and second depth (docs/raster.md, "Midpoint and second depth"): the depth_map family's
// `depth_layer` key. Second depth (Wang & Molnar 1994) is the map of back faces alone, what
// `cull: front` draws, so it needs nothing here but the key (parse sets the culling). Midpoint
// depth (Woo, Graphics Gems III, 1992) is a variant of the depth-map core: the shadow pass draws
// the first layer into an image of its own, and a second pass keeps, behind each texel's first
// surface, the midpoint between it and the nearest surface behind it (shaders/peel.frag).
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <tuple>
#include <vector>

#include "raster/cutouts.h"
#include "raster/depth_map.h"
// SPIR-V compiled from shaders/ at build time.
#include "cutout_vert.h"
#include "peel_cutout_frag.h"
#include "peel_frag.h"
#include "shadow_vert.h"

namespace penumbra::raster {

namespace {

constexpr const char* kSecondDepth =
    "midpoint depth's second pass per drawn map layer: every triangle again, fragments at or in front of the first "
    "layer discarded, the rest writing the midpoint between the first layer and themselves (depth test less)";

// The second pass's set: the first depth layer, read by texelFetch; a scene with cut-outs adds
// their bindings (raster/cutouts.h).
constexpr std::array<BindingDecl, 1> kPeelBindings = {{{0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER}}};
std::vector<BindingDecl> peel_bindings(const SceneOnGpu& s) {
    std::vector<BindingDecl> b(kPeelBindings.begin(), kPeelBindings.end());
    if (s.has_cutouts) b.insert(b.end(), cutout_bindings().begin(), cutout_bindings().end());
    return b;
}
struct PeelPush {
    glm::mat4 view_proj;
    std::uint32_t layer;
    float epsilon;  // depth units: the first layer's own surface, drawn again, is within it
};

bool midpoint(const Technique& t) {
    return t.depth_layer == DepthLayer::midpoint;
}

class MidpointVariant final : public DepthMapVariant {
  public:
    explicit MidpointVariant(const SceneOnGpu& scene)
        : s_(scene),
          ctx_(scene.ctx),
          peel_sets_(scene.ctx, peel_bindings(scene),
                     scene.has_cutouts ? VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT
                                       : VK_SHADER_STAGE_FRAGMENT_BIT) {
        peel_layout_ = make_pipeline_layout(ctx_, peel_sets_.layout(), sizeof(PeelPush),
                                            VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT);
        nearest_ = make_sampler(ctx_, false, false, false);
    }

    // The midpoint keeps two depth layers a texel (the first, and the midpoint the lookup reads).
    int map_copies(const Technique& t) const override { return midpoint(t) ? 2 : 1; }

    // Per map: the first layer, and the second pass's triangle ids (its pipeline has a colour
    // target; nothing reads them).
    void ensure_map_resources(const Technique& t, std::span<const MapShape> maps, std::span<const GpuImage* const>,
                              bool) override {
        if (!midpoint(t)) {
            if (!shapes_.empty()) {
                images_.clear();
                arena_ = MemoryArena(ctx_);
                shapes_.clear();
            }
            return;
        }
        if (std::equal(maps.begin(), maps.end(), shapes_.begin(), shapes_.end())) return;
        images_.clear();
        arena_ = MemoryArena(ctx_);
        images_.resize(maps.size());
        for (std::size_t i = 0; i < maps.size(); ++i) {
            const MapShape& m = maps[i];
            arena_.add(images_[i].first, m.format, m.resolution, m.resolution, m.layers,
                       VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT,
                       VK_IMAGE_ASPECT_DEPTH_BIT, true);
            arena_.add(images_[i].second_prim, kPrimFormat, m.resolution, m.resolution, m.layers,
                       VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT, VK_IMAGE_ASPECT_COLOR_BIT, true);
        }
        arena_.commit();
        for (Images& m : images_)
            for (std::uint32_t l = 0; l < m.first.layers; ++l) {
                m.first_layers.push_back(create_layer_view(ctx_, m.first, l, VK_IMAGE_ASPECT_DEPTH_BIT));
                m.second_prim_layers.push_back(create_layer_view(ctx_, m.second_prim, l, VK_IMAGE_ASPECT_COLOR_BIT));
            }
        peel_sets_.reserve(images_.size());
        for (std::size_t i = 0; i < images_.size(); ++i) {
            std::vector<DescriptorResource> r(1);
            r[0].image = {nearest_.get(), images_[i].first.view.get(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
            if (s_.has_cutouts) append_cutout_resources(s_, r);
            peel_sets_.write(i, r);
        }
        shapes_.assign(maps.begin(), maps.end());
    }

    // The first pass draws the first layer, read by the second pass, which draws the core's map.
    VkImageView shadow_target(const Technique& t, std::size_t map, std::uint32_t layer) const override {
        return midpoint(t) ? images_[map].first_layers[layer].get() : VK_NULL_HANDLE;
    }
    void before_shadow(VkCommandBuffer cmd, const Technique& t, std::size_t map) override {
        if (!midpoint(t)) return;
        const GpuImage& first = images_[map].first;
        image_barrier(cmd, first.image.get(), VK_IMAGE_ASPECT_DEPTH_BIT, first.layers, VK_IMAGE_LAYOUT_UNDEFINED,
                      VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
                      VK_ACCESS_2_NONE, kFragmentTests,
                      VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT);
    }

    // Every sampled layer drawn again into the core's map, keeping behind each texel's first
    // layer the nearest surface's midpoint with it. The first layer was just drawn (with the
    // technique's bias, if any); this pass has none (the midpoint is the bias).
    void record_map_pass(VkCommandBuffer cmd, const Technique& t, const MapTargets& map) override {
        if (!midpoint(t)) return;
        Images& m = images_[map.map_index];
        const std::uint32_t res = map.depth->width;
        image_barrier(cmd, m.first.image.get(), VK_IMAGE_ASPECT_DEPTH_BIT, m.first.layers,
                      VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                      kFragmentTests, VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
                      VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT);
        image_barrier(cmd, m.second_prim.image.get(), VK_IMAGE_ASPECT_COLOR_BIT, m.second_prim.layers,
                      VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                      VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_NONE,
                      VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT);
        VkDescriptorSet set = peel_sets_[map.map_index];
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, peel_layout_.get(), 0, 1, &set, 0, nullptr);
        // Two depth quanta: the first layer's own surface drawn again lies within one of it (a UNORM
        // map rounds it), and never behind by more.
        const float epsilon = static_cast<float>(2 * std::max(depth_resolution(t.depth_format), std::ldexp(1.0, -22)));
        for (std::uint32_t layer = 0; layer < map.projection->view_proj.size(); ++layer) {
            if (!(map.layers_sampled & (1u << layer))) continue;
            begin_rendering(cmd, m.second_prim_layers[layer].get(), map.depth_layers[layer].get(), res, res, 1.0f);
            vkCmdSetDepthBias(cmd, 0.0f, 0.0f, 0.0f);
            const PeelPush push{glm::mat4(map.projection->view_proj[layer]), layer, epsilon};
            vkCmdPushConstants(cmd, peel_layout_.get(), VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                               sizeof(push), &push);
            draw_casters(cmd, s_, t, [&](Cull c, bool cutout) { return peel_pipeline(t, c, cutout); });
            vkCmdEndRendering(cmd);
        }
    }

    // The second pass's time runs from the shadow pass's end to the map being readable.
    std::uint32_t timed_passes() const override { return 1; }
    void record_after_map(VkCommandBuffer cmd, const Technique&, const MapTargets&, PassMarks& marks) override {
        marks.mark(cmd);
    }
    void add_times(const Technique& t, const std::function<double(std::uint32_t)>& ms,
                   PassTimes& times) const override {
        if (midpoint(t)) times.add("second_depth", ms(0), kSecondDepth);
    }

  private:
    struct Images {
        GpuImage first, second_prim;
        std::vector<UniqueImageView> first_layers, second_prim_layers;
    };

    // The technique's culling (`cull`: draw_casters' per run), depth test less.
    // A cut-out's runs peel with the alpha test (shaders/peel_cutout.frag).
    VkPipeline peel_pipeline(const Technique& t, Cull cull, bool cutout) {
        const double blend_cutoff = cutout && t.blend == Blend::cutout ? t.blend_cutoff : -1;
        const bool mipmaps = cutout && t.alpha_mipmaps;
        UniquePipeline& p = peel_pipelines_[{vk_format(t.depth_format), cull, cutout, blend_cutoff, mipmaps}];
        if (!p) {
            GraphicsSetup g{cutout ? kCutoutVert : kShadowVert,
                            cutout ? sizeof(kCutoutVert) : sizeof(kShadowVert),
                            cutout ? kPeelCutoutFrag : kPeelFrag,
                            cutout ? sizeof(kPeelCutoutFrag) : sizeof(kPeelFrag),
                            vk_format(t.depth_format),
                            VK_COMPARE_OP_LESS,
                            vk_cull(cull),
                            VK_FRONT_FACE_CLOCKWISE,
                            true,
                            false};
            if (cutout) g.frag_spec = alpha_spec(t);
            p = make_graphics_pipeline(ctx_, peel_layout_.get(), g);
        }
        return p.get();
    }

    const SceneOnGpu& s_;
    const VulkanContext& ctx_;
    DescriptorSets peel_sets_;
    UniquePipelineLayout peel_layout_;
    UniqueSampler nearest_;
    std::map<std::tuple<VkFormat, Cull, bool, double, bool>, UniquePipeline> peel_pipelines_;
    // The arena before what is bound to it: destroyed after it.
    MemoryArena arena_;
    std::vector<Images> images_;
    std::vector<MapShape> shapes_;  // what images_ were made for (empty: none)
};

}  // namespace

std::unique_ptr<DepthMapVariant> make_midpoint_variant(const SceneOnGpu& scene) {
    return std::make_unique<MidpointVariant>(scene);
}

}  // namespace penumbra::raster
