// The filterable families (docs/raster.md, "Filterable shadow maps"): variance shadow maps
// (Donnelly & Lauritzen 2006), exponential shadow maps (Annen et al. 2008) and exponential
// variance shadow maps (Lauritzen & McCool 2008), with two or four moments, and moment shadow
// maps (Peters & Klein 2015), with four. They share the
// depth-map family's map and keys (resolution, format, fit, cull, bias, lights); a moments pass,
// a separable Gaussian blur and optionally a mip chain follow the map (MomentsVariant below, a
// variant of the depth-map core, raster/depth_map.h; raster/filterable_moments.comp), and the
// lookup (raster/filterable_lookup.comp) samples the filtered moments bilinearly or trilinearly.
#include "raster/filterable.h"

#include <fmt/format.h>

#include <limits>
#include <map>

#include "common/errors.h"
#include "common/json_reader.h"
#include "raster/depth_map.h"
#include "raster/knobs.h"
#include "raster/technique_family.h"
// SPIR-V compiled from raster/filterable_*.comp at build time.
#include "filterable_lookup_comp.h"
#include "filterable_moments_comp.h"

namespace penumbra::raster {

const char* to_string(MomentKind k) {
    static const char* const kNames[] = {"vsm", "esm", "evsm2", "evsm4", "msm"};
    return kNames[static_cast<int>(k)];
}

const char* to_string(MsmVariant v) {
    return v == MsmVariant::hamburger ? "hamburger" : "hausdorff";
}

glm::vec4 moment_uniform(const MomentParameters& p) {
    if (p.kind == MomentKind::msm)
        return glm::vec4(static_cast<float>(p.moment_bias), 0.0f, p.variant == MsmVariant::hausdorff ? 1.0f : 0.0f,
                         static_cast<float>(p.storage_bits));
    return glm::vec4(p.min_variance, p.light_bleed, p.exponent, p.negative_exponent);
}

double msm_visibility(const std::array<double, 4>& moments, double z, double alpha, MsmVariant variant) {
    // The bias mixes in a little of the moments of a spread-out distribution, so that the Hankel
    // matrix below stays positive definite under rounding (Peters & Klein 2015, section 5).
    std::array<double, 4> b{};
    for (int i = 0; i < 4; ++i) b[i] = (1 - alpha) * moments[i] + alpha * 0.5;
    // Solve B c = (1, z, z^2) for the Hankel matrix B = [[1, b1, b2], [b1, b2, b3], [b2, b3, b4]]
    // by its LDL^T factorisation: c's polynomial vanishes at the two other support points of
    // the distribution with these moments that puts weight on z.
    const double d22 = b[1] - b[0] * b[0];
    const double l32 = (b[2] - b[0] * b[1]) / d22;
    const double d33 = b[3] - b[1] * b[1] - l32 * l32 * d22;
    double c2 = z - b[0];
    double c3 = (z * z - b[1] - l32 * c2) / d33;
    c2 = c2 / d22 - l32 * c3;
    const double c1 = 1 - b[0] * c2 - b[1] * c3;
    const double p = c2 / c3, q = c1 / c3;
    const double r = std::sqrt(std::max(0.25 * p * p - q, 0.0));
    const double z2 = -0.5 * p - r, z3 = -0.5 * p + r;
    double shadow = 0;
    if (z > z3) {
        shadow = 1 - (z2 * z3 - b[0] * (z2 + z3) + b[1]) / ((z - z2) * (z - z3));
    } else if (z > z2) {
        shadow = (z * z3 - b[0] * (z + z3) + b[1]) / ((z3 - z2) * (z - z2));
    }
    if (variant == MsmVariant::hausdorff && (z2 < 0 || z3 > 1)) {
        // Those points leave [0, 1]: the bound of four points, one of them 0 or 1 (Peters &
        // Klein 2015, the Hausdorff moment problem). Where the receiver ties the free point the
        // formula is 0/0 and the three-point bound stays (penumbra's guard; the paper has none).
        const double free = ((b[2] - b[1]) * z + b[2] - b[3]) / ((b[1] - b[0]) * z + b[1] - b[2]);
        const double w = z > free ? 1.0 : 0.0;
        const double four =
            (b[1] - b[0] + (b[2] - b[0] - (free + 1) * (b[1] - b[0])) * (free - w - z) / (z * (z - free))) /
                (free - w) +
            1 - b[0];
        if (std::isfinite(four)) shadow = four;
    }
    return 1 - std::clamp(shadow, 0.0, 1.0);
}

namespace {

// Peters & Klein 2015, section 4.3: q = A b + (kOffset, 0, 0, 0), rows of A; and A's inverse.
constexpr double kMsmOffset = 0.035955884801;
constexpr double kMsmA[4][4] = {{-2.07224649, 32.23703778, -68.571074599, 39.3703274134},
                                {13.7948857237, -59.4683975703, 82.0359750338, -35.364903257},
                                {0.105877704, -1.9077466311, 9.3496555107, -6.6543490743},
                                {9.7924062118, -33.7652110555, 47.9456096605, -23.9728048165}};
constexpr double kMsmAInverse[4][4] = {{0.2227744146, 0.0771972861, 0.7926986636, 0.0319417555},
                                       {0.1549679261, 0.1394629426, 0.7963415838, -0.1722823173},
                                       {0.1451988946, 0.2120202157, 0.7258694464, -0.2758014811},
                                       {0.163127443, 0.2591432266, 0.6539092497, -0.3376131734}};

}  // namespace

std::array<double, 4> msm_optimise(const std::array<double, 4>& b) {
    std::array<double, 4> q{};
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) q[i] += kMsmA[i][j] * b[j];
    q[0] += kMsmOffset;
    return q;
}

std::array<double, 4> msm_unoptimise(const std::array<double, 4>& q) {
    std::array<double, 4> b{};
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) b[i] += kMsmAInverse[i][j] * (q[j] - (j == 0 ? kMsmOffset : 0.0));
    return b;
}

std::array<double, 4> round_to_unorm16(const std::array<double, 4>& q) {
    std::array<double, 4> r{};
    for (int i = 0; i < 4; ++i) r[i] = std::round(std::clamp(q[i], 0.0, 1.0) * 65535.0) / 65535.0;
    return r;
}

const MomentParameters* moment_parameters(const Technique& t) {
    return t.parameters<MomentParameters>();
}

namespace {

const MomentParameters& parameters_of(const Technique& t) {
    static const MomentParameters kNone;
    const MomentParameters* p = moment_parameters(t);
    return p ? *p : kNone;
}

void parse_moment_keys(MomentKind kind, JsonObject& o, Technique& t) {
    // The moments' variance floor stands in for a depth bias (Filament ignores its biases with
    // VSM): no hardware bias unless the technique asks for one.
    t.bias = Bias{};
    parse_depth_map_keys(o, t);
    if (t.filter.type != FilterType::none)
        o.fail("filter", fmt::format("the {} family filters its moments (\"blur\" and a bilinear tap); filter.type "
                                     "must be \"none\"",
                                     to_string(kind)));
    if (o.has("area_samples") && o.integer("area_samples", 0, 256) > 0)
        o.fail("area_samples", "only the averaged_area family draws area samples (\"family\": \"averaged_area\")");
    auto p = std::make_shared<MomentParameters>();
    p->kind = kind;
    p->blur = static_cast<int>(o.integer("blur", 0, 0, 32));
    p->mipmaps = o.boolean("mipmaps", false);
    if (kind == MomentKind::vsm) {
        if (o.has("vsm")) {
            JsonObject v = o.object("vsm");
            p->min_variance = v.number_in("min_variance", p->min_variance, 0.0, 1.0, "squared depth units in [0, 1]");
            p->light_bleed = v.number_in("light_bleed", p->light_bleed, 0.0, 0.999, "a fraction in [0, 0.999]");
            v.finish();
        }
    } else if (kind == MomentKind::esm) {
        if (o.has("esm")) {
            JsonObject e = o.object("esm");
            p->exponent = e.number_in("exponent", p->exponent, 0.0, 1e6, "a positive number");
            if (p->exponent <= 0) e.fail("exponent", "must be > 0");
            if (p->exponent > kMaxEsmExponent)
                e.fail("exponent", fmt::format("{} overflows float32 moments: exp(c) exceeds FLT_MAX beyond c = {}",
                                               p->exponent, kMaxEsmExponent));
            e.finish();
        }
    } else if (kind != MomentKind::msm) {
        p->exponent = 40;  // TheRealMJP/Shadows' defaults, +40 / -5 for fp32
        // Its VSMBias 0.01 floors the warped depth's deviation at 1e-4 c exp(c w), i.e. a depth
        // deviation of 5e-5. The floor must be small here: the warped gap t - mean is at most
        // exp(c w), so the floor alone leaks (2 c sigma)^2 of the light (0.0064 at sigma 1e-3).
        p->min_variance = kEvsmMinVariance;
        if (o.has("evsm")) {
            JsonObject e = o.object("evsm");
            if (e.has("exponents")) {
                const nlohmann::json& x = e.get("exponents");
                if (!x.is_array() || x.size() != 2 || !x[0].is_number() || !x[1].is_number())
                    e.fail("exponents", "expected [positive, negative], two numbers, e.g. [40, 5]");
                p->exponent = x[0].get<double>();
                p->negative_exponent = x[1].get<double>();
                for (double c : {p->exponent, p->negative_exponent}) {
                    if (!(c > 0)) e.fail("exponents", fmt::format("{} is not > 0 (both are magnitudes)", c));
                    if (c > kMaxEvsmExponent)
                        e.fail("exponents",
                               fmt::format("{} overflows float32 moments: the second moment exp(2c) exceeds FLT_MAX "
                                           "beyond c = {} (Filament's fp32 limit)",
                                           c, kMaxEvsmExponent));
                }
            }
            p->min_variance = e.number_in("min_variance", p->min_variance, 0.0, 1.0, "squared depth units in [0, 1]");
            p->light_bleed = e.number_in("light_bleed", p->light_bleed, 0.0, 0.999, "a fraction in [0, 0.999]");
            e.finish();
        }
    } else {
        // msm: Peters & Klein's bound needs no light-bleed reduction (TheRealMJP/Shadows: 0 by default).
        p->light_bleed = 0;
        p->min_variance = 0;
        if (o.has("msm")) {
            JsonObject m = o.object("msm");
            p->variant = pick_enum(m, "variant", MsmVariant::hamburger, {MsmVariant::hamburger, MsmVariant::hausdorff});
            p->storage_bits = static_cast<int>(m.integer("storage", 32, 16, 32));
            if (p->storage_bits != 16 && p->storage_bits != 32)
                m.fail("storage",
                       fmt::format("{} is not 16 (optimised 16-bit quantisation) or 32 (float)", p->storage_bits));
            p->moment_bias = m.number_in("moment_bias", p->storage_bits == 16 ? kMsmMomentBias16 : kMsmMomentBias32,
                                         0.0, 0.5, "a fraction in [0, 0.5]");
            m.finish();
        }
    }
    t.family_parameters = std::move(p);
}

nlohmann::json moment_keys_json(const Technique& t) {
    const MomentParameters& p = parameters_of(t);
    nlohmann::json j = depth_map_keys_json(t);
    j["blur"] = p.blur;
    j["mipmaps"] = p.mipmaps;
    switch (p.kind) {
        case MomentKind::vsm: j["vsm"] = {{"min_variance", p.min_variance}, {"light_bleed", p.light_bleed}}; break;
        case MomentKind::esm: j["esm"] = {{"exponent", p.exponent}}; break;
        case MomentKind::evsm2:
        case MomentKind::evsm4:
            j["evsm"] = {{"exponents", {p.exponent, p.negative_exponent}},
                         {"min_variance", p.min_variance},
                         {"light_bleed", p.light_bleed}};
            break;
        case MomentKind::msm:
            j["msm"] = {{"variant", to_string(p.variant)}, {"storage", p.storage_bits}, {"moment_bias", p.moment_bias}};
            break;
    }
    return j;
}

}  // namespace

namespace {

// The moment families' passes (raster/filterable_moments.comp): what they read, what they write.
constexpr std::array<BindingDecl, 2> kMomentBindings = {{
    {gpu::kBindingMomentSource, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER},
    {gpu::kBindingMomentTarget, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE},
}};
// Per map, three sets: depth -> moments, moments -> scratch (blur along x), scratch -> moments (along y).
constexpr std::size_t kMomentSetsPerMap = 3;
constexpr const char* kMomentsPass =
    "compute pass per drawn map layer: the family's moments of every depth texel (vsm d, d^2; esm exp(c d); evsm "
    "the warped moments; msm d..d^4, optimised and rounded to 16 bits with msm.storage 16) into a texture of the "
    "family's format";
constexpr const char* kBlurPass =
    "two compute passes per drawn map layer: the separable Gaussian of radius `blur` texels (sigma = blur / 2) "
    "over the moments, along x into a scratch texture and along y back";
constexpr const char* kMipmapPass =
    "the moment texture's mip chain, each level a linear blit of the one above (vkCmdBlitImage), after the blur";

// The moment texture's format: the family's moments in float32, or msm's 16-bit storage.
VkFormat moment_format(const MomentParameters& m) {
    switch (m.kind) {
        case MomentKind::esm: return VK_FORMAT_R32_SFLOAT;
        case MomentKind::vsm:
        case MomentKind::evsm2: return VK_FORMAT_R32G32_SFLOAT;
        case MomentKind::evsm4: return VK_FORMAT_R32G32B32A32_SFLOAT;
        case MomentKind::msm:
            return m.storage_bits == 16 ? VK_FORMAT_R16G16B16A16_UNORM : VK_FORMAT_R32G32B32A32_SFLOAT;
    }
    return VK_FORMAT_R32G32B32A32_SFLOAT;
}

// Levels of a full mip chain down to 1x1.
std::uint32_t mip_levels(std::uint32_t res) {
    std::uint32_t levels = 1;
    while (res > 1) {
        res /= 2;
        ++levels;
    }
    return levels;
}

// The moment families' variant of the depth-map core: after the map, a moments pass, the blur and
// the mip chain fill a texture of moments per map, and the lookup (raster/filterable_lookup.comp)
// samples them instead of comparing depths.
class MomentsVariant final : public DepthMapVariant {
  public:
    explicit MomentsVariant(const SceneOnGpu& scene)
        : ctx_(scene.ctx), sets_(scene.ctx, kMomentBindings, VK_SHADER_STAGE_COMPUTE_BIT) {
        layout_ =
            make_pipeline_layout(ctx_, sets_.layout(), sizeof(gpu::MomentPassParams), VK_SHADER_STAGE_COMPUTE_BIT);
        nearest_ = make_sampler(ctx_, false, false, false);
        // The lookup samples moments as engines do: bilinear, trilinear across the mip levels, the
        // map's edge texels repeated beyond it.
        VkSamplerCreateInfo ci{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
        ci.magFilter = ci.minFilter = VK_FILTER_LINEAR;
        ci.mipmapMode = VK_SAMPLER_MIPMAP_MODE_LINEAR;
        ci.addressModeU = ci.addressModeV = ci.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
        ci.maxLod = VK_LOD_CLAMP_NONE;
        VkSampler sampler;
        VK_CHECK(vkCreateSampler(ctx_.device(), &ci, nullptr, &sampler));
        sampler_ = UniqueSampler(ctx_.device(), sampler);
    }

    void check_supported(const Technique& t) override {
        const MomentParameters* m = moment_parameters(t);
        if (!m) return;
        // The moment passes write one shader into each family's format, and the lookup filters it.
        VkFormatFeatureFlags need = VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT | VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT |
                                    VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT;
        if (m->mipmaps) need |= VK_FORMAT_FEATURE_BLIT_SRC_BIT | VK_FORMAT_FEATURE_BLIT_DST_BIT;
        if (!ctx_.storage_write_without_format() || !ctx_.supports_format_features(moment_format(*m), need))
            throw EnvironmentError(
                fmt::format("Vulkan device '{}' cannot store, filter{} the {} family's moments (format {}, "
                            "shaderStorageImageWriteWithoutFormat {})",
                            ctx_.info().name, m->mipmaps ? " and blit" : " and", to_string(m->kind),
                            static_cast<int>(moment_format(*m)), ctx_.storage_write_without_format() ? "on" : "off"));
    }

    // Per map the moments (level 0, then the mip chain) and the blur's scratch, both kept in GENERAL.
    void ensure_map_resources(const Technique& t, std::span<const MapShape> maps,
                              std::span<const GpuImage* const> depth, bool remade) override {
        const MomentParameters* m = moment_parameters(t);
        if (!m) return;
        const VkFormat format = moment_format(*m);
        const std::uint32_t levels = m->mipmaps && !maps.empty() ? mip_levels(maps[0].resolution) : 1;
        if (!remade && format == format_ && levels == levels_ &&
            std::equal(maps.begin(), maps.end(), shapes_.begin(), shapes_.end()))
            return;
        textures_.clear();
        arena_ = MemoryArena(ctx_);
        textures_.resize(maps.size());
        const VkImageUsageFlags usage = VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
        for (std::size_t i = 0; i < maps.size(); ++i) {
            const std::uint32_t res = maps[i].resolution, layers = maps[i].layers;
            arena_.add(textures_[i].moments, format, res, res, layers,
                       usage | VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                       VK_IMAGE_ASPECT_COLOR_BIT, true, levels);
            arena_.add(textures_[i].scratch, format, res, res, layers, usage, VK_IMAGE_ASPECT_COLOR_BIT, true);
        }
        arena_.commit();
        sets_.reserve(kMomentSetsPerMap * textures_.size());
        for (std::size_t i = 0; i < textures_.size(); ++i) {
            Textures& x = textures_[i];
            x.moments_target = create_level_view(ctx_, x.moments, 0, VK_IMAGE_ASPECT_COLOR_BIT);
            x.scratch_target = create_level_view(ctx_, x.scratch, 0, VK_IMAGE_ASPECT_COLOR_BIT);
            std::array<DescriptorResource, kMomentBindings.size()> r{};
            r[0].image = {nearest_.get(), depth[i]->view.get(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
            r[1].image = {VK_NULL_HANDLE, x.moments_target.get(), VK_IMAGE_LAYOUT_GENERAL};
            sets_.write(kMomentSetsPerMap * i, r);
            r[0].image = {nearest_.get(), x.moments.view.get(), VK_IMAGE_LAYOUT_GENERAL};
            r[1].image = {VK_NULL_HANDLE, x.scratch_target.get(), VK_IMAGE_LAYOUT_GENERAL};
            sets_.write(kMomentSetsPerMap * i + 1, r);
            r[0].image = {nearest_.get(), x.scratch.view.get(), VK_IMAGE_LAYOUT_GENERAL};
            r[1].image = {VK_NULL_HANDLE, x.moments_target.get(), VK_IMAGE_LAYOUT_GENERAL};
            sets_.write(kMomentSetsPerMap * i + 2, r);
        }
        format_ = format;
        levels_ = levels;
        shapes_.assign(maps.begin(), maps.end());
    }

    // The moment textures live in GENERAL: written by the passes, blitted, sampled.
    void record_layouts(VkCommandBuffer cmd) override {
        for (Textures& x : textures_) {
            if (x.in_general) continue;
            for (GpuImage* img : {&x.moments, &x.scratch})
                image_barrier(cmd, img->image.get(), VK_IMAGE_ASPECT_COLOR_BIT, img->layers, VK_IMAGE_LAYOUT_UNDEFINED,
                              VK_IMAGE_LAYOUT_GENERAL, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE,
                              VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT);
            x.in_general = true;
        }
    }

    // The moments follow the map and the family's parameters: a reused map with the same
    // parameters keeps them. Marks after the moments, the blur and the mip chain.
    std::uint32_t timed_passes() const override { return 3; }
    void record_after_map(VkCommandBuffer cmd, const Technique& t, const MapTargets& map, PassMarks& marks) override {
        const MomentParameters* m = moment_parameters(t);
        Textures* x = m ? &textures_[map.map_index] : nullptr;
        if (x && map.redrawn) x->of.reset();
        if (x && map.layers_sampled != 0) {
            const std::array<double, 7> of = {static_cast<double>(map.depth->width),
                                              static_cast<double>(m->kind),
                                              m->exponent,
                                              m->negative_exponent,
                                              static_cast<double>(m->storage_bits),
                                              static_cast<double>(m->blur),
                                              m->mipmaps ? 1.0 : 0.0};
            if (x->of != of || x->layers_of != map.layers_sampled || x->views_of != map.projection->view_proj) {
                record_moments(cmd, *m, t.reversed_z, map, marks);
                x->of = of;
                x->layers_of = map.layers_sampled;
                x->views_of = map.projection->view_proj;
                return;
            }
        }
        for (int k = 0; k < 3; ++k) marks.mark(cmd);  // no moment pass: its marks at once
    }
    void add_times(const Technique& t, const std::function<double(std::uint32_t)>& ms,
                   PassTimes& times) const override {
        const MomentParameters* m = moment_parameters(t);
        if (!m) return;
        times.add("moments", ms(0), kMomentsPass);
        if (m->blur > 0) times.add("blur", ms(1), kBlurPass);
        if (m->mipmaps) times.add("mipmaps", ms(2), kMipmapPass);
    }

    std::optional<LookupShader> lookup_shader(const Technique& t, const Light&) const override {
        const MomentParameters* m = moment_parameters(t);
        if (!m) return std::nullopt;
        // Specialisation constant kSpecFilter is the moment kind; the blur is its own pass.
        return LookupShader{kFilterableLookupComp, sizeof(kFilterableLookupComp), static_cast<std::uint32_t>(m->kind),
                            0};
    }
    void fill_params(gpu::LookupParams& p, const Technique& t, const Light&, const LightProjection&) const override {
        const MomentParameters* m = moment_parameters(t);
        if (!m) return;
        p.moments = moment_uniform(*m);
        p.moment_map =
            glm::vec4(static_cast<float>(m->mipmaps ? mip_levels(static_cast<std::uint32_t>(t.resolution)) : 1),
                      m->kind == MomentKind::msm && m->storage_bits == 16 ? 1.0f : 0.0f, 0.0f, 0.0f);
    }
    std::optional<VkDescriptorImageInfo> family_image(const Technique& t, std::size_t map) const override {
        if (!moment_parameters(t)) return std::nullopt;
        return VkDescriptorImageInfo{sampler_.get(), textures_[map].moments.view.get(), VK_IMAGE_LAYOUT_GENERAL};
    }

  private:
    struct Textures {
        GpuImage moments, scratch;
        UniqueImageView moments_target, scratch_target;  // level 0, every layer: the storage views
        bool in_general = false;
        // What they hold: the map's size and the parameters, its sampled layers and views.
        std::optional<std::array<double, 7>> of;
        std::uint32_t layers_of = 0;
        std::vector<glm::dmat4> views_of;
    };

    VkPipeline pipeline(const MomentParameters& m, gpu::uint pass) {
        const std::array<std::uint32_t, 3> spec = {static_cast<std::uint32_t>(m.kind), pass,
                                                   static_cast<std::uint32_t>(m.blur)};
        UniquePipeline& p = pipelines_[spec];
        if (!p)
            p = make_compute_pipeline(ctx_, layout_.get(), kFilterableMomentsComp, sizeof(kFilterableMomentsComp),
                                      spec);
        return p.get();
    }

    // The moments of every sampled layer, the separable blur, the mip chain, each marked after.
    // Every pass reads what the one before wrote: a memory barrier between them (the textures
    // stay in GENERAL).
    void record_moments(VkCommandBuffer cmd, const MomentParameters& m, bool reversed_z, const MapTargets& map,
                        PassMarks& marks) {
        Textures& x = textures_[map.map_index];
        const auto res = map.depth->width;
        const std::uint32_t layer_count = static_cast<std::uint32_t>(map.projection->view_proj.size());
        const gpu::MomentPassParams base{
            glm::vec4(static_cast<float>(m.exponent), static_cast<float>(m.negative_exponent),
                      m.kind == MomentKind::msm && m.storage_bits == 16 ? 1.0f : 0.0f, 0.0f),
            glm::uvec4(0u, res, reversed_z ? 1u : 0u, 0u)};  // moments of forward depth
        auto dispatch = [&](gpu::uint pass, std::size_t set_index) {
            vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline(m, pass));
            VkDescriptorSet set = sets_[kMomentSetsPerMap * map.map_index + set_index];
            vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_.get(), 0, 1, &set, 0, nullptr);
            for (std::uint32_t layer = 0; layer < layer_count; ++layer) {
                if (!(map.layers_sampled & (1u << layer))) continue;
                gpu::MomentPassParams push = base;
                push.layer.x = layer;
                vkCmdPushConstants(cmd, layout_.get(), VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
                vkCmdDispatch(cmd, (res + 7) / 8, (res + 7) / 8, 1);
            }
        };
        auto compute_to_compute = [&] {
            memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                           VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                           VK_ACCESS_2_SHADER_SAMPLED_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
        };
        // The previous light's or render's lookup and blits may still read the textures.
        memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_BLIT_BIT,
                       VK_ACCESS_2_SHADER_SAMPLED_READ_BIT | VK_ACCESS_2_TRANSFER_READ_BIT,
                       VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
        dispatch(gpu::kMomentPassWarp, 0);
        compute_to_compute();
        marks.mark(cmd);
        if (m.blur > 0) {
            dispatch(gpu::kMomentPassBlurX, 1);
            compute_to_compute();
            dispatch(gpu::kMomentPassBlurY, 2);
            compute_to_compute();
        }
        marks.mark(cmd);
        if (x.moments.levels > 1) {
            memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                           VK_PIPELINE_STAGE_2_BLIT_BIT,
                           VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT);
            for (std::uint32_t level = 1; level < x.moments.levels; ++level) {
                const auto from = static_cast<std::int32_t>(std::max(res >> (level - 1), 1u));
                const auto to = static_cast<std::int32_t>(std::max(res >> level, 1u));
                VkImageBlit blit{};
                blit.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level - 1, 0, x.moments.layers};
                blit.srcOffsets[1] = {from, from, 1};
                blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level, 0, x.moments.layers};
                blit.dstOffsets[1] = {to, to, 1};
                vkCmdBlitImage(cmd, x.moments.image.get(), VK_IMAGE_LAYOUT_GENERAL, x.moments.image.get(),
                               VK_IMAGE_LAYOUT_GENERAL, 1, &blit, VK_FILTER_LINEAR);
                memory_barrier(cmd, VK_PIPELINE_STAGE_2_BLIT_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                               VK_PIPELINE_STAGE_2_BLIT_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
            }
            memory_barrier(cmd, VK_PIPELINE_STAGE_2_BLIT_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                           VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT);
        }
        marks.mark(cmd);
    }

    const VulkanContext& ctx_;
    DescriptorSets sets_;
    UniquePipelineLayout layout_;
    UniqueSampler nearest_, sampler_;
    std::map<std::array<std::uint32_t, 3>, UniquePipeline> pipelines_;
    // The arena before what is bound to it: destroyed after it.
    MemoryArena arena_;
    std::vector<Textures> textures_;
    VkFormat format_ = VK_FORMAT_UNDEFINED;
    std::uint32_t levels_ = 0;
    std::vector<MapShape> shapes_;  // what textures_ were made for
};

std::unique_ptr<TechniqueFamily> make_moment_family(const SceneOnGpu& scene) {
    DepthMapVariants variants;
    variants.push_back(std::make_unique<MomentsVariant>(scene));
    return make_depth_map_core(scene, std::move(variants));
}

// A moment knob: the MomentParameters field `field`, drawn at most at `most`.
KnobDecl moment_knob(const char* name, std::string key, const char* unit, double lower, double upper,
                     double MomentParameters::*field, double most = std::numeric_limits<double>::infinity()) {
    KnobDecl k;
    k.name = name;
    k.key = std::move(key);
    k.unit = unit;
    k.lower = lower;
    k.upper = upper;
    k.scope = KnobScope::technique;
    k.by_default = true;
    k.read = [field](const Technique& t) { return parameters_of(t).*field; };
    k.write = [field, most](Technique& t, double v) {
        auto p = std::make_shared<MomentParameters>(parameters_of(t));
        p.get()->*field = std::min(v, most);
        t.family_parameters = std::move(p);
    };
    return k;
}

// The family's tune knobs (docs/tune.md, "Knobs"), each the technique's (one value for every
// light), ranged around its default up to where it stops making sense: the variance floor and
// the light-bleed reduction (vsm, evsm; the reduction drawn at most 0.999), the exponent (esm's
// c up to its float32 cap; evsm's positive one, searched over the same range and drawn at most
// at its own cap of 42), msm's moment bias.
std::vector<KnobDecl> moment_knobs(MomentKind kind) {
    if (kind == MomentKind::esm)
        return {moment_knob("exponent", "esm.exponent", "exponent", 1, kMaxEsmExponent, &MomentParameters::exponent,
                            kMaxEsmExponent)};
    if (kind == MomentKind::msm)
        return {moment_knob("moment_bias", "msm.moment_bias", "fraction", 1e-7, 1e-2, &MomentParameters::moment_bias)};
    const std::string own = kind == MomentKind::vsm ? "vsm" : "evsm";
    std::vector<KnobDecl> k = {moment_knob("min_variance", own + ".min_variance", "squared depth units", 1e-9, 1e-2,
                                           &MomentParameters::min_variance),
                               moment_knob("light_bleed", own + ".light_bleed", "fraction", 1e-2, 0.95,
                                           &MomentParameters::light_bleed, 0.999)};
    if (kind != MomentKind::vsm)
        k.push_back(moment_knob("exponent", "evsm.exponents", "exponent", 1, kMaxEsmExponent,
                                &MomentParameters::exponent, kMaxEvsmExponent));
    return k;
}

FamilyEntry moment_family_entry(MomentKind kind, std::string description) {
    FamilyEntry e = depth_map_family_entry();
    e.name = to_string(kind);
    e.description = std::move(description);
    e.parse = [kind](JsonObject& o, Technique& t) { parse_moment_keys(kind, o, t); };
    e.write = [](const Technique& t, nlohmann::json& j) { j.update(moment_keys_json(t)); };
    e.hints = [](const Technique& t) {
        // The filter reaches the blur radius plus the bilinear tap's texel; light bleeding is
        // a class of its own for these families (docs/metrics.md).
        ScoringHints h = depth_map_family_entry().hints(t);
        h.filter_reach_texels = 1.0 + parameters_of(t).blur;
        h.light_bleeding = true;
        return h;
    };
    e.make = make_moment_family;
    e.describe_light = [](const Technique& t, const Light&, const RasterLightStats&) {
        const MomentParameters& p = parameters_of(t);
        return nlohmann::json{
            {"moments",
             {{"kind", to_string(p.kind)},
              {"count", p.kind == MomentKind::esm                                  ? 1
                        : p.kind == MomentKind::evsm4 || p.kind == MomentKind::msm ? 4
                                                                                   : 2},
              {"blur_texels", p.blur},
              {"format", p.kind == MomentKind::msm && p.storage_bits == 16          ? "rgba16_unorm"
                         : p.kind == MomentKind::esm                                ? "r32_sfloat"
                         : p.kind == MomentKind::vsm || p.kind == MomentKind::evsm2 ? "rg32_sfloat"
                                                                                    : "rgba32_sfloat"},
              {"sampled", p.mipmaps ? "trilinear" : "bilinear"},
              {"gathered_in_lookup", false}}}};
    };
    e.memory = [](const Technique& t) {
        // The depth map, and the moment texture with the blur's scratch (a third more with the
        // mip chain), counted as bytes of a map texel.
        const MomentParameters& p = parameters_of(t);
        RasterMemory m = depth_map_family_entry().memory(t);
        const int texel = p.kind == MomentKind::esm                                  ? 4
                          : p.kind == MomentKind::vsm || p.kind == MomentKind::evsm2 ? 8
                          : p.kind == MomentKind::msm && p.storage_bits == 16        ? 8
                                                                                     : 16;
        m.depth_bytes += texel + (p.mipmaps ? (texel * 4 + 2) / 3 : texel);
        return m;
    };
    // The depth-map biases stay keys, not knobs: the family's defaults leave them off.
    e.sweep_keys = sweep_keys_of(depth_map_family_entry());
    std::erase_if(e.sweep_keys, [](const std::string& k) { return k.rfind("filter.", 0) == 0; });
    for (const char* k : {"blur", "mipmaps"}) e.sweep_keys.push_back(k);
    if (kind == MomentKind::msm)
        for (const char* k : {"msm.variant", "msm.storage"}) e.sweep_keys.push_back(k);
    e.knobs = moment_knobs(kind);
    return e;
}

}  // namespace

void add_filterable_families(std::deque<FamilyEntry>& families) {
    families.push_back(
        moment_family_entry(MomentKind::vsm,
                            "variance shadow maps (Donnelly & Lauritzen 2006): two moments, Chebyshev's bound with a "
                            "variance floor and light-bleed reduction; \"blur\" texels of separable Gaussian"));
    families.push_back(moment_family_entry(
        MomentKind::esm, "exponential shadow maps (Annen et al. 2008): exp(c d) filtered, visibility exp(c (d - z))"));
    families.push_back(
        moment_family_entry(MomentKind::evsm2,
                            "exponential variance shadow maps (Lauritzen & McCool 2008): Chebyshev on the positive "
                            "exponential warp of depth in [-1, 1]"));
    families.push_back(
        moment_family_entry(MomentKind::evsm4,
                            "exponential variance shadow maps (Lauritzen & McCool 2008): positive and negative "
                            "warps, the smaller Chebyshev bound"));
    families.push_back(
        moment_family_entry(MomentKind::msm,
                            "moment shadow maps (Peters & Klein 2015): four moments, the sharpest lower bound on the "
                            "shadow (Hamburger or Hausdorff), 32-bit or optimised 16-bit storage"));
}

}  // namespace penumbra::raster
