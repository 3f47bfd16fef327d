// The depth-map core (raster/depth_map.h; docs/raster.md): one depth map per light (six cube faces
// for a point light) drawn with the technique's fit, format, culling and hardware depth bias,
// then one compute lookup per light that applies the shader biases and the filter (none, 2x2
// compare, PCF, Poisson, Vogel, PCSS) and writes V with the lookups behind it. A render with lookups
// (the diagnostic one) also stores the triangle id per map texel for the acne rule; a V-only
// render (the production one) draws depth alone, the pass an engine pays. Variants (cascades,
// moments, midpoint and second depth) change it through the hooks of DepthMapVariant, each in its
// family's file. Everything it builds is cached for the session's next render: pipelines by their
// specialisation, a map per light (one map for all when they would not fit kMapBudgetBytes) by
// size and format, per-light buffers and descriptor sets by light count; a map whose inputs did
// not change is not drawn again.
#include "raster/depth_map.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>
#include <optional>
#include <span>
#include <tuple>

#include "common/camera.h"
#include "common/errors.h"
#include "common/memory_estimate.h"
#include "common/stopwatch.h"
#include "raster/area_lights.h"
#include "raster/cutouts.h"
#include "raster/surface_seen.h"
#include "shaders/penumbra_shared.h"
// SPIR-V compiled from shaders/ at build time.
#include "caster_cutout_geom.h"
#include "caster_cutout_vert.h"
#include "caster_geom.h"
#include "caster_vert.h"
#include "cutout_vert.h"
#include "lookup_depth_map_comp.h"
#include "shadow_cutout_depth_frag.h"
#include "shadow_cutout_frag.h"
#include "shadow_frag.h"
#include "shadow_vert.h"

namespace penumbra::raster {

static_assert(gpu::kFlagSurface == kRasterSurface && gpu::kFlagBackFacing == kRasterBackFacing &&
              gpu::kFlagOutsideCone == kRasterOutsideCone && gpu::kFlagOutsideMap == kRasterOutsideMap);
static_assert(sizeof(gpu::LookupTexel) == 36);

VkFormat vk_format(DepthFormat f) {
    switch (f) {
        case DepthFormat::d16: return VK_FORMAT_D16_UNORM;
        case DepthFormat::d24: return VK_FORMAT_X8_D24_UNORM_PACK32;
        case DepthFormat::d32: return VK_FORMAT_D32_SFLOAT;
    }
    return VK_FORMAT_D32_SFLOAT;
}

std::uint64_t depth_texel_bytes(DepthFormat f) {
    return f == DepthFormat::d16 ? 2 : 4;
}

// Light maps have no y flip, which mirrors the winding: counter-clockwise as seen from the light
// is VK_FRONT_FACE_CLOCKWISE with these (pinned by the culling test).
void draw_casters(VkCommandBuffer cmd, const SceneOnGpu& scene, const Technique& t,
                  const std::function<VkPipeline(Cull, bool alpha_test)>& pipeline) {
    if (t.cull != Cull::material && !scene.has_cutouts) {
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline(t.cull, false));
        if (scene.index_count > 0) vkCmdDrawIndexed(cmd, scene.index_count, 1, 0, 0, 0);
        return;
    }
    VkPipeline bound = VK_NULL_HANDLE;
    for (const SceneOnGpu::SidedRun& run : scene.sided_runs) {
        const Cull cull = t.cull != Cull::material ? t.cull : run.double_sided ? Cull::none : t.single_sided_cull;
        if (run.alpha == AlphaMode::blend && t.blend == Blend::none) continue;  // blended materials cast nothing
        const bool alpha_test =
            run.alpha == AlphaMode::mask || (run.alpha == AlphaMode::blend && t.blend == Blend::cutout);
        VkPipeline p = pipeline(cull, alpha_test);
        if (p != bound) vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, bound = p);
        // The instance starts at the run's first triangle: the shaders add it to gl_PrimitiveID.
        vkCmdDrawIndexed(cmd, 3 * run.count, 1, 3 * run.first, 0, run.first);
    }
}

VkCullModeFlags vk_cull(Cull c) {
    // Cull::material is drawn run by run (DepthMapCore::draw_casters), each run with none or the
    // single-sided side: never one mode.
    return c == Cull::back ? VK_CULL_MODE_BACK_BIT : c == Cull::front ? VK_CULL_MODE_FRONT_BIT : VK_CULL_MODE_NONE;
}

UniquePipeline make_compute_pipeline(const VulkanContext& ctx, VkPipelineLayout layout, const std::uint32_t* code,
                                     std::size_t bytes, std::span<const std::uint32_t> spec) {
    UniqueShaderModule cs = make_module(ctx, code, bytes);
    std::vector<VkSpecializationMapEntry> entries(spec.size());
    for (std::uint32_t i = 0; i < spec.size(); ++i) entries[i] = {i, i * 4, 4};
    VkSpecializationInfo si{static_cast<std::uint32_t>(entries.size()), entries.data(), spec.size_bytes(), spec.data()};
    VkComputePipelineCreateInfo ci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    ci.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
    ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    ci.stage.module = cs.get();
    ci.stage.pName = "main";
    ci.stage.pSpecializationInfo = spec.empty() ? nullptr : &si;
    ci.layout = layout;
    VkPipeline p;
    VK_CHECK(vkCreateComputePipelines(ctx.device(), VK_NULL_HANDLE, 1, &ci, nullptr, &p));
    return UniquePipeline(ctx.device(), p);
}

gpu::uint filter_kind(FilterType f) {
    switch (f) {
        case FilterType::none: return gpu::kFilterNone;
        case FilterType::hw2x2: return gpu::kFilterHw2x2;
        case FilterType::pcf: return gpu::kFilterPcf;
        case FilterType::poisson: return gpu::kFilterPoisson;
        case FilterType::pcss: return gpu::kFilterPcss;
        case FilterType::vogel: return gpu::kFilterVogel;
    }
    return gpu::kFilterNone;
}

namespace {

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

gpu::uint normal_factor_kind(NormalFactor f) {
    switch (f) {
        case NormalFactor::none: return gpu::kNormalFactorNone;
        case NormalFactor::one_minus_ndotl: return gpu::kNormalFactorOneMinusNdotL;
        case NormalFactor::sin: return gpu::kNormalFactorSin;
    }
    return gpu::kNormalFactorNone;
}

// A layer's matrix as the map is drawn and read: reversed_z maps depth z to 1 - z (clip z to
// w - z), as an engine's reverse-Z projection does, so the stored depths keep float's finer
// steps near 0 for the far end.
glm::dmat4 map_view_proj(const Technique& t, const glm::dmat4& view_proj) {
    if (!t.reversed_z) return view_proj;
    glm::dmat4 flip(1.0);
    flip[2][2] = -1.0;  // z' = w - z: column 2 row 2 is -1, column 3 row 2 is 1
    flip[3][2] = 1.0;
    return flip * view_proj;
}

// The caster offsets a technique draws its map with (shadow_bias.geom), all zero by default.
bool has_caster_offsets(const Bias& b) {
    const CasterBias& c = b.caster;
    return c.world != 0 || c.world_texels != 0 || c.normal != 0 || c.normal_texels != 0 || c.depth != 0;
}

using SpecData = std::array<std::uint32_t, 8>;  // indexed by gpu::kSpec*

// The lookup set, declared once: the layout, the pool and the writes come from this table.
constexpr std::array<BindingDecl, 11> kLookupBindings = {{
    {gpu::kBindingGBufferPrim, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE},
    {gpu::kBindingPositions, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
    {gpu::kBindingIndices, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
    {gpu::kBindingShadowDepth, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER},
    {gpu::kBindingShadowPrim, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER},
    {gpu::kBindingShadowCompare, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER},
    {gpu::kBindingLookupParams, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER},
    {gpu::kBindingLookupOut, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
    {gpu::kBindingFaceMask, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
    {gpu::kBindingVisibilityOut, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
    {gpu::kBindingFamilyImage, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER},
}};

// Everything a shadow pass's map depends on: equal keys draw equal maps.
struct MapContent {
    std::vector<glm::dmat4> view_proj;
    std::uint32_t layers = 0;
    int resolution = 0;
    DepthFormat format = DepthFormat::d32;
    Cull cull = Cull::back, single_sided_cull = Cull::back;
    double constant = 0, slope = 0, clamp = 0;
    DepthLayer depth_layer = DepthLayer::first;
    std::vector<double> constant_scale;  // per layer: DepthMapVariant::constant_scale
    bool reversed_z = false;
    CasterBias caster;
    bool operator==(const MapContent&) const = default;
};

// Maps of all lights together up to this size get a map each, kept between renders; beyond it
// the lights share one map, drawn again for each light.
constexpr std::uint64_t kMapBudgetBytes = kShadowMapBudget;  // common/memory_estimate.h: the estimate follows it

// What each timed pass includes (raster.json's gpu_passes). The copy of the lookup's output
// to the host is not timed.
constexpr const char* kShadowWithIds =
    "depth pass per drawn map layer with the technique's depth bias, also writing the triangle id per texel "
    "(R32_UINT colour target, for the acne rule): the diagnostic shadow pass";
constexpr const char* kShadowDepthOnly =
    "depth-only pass per drawn map layer with the technique's depth bias (vertex shader only, no colour "
    "target): the production shadow pass, as an engine draws it";
constexpr const char* kLookupDiagnostic =
    "compute pass per light: V and every diagnostic lookup (36 bytes a pixel), without the copy to the host";
constexpr const char* kLookupV = "compute pass per light: V alone (4 bytes a pixel), without the copy to the host";

// Timestamps per light: before the shadow pass, after it, one after each of the variants'
// passes (DepthMapVariant::timed_passes), after the lookup. Two more, first, for the face masks.
constexpr std::uint32_t kCoreQueriesPerLight = 3;
constexpr std::uint32_t kMaskQueries = 2;

class DepthMapCore final : public TechniqueFamily {
  public:
    DepthMapCore(const SceneOnGpu& scene, DepthMapVariants variants);
    void render(const Technique& t, std::span<const Light> lights, const RenderOptions& options, RasterFrame& frame,
                RasterStats& stats) override;

  private:
    // Per light: its uniform parameters, the cube-face mask, and its output: every lookup
    // (36 bytes a pixel) or V alone (4 bytes), as the render asks, with a host copy on GPUs.
    struct Slot {
        GpuBuffer params, mask, output, output_host;
    };
    // A light's shadow map (or every light's, when they share one) and what it holds.
    struct LightMap {
        GpuImage depth, prim;
        std::vector<UniqueImageView> depth_layers, prim_layers;
        std::optional<MapContent> content;  // set: drawn, in SHADER_READ_ONLY_OPTIMAL
        bool triangle_ids = false;          // `prim` holds the triangle ids of `content` (else stale)
        bool read_only = false;             // in SHADER_READ_ONLY_OPTIMAL (else never written: UNDEFINED)
    };

    void check_supported(const Technique& t, RasterStats& stats);
    std::uint32_t layers_of(const Technique& t, const Light& l) const;
    VkPipeline shadow_pipeline(const Technique& t, bool triangle_ids, Cull cull, bool cutout);
    LookupShader shader_for(const Technique& t, const Light& l) const;
    SpecData lookup_spec(const Technique& t, const LookupShader& shader, gpu::uint kind, gpu::uint mode) const;
    VkPipeline lookup_pipeline(const Technique& t, const Light& l, gpu::uint kind, gpu::uint mode);
    void make_lookup_pipelines(const Technique& t, std::span<const Light> lights, const RenderOptions& options);
    VkSampler compare_sampler(bool linear, bool clamp_to_border, bool reversed_z);
    gpu::ShadowPush caster_push(const Technique& t, const Light& light, const LightProjection& projection,
                                std::uint32_t layer) const;
    void ensure_maps(const Technique& t, std::span<const Light> lights);
    std::size_t map_of_index(std::size_t li) const { return maps_.size() == 1 ? 0 : li; }
    LightMap& map_of(std::size_t li) { return maps_[map_of_index(li)]; }
    void record_map_layouts(VkCommandBuffer cmd);
    void ensure_slots(std::size_t n, bool lookups);
    // What the lookup pass writes per light: every lookup, or V alone.
    VkDeviceSize output_bytes(bool lookups) const {
        return s_.pixels * (lookups ? sizeof(gpu::LookupTexel) : sizeof(float));
    }
    std::uint32_t queries_per_light() const { return kCoreQueriesPerLight + variant_passes_; }
    gpu::LookupParams light_params(const Technique& t, const Light& light, const LightProjection& projection) const;
    void record_masks(VkCommandBuffer cmd, std::span<const Light> lights, const Technique& t);
    void record_light(VkCommandBuffer cmd, const Technique& t, const Light& light, std::size_t li, RasterLightStats& ls,
                      const RenderOptions& options);
    RasterLightImage read_back(std::size_t li, bool lookups) const;
    const GpuBuffer& host_copy(const Slot& slot) const;

    const SceneOnGpu& s_;
    const VulkanContext& ctx_;
    DepthMapVariants variants_;
    std::uint32_t variant_passes_ = 0;  // timed passes of all variants together
    bool hardware_compare_ = false;
    bool direct_readback_ = false;  // the device shares host memory: the lookup writes where the CPU reads

    DescriptorSets sets_;
    UniquePipelineLayout shadow_layout_, caster_layout_, lookup_layout_;
    // By format, culling, hardware bias, triangle ids, reversed Z, caster offsets, alpha test and
    // the blend cutoff it tests blended materials at, alpha.mipmaps.
    std::map<std::tuple<VkFormat, Cull, bool, bool, bool, bool, bool, double, bool>, UniquePipeline> shadow_pipelines_;
    std::map<std::pair<const std::uint32_t*, SpecData>, UniquePipeline> lookup_pipelines_;
    std::map<std::tuple<bool, bool, bool>, UniqueSampler> compare_samplers_;
    UniqueSampler nearest_;

    // Each arena before what is bound to it: destroyed after it.
    MemoryArena maps_arena_, slots_arena_;
    std::vector<LightMap> maps_;
    std::vector<glm::vec2> disk_;
    std::vector<Slot> slots_;
    bool slots_hold_lookups_ = false;
    GpuTimestamps timer_;
};

DepthMapCore::DepthMapCore(const SceneOnGpu& scene, DepthMapVariants variants)
    : s_(scene),
      ctx_(scene.ctx),
      variants_(std::move(variants)),
      direct_readback_(scene.ctx.info().type == "cpu" || scene.ctx.info().type == "integrated-gpu"),
      sets_(scene.ctx, kLookupBindings, VK_SHADER_STAGE_COMPUTE_BIT),
      timer_(scene.ctx) {
    for (const auto& v : variants_) variant_passes_ += v->timed_passes();
    // A scene with cut-outs binds their set for every shadow pipeline (shaders/cutout.glsl).
    shadow_layout_ = make_pipeline_layout(ctx_, s_.has_cutouts ? s_.cutout_set->layout() : VK_NULL_HANDLE,
                                          sizeof(glm::mat4), VK_SHADER_STAGE_VERTEX_BIT);
    caster_layout_ = make_pipeline_layout(ctx_, s_.has_cutouts ? s_.cutout_set->layout() : VK_NULL_HANDLE,
                                          sizeof(gpu::ShadowPush), VK_SHADER_STAGE_GEOMETRY_BIT);
    lookup_layout_ = make_pipeline_layout(ctx_, sets_.layout(), 0, 0);
    nearest_ = make_sampler(ctx_, false, false, false);  // texelFetch ignores it; depth and prim share it
}

void DepthMapCore::check_supported(const Technique& t, RasterStats& stats) {
    std::uint32_t max_dim = ctx_.limits().maxImageDimension2D;
    if (static_cast<std::uint32_t>(t.resolution) > max_dim)
        throw InputError(fmt::format("technique.resolution: {} exceeds the device's maxImageDimension2D {} ({})",
                                     t.resolution, max_dim, ctx_.info().name));
    if (!ctx_.supports_depth_attachment(vk_format(t.depth_format)))
        throw EnvironmentError(fmt::format("Vulkan device '{}' cannot render and sample depth format {}",
                                           ctx_.info().name, to_string(t.depth_format)));
    bool wants_bilinear =
        t.filter.type == FilterType::hw2x2 ||
        (t.filter.bilinear_taps && (t.filter.type == FilterType::pcf || t.filter.type == FilterType::poisson ||
                                    t.filter.type == FilterType::vogel));
    hardware_compare_ = wants_bilinear && ctx_.supports_linear_depth_compare(vk_format(t.depth_format));
    stats.hw2x2 = !wants_bilinear ? "unused" : hardware_compare_ ? "hardware" : "emulated";
    for (const auto& v : variants_) v->check_supported(t);
}

std::uint32_t DepthMapCore::layers_of(const Technique& t, const Light& l) const {
    for (const auto& v : variants_)
        if (const auto layers = v->layers(t, l)) return *layers;
    return l.type == LightType::point ? 6u : 1u;
}

// With triangle ids: a fragment shader writes each texel's triangle into the R32_UINT target.
// Without: no fragment shader and no colour target, the depth pass an engine draws. Both share
// the vertex shader, depth bias, clamp and culling, so they store the same depths. Caster
// offsets add a geometry shader (caster.geom); reversed Z keeps the nearest surface with GREATER.
VkPipeline DepthMapCore::shadow_pipeline(const Technique& t, bool triangle_ids, Cull cull, bool cutout) {
    const bool bias = t.bias.constant != 0 || t.bias.slope != 0;
    const bool caster = has_caster_offsets(t.bias);
    const double blend_cutoff = cutout && t.blend == Blend::cutout ? t.blend_cutoff : -1;
    const bool mipmaps = cutout && t.alpha_mipmaps;
    auto key = std::make_tuple(vk_format(t.depth_format), cull, bias, triangle_ids, t.reversed_z, caster, cutout,
                               blend_cutoff, mipmaps);
    UniquePipeline& p = shadow_pipelines_[key];
    if (!p) {
        // A cut-out's pass tests alpha (shaders/shadow_cutout*.frag), with or without the ids.
        const std::uint32_t* frag = cutout         ? (triangle_ids ? kShadowCutoutFrag : kShadowCutoutDepthFrag)
                                    : triangle_ids ? kShadowFrag
                                                   : nullptr;
        const std::size_t frag_bytes = cutout
                                           ? (triangle_ids ? sizeof(kShadowCutoutFrag) : sizeof(kShadowCutoutDepthFrag))
                                       : triangle_ids ? sizeof(kShadowFrag)
                                                      : 0;
        const std::uint32_t* vert = caster   ? (cutout ? kCasterCutoutVert : kCasterVert)
                                    : cutout ? kCutoutVert
                                             : kShadowVert;
        const std::size_t vert_bytes = caster   ? (cutout ? sizeof(kCasterCutoutVert) : sizeof(kCasterVert))
                                       : cutout ? sizeof(kCutoutVert)
                                                : sizeof(kShadowVert);
        GraphicsSetup g{vert,
                        vert_bytes,
                        frag,
                        frag_bytes,
                        vk_format(t.depth_format),
                        t.reversed_z ? VK_COMPARE_OP_GREATER : VK_COMPARE_OP_LESS,
                        vk_cull(cull),
                        VK_FRONT_FACE_CLOCKWISE,
                        true,
                        bias};
        if (caster) {
            g.geom = cutout ? kCasterCutoutGeom : kCasterGeom;
            g.geom_bytes = cutout ? sizeof(kCasterCutoutGeom) : sizeof(kCasterGeom);
        }
        if (!triangle_ids) g.colour_format = VK_FORMAT_UNDEFINED;  // a cut-out's depth pass: no colour target
        if (cutout) g.frag_spec = alpha_spec(t);
        p = make_graphics_pipeline(ctx_, caster ? caster_layout_.get() : shadow_layout_.get(), g);
    }
    return p.get();
}

// Light `l`'s lookup: a variant's shader, or the depth map's own (shaders/lookup_depth_map.comp).
LookupShader DepthMapCore::shader_for(const Technique& t, const Light& l) const {
    for (const auto& v : variants_)
        if (const auto shader = v->lookup_shader(t, l)) return *shader;
    return {kLookupDepthMapComp, sizeof(kLookupDepthMapComp), filter_kind(t.filter.type),
            static_cast<std::uint32_t>(t.filter.size)};
}

SpecData DepthMapCore::lookup_spec(const Technique& t, const LookupShader& shader, gpu::uint kind,
                                   gpu::uint mode) const {
    return {kind,
            shader.filter,
            shader.pcf_size,
            static_cast<std::uint32_t>(t.filter.taps),
            t.filter.bilinear_taps ? 1u : 0u,
            t.bias.receiver_plane ? 1u : 0u,
            hardware_compare_ ? 1u : 0u,
            mode};
}

VkPipeline DepthMapCore::lookup_pipeline(const Technique& t, const Light& l, gpu::uint kind, gpu::uint mode) {
    const LookupShader shader = shader_for(t, l);
    UniquePipeline& p = lookup_pipelines_[{shader.code, lookup_spec(t, shader, kind, mode)}];
    if (!p)
        p = make_compute_pipeline(ctx_, lookup_layout_.get(), shader.code, shader.bytes,
                                  lookup_spec(t, shader, kind, mode));
    return p.get();
}

// llvmpipe compiles each lookup pipeline on one core, 0.11-0.13 s apiece on the 2-core
// development VM (four for data/default's sun, spot and point: its face mask too), where a GPU
// driver takes milliseconds: those a render will record and lacks are made side by side first
// (Vulkan lets pipelines be created from several threads at once). The pipelines are the same
// ones: only when they are made changes.
void DepthMapCore::make_lookup_pipelines(const Technique& t, std::span<const Light> lights,
                                         const RenderOptions& options) {
    struct Wanted {
        LookupShader shader;
        SpecData spec;
    };
    std::vector<Wanted> missing;
    auto want = [&](const LookupShader& shader, const SpecData& spec) {
        const std::pair<const std::uint32_t*, SpecData> key{shader.code, spec};
        if (!lookup_pipelines_.contains(key) && std::none_of(missing.begin(), missing.end(), [&](const Wanted& w) {
                return w.shader.code == shader.code && w.spec == spec;
            }))
            missing.push_back({shader, spec});
    };
    for (std::size_t li = 0; li < lights.size(); ++li) {
        if (lights[li].type == LightType::point) {
            const LookupShader mask = shader_for(t, lights[li]);
            want(mask, lookup_spec(t, mask, gpu::kLightPoint, gpu::kModeFaceMask));
        }
        const Technique tl = t.for_light(li);
        const LookupShader shader = shader_for(tl, lights[li]);
        want(shader, lookup_spec(tl, shader, light_kind(lights[li].type),
                                 options.lookups ? gpu::kModeLookup : gpu::kModeVisibility));
    }
    if (missing.size() < 2) return;  // made where it is recorded
    std::vector<UniquePipeline> made(missing.size());
    tbb::parallel_for(std::size_t(0), missing.size(), [&](std::size_t i) {
        made[i] = make_compute_pipeline(ctx_, lookup_layout_.get(), missing[i].shader.code, missing[i].shader.bytes,
                                        missing[i].spec);
    });
    for (std::size_t i = 0; i < missing.size(); ++i)
        lookup_pipelines_[{missing[i].shader.code, missing[i].spec}] = std::move(made[i]);
}

VkSampler DepthMapCore::compare_sampler(bool linear, bool clamp_to_border, bool reversed_z) {
    UniqueSampler& s = compare_samplers_[{linear, clamp_to_border, reversed_z}];
    if (!s) s = make_sampler(ctx_, true, linear, clamp_to_border, reversed_z);
    return s.get();
}

gpu::ShadowPush DepthMapCore::caster_push(const Technique& t, const Light& light, const LightProjection& projection,
                                          std::uint32_t layer) const {
    gpu::ShadowPush push{};
    push.view_proj = glm::mat4(map_view_proj(t, projection.view_proj[layer]));
    const bool positional = light.type != LightType::directional;
    if (positional) {
        push.light = glm::vec4(glm::vec3(drawn_light_position(light, s_.origin, t.precision)), 1.0f);
        push.texel = glm::vec4(glm::vec3(projection.axis[layer]), projection.metres_per_texel_per_metre);
    } else {
        push.light = glm::vec4(glm::vec3(light.direction), 0.0f);
        const double texel =
            layer < projection.cascade_texel.size() ? projection.cascade_texel[layer] : projection.metres_per_texel;
        push.texel = glm::vec4(0.0f, 0.0f, 0.0f, static_cast<float>(texel));
    }
    const CasterBias& c = t.bias.caster;
    push.offsets = glm::vec4(c.world, c.world_texels, c.normal, c.normal_texels);
    push.caster =
        glm::vec4(static_cast<float>(normal_factor_kind(c.normal_factor)), c.depth, 0.0f, t.reversed_z ? 1.0f : 0.0f);
    return push;
}

// The maps of `lights`: one per light (its layers), or one for all beyond kMapBudgetBytes; then the
// variants' own resources beside them.
void DepthMapCore::ensure_maps(const Technique& t, std::span<const Light> lights) {
    const VkFormat format = vk_format(t.depth_format);
    // Without lights nothing samples a map: a 1x1 placeholder keeps descriptors valid.
    const auto res = static_cast<std::uint32_t>(lights.empty() ? 1 : t.resolution);
    int copies = 1;
    for (const auto& v : variants_) copies = std::max(copies, v->map_copies(t));
    std::vector<std::uint32_t> wanted;
    std::uint64_t bytes = 0;
    for (const Light& l : lights) {
        wanted.push_back(layers_of(t, l));
        bytes += std::uint64_t{res} * res * layers_of(t, l) * (depth_texel_bytes(t.depth_format) + 4) *
                 static_cast<std::uint64_t>(copies);
    }
    if (wanted.empty() || bytes > kMapBudgetBytes) {
        std::uint32_t most = 1;
        for (const Light& l : lights) most = std::max(most, layers_of(t, l));
        wanted = {most};  // one map for all
    }
    bool same = maps_.size() == wanted.size();
    for (std::size_t i = 0; same && i < wanted.size(); ++i)
        same = maps_[i].depth.format == format && maps_[i].depth.width == res && maps_[i].depth.layers == wanted[i];
    if (!same) {
        maps_.clear();
        maps_arena_ = MemoryArena(ctx_);
        maps_.resize(wanted.size());
        for (std::size_t i = 0; i < wanted.size(); ++i) {
            maps_arena_.add(maps_[i].depth, format, res, res, wanted[i],
                            VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT,
                            VK_IMAGE_ASPECT_DEPTH_BIT, true);
            maps_arena_.add(maps_[i].prim, kPrimFormat, res, res, wanted[i],
                            VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT, VK_IMAGE_ASPECT_COLOR_BIT,
                            true);
        }
        maps_arena_.commit();
        for (LightMap& m : maps_)
            for (std::uint32_t l = 0; l < m.depth.layers; ++l) {
                m.depth_layers.push_back(create_layer_view(ctx_, m.depth, l, VK_IMAGE_ASPECT_DEPTH_BIT));
                m.prim_layers.push_back(create_layer_view(ctx_, m.prim, l, VK_IMAGE_ASPECT_COLOR_BIT));
            }
    }
    std::vector<MapShape> shapes;
    std::vector<const GpuImage*> depth;
    for (const LightMap& m : maps_) {
        shapes.push_back({m.depth.format, m.depth.width, m.depth.layers});
        depth.push_back(&m.depth);
    }
    for (const auto& v : variants_) v->ensure_map_resources(t, shapes, depth, !same);
}

// The lookup descriptors name the maps in SHADER_READ_ONLY, the mask dispatches' too (which
// never read them): make that true of maps never drawn.
void DepthMapCore::record_map_layouts(VkCommandBuffer cmd) {
    for (LightMap& m : maps_) {
        if (m.read_only) continue;
        image_barrier(cmd, m.depth.image.get(), VK_IMAGE_ASPECT_DEPTH_BIT, m.depth.layers, VK_IMAGE_LAYOUT_UNDEFINED,
                      VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE,
                      VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT);
        image_barrier(cmd, m.prim.image.get(), VK_IMAGE_ASPECT_COLOR_BIT, m.prim.layers, VK_IMAGE_LAYOUT_UNDEFINED,
                      VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE,
                      VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT);
        m.read_only = true;
    }
    for (const auto& v : variants_) v->record_layouts(cmd);
}

void DepthMapCore::ensure_slots(std::size_t n, bool lookups) {
    // Outputs sized for the lookups stay for V-only renders too: a sweep alternating the two
    // kinds would otherwise allocate (and, on a GPU, pin host memory for) both every configuration.
    if (slots_.size() >= n && (slots_hold_lookups_ || !lookups)) return;
    lookups = lookups || slots_hold_lookups_;
    // All slots in one arena. A GPU writes its output into its own memory and copies it back
    // once; a CPU device writes it where it is read.
    slots_.clear();
    slots_arena_ = MemoryArena(ctx_);
    slots_.resize(n);
    const VkDeviceSize bytes = s_.pixels * (lookups ? sizeof(gpu::LookupTexel) : sizeof(float));
    for (Slot& slot : slots_) {
        slots_arena_.add(slot.params, sizeof(gpu::LookupParams), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, true);
        slots_arena_.add(slot.mask, 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true);
        slots_arena_.add(slot.output, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                         direct_readback_);
        if (!direct_readback_) slots_arena_.add(slot.output_host, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, true);
    }
    slots_arena_.commit();
    slots_hold_lookups_ = lookups;
    sets_.reserve(n);
}

gpu::LookupParams DepthMapCore::light_params(const Technique& t, const Light& light,
                                             const LightProjection& projection) const {
    const Scenario& sc = s_.scenario;
    const Camera& cam = s_.camera;
    const bool persp = cam.type == ProjectionType::perspective;
    const glm::dvec2 plane = ndc_to_image_plane(cam, sc.width, sc.height);
    gpu::LookupParams p{};
    p.cam_forward = glm::vec4(glm::vec3(cam.forward), persp ? 1.0f : 0.0f);
    p.cam_right = glm::vec4(glm::vec3(cam.right), static_cast<float>(plane.x));
    p.cam_up = glm::vec4(glm::vec3(cam.up), static_cast<float>(plane.y));
    p.image = glm::vec4(sc.width, sc.height, 1.0f / sc.width, 1.0f / sc.height);
    p.light_pos = glm::vec4(glm::vec3(drawn_light_position(light, s_.origin, t.precision)), 0.0f);
    p.light_dir = glm::vec4(glm::vec3(light.direction), static_cast<float>(std::cos(light.outer_cone_rad)));
    p.bias = glm::vec4(t.bias.world, t.bias.normal_offset, t.bias.shader_depth, t.bias.constant);
    p.bias2 = glm::vec4(t.bias.slope, t.bias.clamp, depth_resolution(t.depth_format), 0.0f);
    const CasterBias& c = t.bias.caster;
    p.bias3 = glm::vec4(t.bias.normal_offset_m, static_cast<float>(normal_factor_kind(t.bias.normal_factor)),
                        t.bias.normal_perpendicular ? 1.0f : 0.0f, t.bias.world_depth_range);
    p.caster = glm::vec4(c.world, c.world_texels, c.normal, c.normal_texels);
    p.caster2 =
        glm::vec4(static_cast<float>(normal_factor_kind(c.normal_factor)), c.depth, t.reversed_z ? 1.0f : 0.0f, 0.0f);
    p.map = glm::vec4(t.resolution, 1.0f / t.resolution, t.filter.radius_texels,
                      static_cast<float>(projection.view_proj.size()));
    p.footprint = glm::vec4(projection.metres_per_texel, projection.metres_per_texel_per_metre, 0.0f, 0.0f);
    // PCSS reaches here with lights that have a size only (check_technique_lights): an area
    // light's radius, or a sun's angular radius as its tangent (shaders/lookup_core.glsl, pcss_visibility).
    const double light_size =
        light.type == LightType::directional ? std::tan(0.5 * light.angular_diameter_rad) : light.radius;
    p.pcss = glm::vec4(light_size, projection.near, projection.far, t.filter.max_radius_texels);
    for (std::size_t l = 0; l < projection.view_proj.size(); ++l) {
        p.view_proj[l] = glm::mat4(map_view_proj(t, projection.view_proj[l]));
        p.light_axis[l] = glm::vec4(glm::vec3(projection.axis[l]), 0.0f);
    }
    for (std::size_t k = 0; k < disk_.size(); ++k) {
        glm::vec4& pair = p.poisson[k / 2];
        if (k % 2 == 0) {
            pair.x = disk_[k].x;
            pair.y = disk_[k].y;
        } else {
            pair.z = disk_[k].x;
            pair.w = disk_[k].y;
        }
    }
    for (const auto& v : variants_) v->fill_params(p, t, light, projection);
    return p;
}

const GpuBuffer& DepthMapCore::host_copy(const Slot& slot) const {
    return direct_readback_ ? slot.output : slot.output_host;
}

RasterLightImage DepthMapCore::read_back(std::size_t li, bool lookups) const {
    const std::size_t n = s_.pixels;
    RasterLightImage img;
    if (!lookups) {
        const auto* v = static_cast<const float*>(host_copy(slots_[li]).mapped);
        img.V.assign(v, v + n);
        return img;
    }
    const auto* texels = static_cast<const gpu::LookupTexel*>(host_copy(slots_[li]).mapped);
    img.V.resize(n);
    for (std::size_t i = 0; i < n; ++i) img.V[i] = texels[i].V;
    DepthMapLookups& lk = img.lookups.emplace();
    lk.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
        const gpu::LookupTexel& t = texels[i];
        lk.ref_depth[i] = t.ref_depth;
        lk.stored_depth[i] = t.stored_depth;
        lk.stored_prim[i] = t.stored_prim;
        lk.footprint_m[i] = t.footprint_m;
        lk.texel_slope[i] = t.texel_slope;
        lk.bias_m[i] = t.bias_m;
        lk.depth_to_m[i] = t.depth_to_m;
        lk.flags[i] = t.flags & ((1u << gpu::kFlagLayerShift) - 1u);
        lk.layer[i] = t.flags >> gpu::kFlagLayerShift;
    }
    return img;
}

// Point lights: which cube faces some receiver samples, so that only those are drawn.
void DepthMapCore::record_masks(VkCommandBuffer cmd, std::span<const Light> lights, const Technique& t) {
    timer_.write(cmd, 0);
    for (std::size_t li = 0; li < lights.size(); ++li) {
        if (lights[li].type != LightType::point) continue;  // one layer, sampled unless nothing is lit
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE,
                          lookup_pipeline(t, lights[li], gpu::kLightPoint, gpu::kModeFaceMask));
        VkDescriptorSet set = sets_[li];
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, lookup_layout_.get(), 0, 1, &set, 0, nullptr);
        vkCmdDispatch(cmd, (s_.width + 7) / 8, (s_.height + 7) / 8, 1);
    }
    timer_.write(cmd, 1);
    memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
}

void DepthMapCore::record_light(VkCommandBuffer cmd, const Technique& t, const Light& light, std::size_t li,
                                RasterLightStats& ls, const RenderOptions& options) {
    const auto q = static_cast<std::uint32_t>(kMaskQueries + queries_per_light() * li);
    const auto res = static_cast<std::uint32_t>(t.resolution);
    const std::size_t mi = map_of_index(li);
    timer_.write(cmd, q);
    std::vector<double> constant_scale(ls.projection.view_proj.size(), 1.0);
    for (std::uint32_t layer = 0; layer < constant_scale.size(); ++layer)
        for (const auto& v : variants_) constant_scale[layer] *= v->constant_scale(t, light, ls.projection, layer);
    MapContent content{ls.projection.view_proj, ls.layers_sampled, t.resolution, t.depth_format, t.cull,
                       t.single_sided_cull,     t.bias.constant,   t.bias.slope, t.bias.clamp,   t.depth_layer,
                       constant_scale,          t.reversed_z,      t.bias.caster};
    LightMap& map = map_of(li);
    // The lookups read the stored triangle ids; V alone reads depth only, so a map drawn with
    // ids serves it too, but a depth-only map must be drawn again for the lookups.
    const bool triangle_ids = options.lookups;
    ls.map_reused =
        options.reuse_maps && ls.layers_sampled != 0 && map.content == content && (map.triangle_ids || !triangle_ids);
    MapTargets targets{mi, &map.depth, map.depth_layers, &ls.projection, ls.layers_sampled, false};
    if (ls.layers_sampled != 0 && !ls.map_reused) {
        // A lookup may have read these images (a previous render, or the previous light of a
        // shared map); their contents are not needed again.
        map.content.reset();
        targets.redrawn = true;
        image_barrier(cmd, map.depth.image.get(), VK_IMAGE_ASPECT_DEPTH_BIT, map.depth.layers,
                      VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL,
                      VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_NONE, kFragmentTests,
                      VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT);
        for (const auto& v : variants_) v->before_shadow(cmd, t, mi);
        // Without ids the id image stays as it is (SHADER_READ_ONLY, bound but never read).
        if (triangle_ids)
            image_barrier(cmd, map.prim.image.get(), VK_IMAGE_ASPECT_COLOR_BIT, map.prim.layers,
                          VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                          VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_NONE,
                          VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT);
        VkDeviceSize zero = 0;
        vkCmdBindVertexBuffers(cmd, 0, 1, s_.positions.buffer.ptr(), &zero);
        vkCmdBindIndexBuffer(cmd, s_.indices.buffer.get(), 0, VK_INDEX_TYPE_UINT32);
        if (s_.has_cutouts) {  // with the layout the technique's pipelines use (their push ranges differ)
            VkDescriptorSet set = (*s_.cutout_set)[0];
            vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS,
                                    has_caster_offsets(t.bias) ? caster_layout_.get() : shadow_layout_.get(), 0, 1,
                                    &set, 0, nullptr);
        }
        for (std::uint32_t layer = 0; layer < ls.projection.view_proj.size(); ++layer) {
            if (!(ls.layers_sampled & (1u << layer))) continue;  // no receiver samples this face
            VkImageView target = map.depth_layers[layer].get();
            for (const auto& v : variants_)
                if (VkImageView own = v->shadow_target(t, mi, layer)) target = own;
            // Reversed Z clears to 0, the far plane.
            begin_rendering(cmd, triangle_ids ? map.prim_layers[layer].get() : VK_NULL_HANDLE, target, res, res,
                            t.reversed_z ? 0.0f : 1.0f);
            // A variant may scale each layer's constant (cascades.texel_scaled_bias). Reversed Z:
            // away from the light is towards 0, so the hardware bias changes sign (as engines with
            // reverse-Z negate theirs).
            const double sign = t.reversed_z ? -1.0 : 1.0;
            const double constant = t.bias.constant * constant_scale[layer];
            vkCmdSetDepthBias(cmd, static_cast<float>(sign * constant), static_cast<float>(sign * t.bias.clamp),
                              static_cast<float>(sign * t.bias.slope));
            if (has_caster_offsets(t.bias)) {
                const gpu::ShadowPush push = caster_push(t, light, ls.projection, layer);
                vkCmdPushConstants(cmd, caster_layout_.get(), VK_SHADER_STAGE_GEOMETRY_BIT, 0, sizeof(push), &push);
            } else {
                glm::mat4 vp = glm::mat4(map_view_proj(t, ls.projection.view_proj[layer]));
                vkCmdPushConstants(cmd, shadow_layout_.get(), VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(vp), &vp);
            }
            draw_casters(cmd, s_, t, [&](Cull c, bool cutout) { return shadow_pipeline(t, triangle_ids, c, cutout); });
            vkCmdEndRendering(cmd);
            ++ls.layers_rendered;
        }
        timer_.write(cmd, q + 1);
        for (const auto& v : variants_) v->record_map_pass(cmd, t, targets);
        image_barrier(cmd, map.depth.image.get(), VK_IMAGE_ASPECT_DEPTH_BIT, map.depth.layers,
                      VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                      kFragmentTests, VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
                      VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT);
        if (triangle_ids)
            image_barrier(cmd, map.prim.image.get(), VK_IMAGE_ASPECT_COLOR_BIT, map.prim.layers,
                          VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                          VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                          VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT);
        map.content = content;
        map.triangle_ids = triangle_ids;
    }
    ls.map_triangle_ids = ls.layers_sampled != 0 && map.triangle_ids;
    if (ls.layers_sampled == 0 || ls.map_reused) timer_.write(cmd, q + 1);
    // The variants' passes over the readable map (a midpoint's is timed from the shadow pass's end).
    PassMarks marks(timer_, q + 2);
    for (const auto& v : variants_) v->record_after_map(cmd, t, targets, marks);
    vkCmdBindPipeline(
        cmd, VK_PIPELINE_BIND_POINT_COMPUTE,
        lookup_pipeline(t, light, light_kind(light.type), options.lookups ? gpu::kModeLookup : gpu::kModeVisibility));
    VkDescriptorSet set = sets_[li];
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, lookup_layout_.get(), 0, 1, &set, 0, nullptr);
    vkCmdDispatch(cmd, (s_.width + 7) / 8, (s_.height + 7) / 8, 1);
    timer_.write(cmd, q + 2 + variant_passes_);
    const Slot& slot = slots_[li];
    if (direct_readback_ || !options.read_back) {
        memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
        return;
    }
    memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
    VkBufferCopy region{0, 0, output_bytes(options.lookups)};
    vkCmdCopyBuffer(cmd, slot.output.buffer.get(), slot.output_host.buffer.get(), 1, &region);
    memory_barrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                   VK_ACCESS_2_HOST_READ_BIT);
}

void DepthMapCore::render(const Technique& t, std::span<const Light> all_lights, const RenderOptions& options,
                          RasterFrame& frame, RasterStats& stats) {
    auto t0 = SteadyClock::now();
    check_supported(t, stats);
    // An area light is drawn from its centre as a point light carrying its size (for PCSS).
    Technique centred_technique = t;
    centred_technique.area_samples = 0;
    const std::vector<Light> centred =
        expand_area_lights({all_lights.begin(), all_lights.end()}, centred_technique).lights;
    const std::span<const Light> lights = centred;
    const std::size_t n = lights.size();
    const bool any_point =
        std::any_of(lights.begin(), lights.end(), [](const Light& l) { return l.type == LightType::point; });
    ensure_maps(t, lights);
    ensure_slots(n, options.lookups);
    const auto queries = static_cast<std::uint32_t>(kMaskQueries + queries_per_light() * n);
    timer_.ensure(queries);
    if (static_cast<int>(disk_.size()) != t.filter.taps) disk_ = poisson_disk(t.filter.taps);
    make_lookup_pipelines(t, lights, options);
    for (const auto& v : variants_) v->begin_render(t, lights, stats);

    const Scenario& sc = s_.scenario;
    stats.lights.resize(n);
    for (std::size_t li = 0; li < n; ++li) {
        const Light& light = lights[li];
        RasterLightStats& ls = stats.lights[li];
        ls = {};
        // world_float32: fitted in world space, its matrices then rounded as an engine keeps them.
        const bool world = t.precision == Precision::world_float32;
        const glm::dvec3 fit_origin = world ? glm::dvec3(0.0) : s_.origin;
        std::optional<LightProjection> fitted;
        for (const auto& v : variants_)
            if (!fitted) fitted = v->fit(t, light, fit_origin);
        ls.projection = fitted ? std::move(*fitted)
                               : fit_for_technique(light, sc.scene, s_.camera, sc.width, sc.height, t, fit_origin);
        if (world) round_to_world_float32(ls.projection, s_.origin);
        ls.views = shadow_views(ls.projection);
        for (const auto& w : ls.projection.warnings) stats.warnings.push_back(w);
        const gpu::LookupParams p = light_params(t.for_light(li), light, ls.projection);
        std::memcpy(slots_[li].params.mapped, &p, sizeof(p));
        // Only cube maps are worth a mask pass; a single map is rendered whenever the light exists.
        const std::uint32_t initial = light.type == LightType::point ? 0u : 1u;
        std::memcpy(slots_[li].mask.mapped, &initial, 4);

        const Slot& slot = slots_[li];
        std::array<DescriptorResource, kLookupBindings.size()> r{};
        r[0].image = {VK_NULL_HANDLE, s_.gbuffer_prim.view.get(), VK_IMAGE_LAYOUT_GENERAL};
        r[1].buffer = {s_.positions.buffer.get(), 0, VK_WHOLE_SIZE};
        r[2].buffer = {s_.indices.buffer.get(), 0, VK_WHOLE_SIZE};
        const LightMap& map = map_of(li);
        r[3].image = {nearest_.get(), map.depth.view.get(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
        r[4].image = {nearest_.get(), map.prim.view.get(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
        // Each light its own compare sampler: a cube face clamps to its edge, a 2D map reads a
        // lit border (one sampler for all lights made a sun's lookup outside its map read the
        // edge texel wherever a point light was drawn too, on devices that filter depth).
        const VkSampler compare = compare_sampler(hardware_compare_, light.type != LightType::point, t.reversed_z);
        r[5].image = {compare, map.depth.view.get(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
        r[6].buffer = {slot.params.buffer.get(), 0, slot.params.size};
        // One output, bound to both: the lookup writes the one its mode names.
        r[7].buffer = {slot.output.buffer.get(), 0, slot.output.size};
        r[8].buffer = {slot.mask.buffer.get(), 0, slot.mask.size};
        r[9].buffer = {slot.output.buffer.get(), 0, slot.output.size};
        // A variant's own image (a moment family's moments); the depth map stands in, never read.
        r[10].image = {nearest_.get(), map.depth.view.get(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
        for (const auto& v : variants_)
            if (const auto own = v->family_image(t, map_of_index(li))) r[10].image = *own;
        sets_.write(li, r);
    }
    stats.setup_s += seconds_since(t0);

    auto t1 = SteadyClock::now();
    if (any_point) {
        ctx_.submit_and_wait([&](VkCommandBuffer cmd) {
            timer_.reset(cmd, 0, kMaskQueries);
            record_map_layouts(cmd);
            record_masks(cmd, lights, t);
        });
        for (std::size_t li = 0; li < n; ++li)
            stats.lights[li].layers_sampled = *static_cast<const std::uint32_t*>(slots_[li].mask.mapped);
    } else {
        for (std::size_t li = 0; li < n; ++li) stats.lights[li].layers_sampled = 1u;
    }
    for (std::size_t li = 0; li < n; ++li)
        for (const auto& v : variants_)
            if (v->draws_every_layer(t, lights[li]))
                stats.lights[li].layers_sampled = (1u << stats.lights[li].projection.view_proj.size()) - 1u;
    ctx_.submit_and_wait([&](VkCommandBuffer cmd) {
        timer_.reset(cmd, kMaskQueries, queries - kMaskQueries);
        record_map_layouts(cmd);
        for (std::size_t li = 0; li < n; ++li)
            record_light(cmd, t.for_light(li), lights[li], li, stats.lights[li], options);
    });
    stats.render_s += seconds_since(t1);

    // All timestamps in one query-pool read.
    const std::uint32_t first = any_point ? 0 : kMaskQueries;
    if (queries > first) timer_.read(first, queries - first);
    for (std::size_t li = 0; li < n; ++li) {
        const auto q = static_cast<std::uint32_t>(kMaskQueries + queries_per_light() * li);
        RasterLightStats& ls = stats.lights[li];
        ls.gpu_ms.add("shadow", timer_.ms(q, q + 1), options.lookups ? kShadowWithIds : kShadowDepthOnly);
        std::uint32_t pass = q + 1;  // each variant's passes, timed from the mark before
        for (const auto& v : variants_) {
            v->add_times(
                t, [&](std::uint32_t k) { return timer_.ms(pass + k, pass + k + 1); }, ls.gpu_ms);
            pass += v->timed_passes();
        }
        ls.gpu_ms.add("lookup", timer_.ms(pass, pass + 1), options.lookups ? kLookupDiagnostic : kLookupV);
        stats.gpu_ms.add(ls.gpu_ms);
        if (options.read_back) {
            frame.lights.push_back(read_back(li, options.lookups));
        } else {
            frame.lights.emplace_back();
            stats.on_device.push_back({slots_[li].output.buffer.get(), output_bytes(options.lookups), options.lookups});
        }
    }
    if (any_point)
        stats.gpu_ms.add("layer_mask", timer_.ms(0, 1),
                         "a compute pass per point light marking the cube faces some receiver samples");
}

}  // namespace

std::unique_ptr<TechniqueFamily> make_depth_map_core(const SceneOnGpu& scene, DepthMapVariants variants) {
    return std::make_unique<DepthMapCore>(scene, std::move(variants));
}

// The depth_map family: the core, and midpoint depth's second pass (raster/depth_layers.cpp).
std::unique_ptr<TechniqueFamily> make_depth_map_family(const SceneOnGpu& scene) {
    DepthMapVariants variants;
    variants.push_back(make_midpoint_variant(scene));
    return make_depth_map_core(scene, std::move(variants));
}

FamilyEntry depth_map_family_entry() {
    FamilyEntry e;
    e.name = "depth_map";
    e.description =
        "one depth map per light (six cube faces for point lights), hardware and shader biases, filters none, "
        "hw2x2, pcf, poisson, pcss, vogel";
    e.parse = [](JsonObject& o, Technique& t) {
        parse_depth_map_keys(o, t);
        t.depth_layer = pick_enum(o, "depth_layer", DepthLayer::first,
                                  {DepthLayer::first, DepthLayer::midpoint, DepthLayer::second});
        // Second-depth shadow mapping is the map of back faces alone: what `cull: front` draws.
        if (t.depth_layer == DepthLayer::second && t.cull == Cull::material)
            o.fail("cull",
                   "depth_layer \"second\" draws back faces alone (cull front); \"material\" culls by material");
        if (t.depth_layer == DepthLayer::second) t.cull = Cull::front;
        // The midpoint pass peels and stores forward depths (shaders/peel.frag).
        if (t.depth_layer == DepthLayer::midpoint && t.reversed_z)
            o.fail("reversed_z", "depth_layer \"midpoint\" stores forward depth; reversed_z must be false with it");
        // Written by to_json as 0 (raster.json readers find it there); more is another family's.
        if (o.has("area_samples") && o.integer("area_samples", 0, 256) > 0)
            o.fail("area_samples", "only the averaged_area family draws area samples (\"family\": \"averaged_area\")");
    };
    e.write = [](const Technique& t, nlohmann::json& j) {
        j.update(depth_map_keys_json(t));
        j["depth_layer"] = to_string(t.depth_layer);
        j["area_samples"] = 0;
    };
    e.hints = [](const Technique& t) {
        // docs/metrics.md, "acne": the shader's reference and stored depths are floats, a few
        // float steps apart, so the quantum is never finer than 2^-22.
        return ScoringHints{filter_reach_texels(t.filter),
                            std::max(depth_resolution(t.depth_format), std::ldexp(1.0, -22))};
    };
    e.memory = [](const Technique& t) {
        // The midpoint keeps two depth layers a texel (the first, and the midpoint the lookup reads)
        // and the second pass's triangle ids: counted as twice the bytes of a texel.
        const int layers = t.depth_layer == DepthLayer::midpoint ? 2 : 1;
        return RasterMemory{t.resolution,
                            layers * static_cast<int>(depth_texel_bytes(t.depth_format)) + (layers - 1) * 4, 0};
    };
    e.describe_light = [](const Technique& t, const Light& light, const RasterLightStats&) {
        nlohmann::json j = nlohmann::json::object();
        // What the map stores, when it is not the nearest surface (docs/raster.md, "Midpoint and second depth").
        if (t.depth_layer == DepthLayer::midpoint)
            j["depth_layer"] = {{"stores", "midpoint"},
                                {"depth_layers", 2},
                                {"second", "nearest surface more than 2 depth quanta behind the first (peeled)"},
                                {"no_second", "the clear value 1 (the far plane)"}};
        else if (t.depth_layer == DepthLayer::second)
            j["depth_layer"] = {{"stores", "second"}, {"depth_layers", 1}, {"faces", "back faces only (cull front)"}};
        // An area light is drawn from its centre: with PCSS sizing the penumbra by the light's size.
        if (is_area_light(light.type))
            j["area"] = {{"method", t.filter.type == FilterType::pcss ? "pcss" : "centre_point"}, {"maps", 1}};
        return j;
    };
    e.sweep_keys = {"resolution",
                    "depth_format",
                    "fit",
                    "shadow_distance",
                    "cull",
                    "bias.shader_depth",
                    "bias.normal_offset_m",
                    "bias.normal_factor",
                    "bias.normal_perpendicular",
                    "bias.world_depth_range",
                    "bias.caster.world",
                    "bias.caster.world_texels",
                    "bias.caster.normal",
                    "bias.caster.normal_texels",
                    "bias.caster.normal_factor",
                    "bias.caster.depth",
                    "reversed_z",
                    "filter.type",
                    "filter.size",
                    "filter.taps",
                    "filter.radius_texels",
                    "filter.bilinear_taps",
                    "filter.max_radius_texels",
                    "depth_layer",
                    "precision"};
    e.knobs = depth_map_bias_knobs();
    e.make = make_depth_map_family;
    return e;
}

}  // namespace penumbra::raster
