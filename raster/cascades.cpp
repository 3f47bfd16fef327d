// The cascaded family (raster/cascades.h): its keys, the placement of the splits, and its variant
// of the depth-map core (raster/depth_map.h), which gives a directional light one layer per
// cascade, with SDSM's reduction (raster/cascades_sdsm.comp) and its lookup
// (raster/cascades_lookup.comp); spot, point and area lights are drawn as the depth_map family
// draws them.
#include "raster/cascades.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include "common/camera.h"
#include "common/json_reader.h"
#include "raster/depth_map.h"
#include "raster/technique_family.h"
#include "shaders/penumbra_shared.h"
// SPIR-V compiled from raster/cascades_*.comp at build time.
#include "cascades_lookup_comp.h"
#include "cascades_sdsm_comp.h"

namespace penumbra::raster {

const char* to_string(CascadeSplit s) {
    static const char* const kNames[] = {"practical", "uniform", "log", "geometric", "fractions"};
    return kNames[static_cast<int>(s)];
}
const char* to_string(CascadeFit f) {
    static const char* const kNames[] = {"sphere", "bounds"};
    return kNames[static_cast<int>(f)];
}

double uniform_split(double near, double far, int i, int count) {
    return near + (far - near) * i / count;
}

double log_split(double near, double far, int i, int count) {
    return near * std::pow(far / near, static_cast<double>(i) / count);
}

double practical_split(double near, double far, int i, int count, double lambda) {
    return lambda * log_split(near, far, i, count) + (1 - lambda) * uniform_split(near, far, i, count);
}

double geometric_split(double first_far, double far, int i, int count) {
    if (count == 1) return far;
    return first_far * std::pow(far / first_far, static_cast<double>(i - 1) / (count - 1));
}

std::vector<double> cascade_far_bounds(const Cascades& c, double near, double far) {
    std::vector<double> bounds;
    for (int i = 1; i <= c.count; ++i) {
        double b = far;
        switch (c.split) {
            case CascadeSplit::uniform: b = uniform_split(near, far, i, c.count); break;
            case CascadeSplit::log: b = log_split(near, far, i, c.count); break;
            case CascadeSplit::practical: b = practical_split(near, far, i, c.count, c.lambda); break;
            case CascadeSplit::geometric: b = geometric_split(c.first_far.value_or(far), far, i, c.count); break;
            case CascadeSplit::fractions:
                b = i - 1 < static_cast<int>(c.fractions.size()) ? c.fractions[i - 1] * far : far;
                break;
        }
        bounds.push_back(i == c.count ? far : b);  // the last ends exactly at the range's end
    }
    return bounds;
}

std::vector<double> sdsm_far_bounds(const Cascades& c, double near, double far, double lo, double hi) {
    lo = std::clamp(lo, near, far);
    hi = std::clamp(hi, lo, far);
    if (!(hi > lo)) hi = std::min(far, lo + std::max(1e-6, 1e-6 * std::abs(lo)));  // one depth seen
    if (c.split == CascadeSplit::fractions) {
        std::vector<double> bounds;
        for (int i = 1; i <= c.count; ++i)
            bounds.push_back(
                i < c.count && i - 1 < static_cast<int>(c.fractions.size()) ? lo + c.fractions[i - 1] * (hi - lo) : hi);
        return bounds;
    }
    Cascades scaled = c;
    if (c.split == CascadeSplit::geometric && c.first_far)
        scaled.first_far = lo + (*c.first_far - near) / (far - near) * (hi - lo);
    return cascade_far_bounds(scaled, lo, hi);
}

const char* cascade_bias_scaling(const Technique& t, std::string_view key) {
    const Cascades* c = cascades_of(t);
    if (!c) return "";
    if (key == "bias.slope" || key == "bias.normal_offset") return "texel_scaled";
    if (key == "bias.world" || key == "bias.constant") return c->texel_scaled_bias ? "texel_scaled" : "same";
    return "same";
}

const Cascades* cascades_of(const Technique& t) {
    return t.family == "cascaded" ? t.parameters<Cascades>() : nullptr;
}

namespace {

Cascades parse_cascades(JsonObject& o) {
    Cascades c;
    const bool has_fractions = o.has("fractions");
    if (has_fractions) {
        const nlohmann::json& f = o.get("fractions");
        if (!f.is_array() || f.empty())
            o.fail("fractions", "expected a non-empty array of fractions of max_distance, e.g. [0.1, 0.2, 0.5]");
        double previous = 0;
        for (const nlohmann::json& x : f) {
            if (!x.is_number()) o.fail("fractions", "expected numbers");
            const double v = x.get<double>();
            if (!(v > previous && v <= 1))
                o.fail("fractions", fmt::format("{} is not increasing in (0, 1] (fractions of max_distance)", v));
            previous = v;
            c.fractions.push_back(v);
        }
        // The last cascade ends at max_distance: a trailing 1 says so, and is implied without it.
        if (c.fractions.back() == 1.0) c.fractions.pop_back();
    }
    const int implied = static_cast<int>(c.fractions.size()) + 1;
    c.count = static_cast<int>(o.integer("count", has_fractions ? implied : 4, 1, kMaxCascades));
    c.split = pick_enum(o, "split", has_fractions ? CascadeSplit::fractions : CascadeSplit::practical,
                        {CascadeSplit::practical, CascadeSplit::uniform, CascadeSplit::log, CascadeSplit::geometric,
                         CascadeSplit::fractions});
    c.lambda = o.number_in("lambda", 0.5, 0.0, 1.0, "a weight in [0, 1]");
    if (o.has("first_far")) c.first_far = o.number_in("first_far", 1e-6, 1e12, "metres > 0");
    if (o.has("max_distance")) c.max_distance = o.number_in("max_distance", 1e-6, 1e12, "metres > 0");
    c.overlap = o.number_in("overlap", 0.0, 0.0, 0.5, "a fraction in [0, 0.5]");
    c.fit = pick_enum(o, "fit", CascadeFit::sphere, {CascadeFit::sphere, CascadeFit::bounds});
    c.stabilize = o.boolean("stabilize", true);
    c.sdsm = o.boolean("sdsm", false);
    c.texel_scaled_bias = o.boolean("texel_scaled_bias", false);
    if (c.split == CascadeSplit::fractions) {
        if (c.fractions.empty() && c.count > 1)
            o.fail("split", "\"fractions\" needs the fractions key, e.g. \"fractions\": [0.1, 0.2, 0.5]");
        if (implied != c.count)
            o.fail("fractions",
                   fmt::format("{} fractions end {} cascades, but count is {}", c.fractions.size(), implied, c.count));
    } else if (has_fractions) {
        o.fail("fractions",
               fmt::format("only split \"fractions\" reads fractions (split is \"{}\")", to_string(c.split)));
    }
    if (c.split == CascadeSplit::geometric) {
        if (!c.first_far) o.fail("split", "\"geometric\" needs first_far, the first cascade's far bound in metres");
        if (c.max_distance && *c.first_far >= *c.max_distance)
            o.fail("first_far", fmt::format("{} m is not less than max_distance {} m", *c.first_far, *c.max_distance));
    } else if (c.first_far) {
        o.fail("first_far",
               fmt::format("only split \"geometric\" reads first_far (split is \"{}\")", to_string(c.split)));
    }
    o.finish();
    return c;
}

nlohmann::json cascades_json(const Cascades& c) {
    nlohmann::json j = {{"count", c.count},        {"split", to_string(c.split)},
                        {"lambda", c.lambda},      {"overlap", c.overlap},
                        {"fit", to_string(c.fit)}, {"stabilize", c.stabilize},
                        {"sdsm", c.sdsm},          {"texel_scaled_bias", c.texel_scaled_bias}};
    if (c.first_far) j["first_far"] = *c.first_far;
    if (!c.fractions.empty()) j["fractions"] = c.fractions;
    if (c.max_distance) j["max_distance"] = *c.max_distance;
    return j;
}

}  // namespace

namespace {

// SDSM's reduction (raster/cascades_sdsm.comp): the camera pass's triangles and the scene, and the range.
constexpr std::array<BindingDecl, 4> kSdsmBindings = {{
    {gpu::kBindingGBufferPrim, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE},
    {gpu::kBindingPositions, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
    {gpu::kBindingIndices, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
    {gpu::kBindingSdsmRange, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
}};
constexpr const char* kSdsmReduce =
    "SDSM's compute pass (Lauritzen et al. 2011): the least and greatest view depth of the visible samples, "
    "reduced on the GPU for the cascades' splits, once per render";

// A sun of the cascaded family has a layer per cascade.
const Cascades* cascades_for(const Technique& t, const Light& l) {
    return l.type == LightType::directional ? cascades_of(t) : nullptr;
}

// The cascaded family's variant of the depth-map core: a sun's layers are its cascades, each
// fitted to its slice of view depth (fit_cascades), all drawn, with its own texel and (with
// texel_scaled_bias) constant bias; the lookup selects and blends them
// (raster/cascades_lookup.comp). Spot, point and area lights are the core's.
class CascadesVariant final : public DepthMapVariant {
  public:
    explicit CascadesVariant(const SceneOnGpu& scene)
        : s_(scene),
          ctx_(scene.ctx),
          sdsm_sets_(scene.ctx, kSdsmBindings, VK_SHADER_STAGE_COMPUTE_BIT),
          sdsm_timer_(scene.ctx) {}

    std::optional<std::uint32_t> layers(const Technique& t, const Light& l) const override {
        if (const Cascades* c = cascades_for(t, l)) return static_cast<std::uint32_t>(c->count);
        return std::nullopt;
    }
    void begin_render(const Technique& t, std::span<const Light> lights, RasterStats& stats) override {
        samples_.reset();
        const Cascades* c = cascades_of(t);
        if (c && c->sdsm &&
            std::any_of(lights.begin(), lights.end(), [&](const Light& l) { return cascades_for(t, l); }))
            samples_ = reduce_view_depth(stats);
    }
    std::optional<LightProjection> fit(const Technique& t, const Light& l,
                                       const glm::dvec3& fit_origin) const override {
        if (!cascades_for(t, l)) return std::nullopt;
        const Scenario& sc = s_.scenario;
        return fit_for_technique(l, sc.scene, s_.camera, sc.width, sc.height, t, fit_origin, samples_);
    }
    // Every cascade is drawn: slices are cut to what the camera sees.
    bool draws_every_layer(const Technique& t, const Light& l) const override { return cascades_for(t, l) != nullptr; }
    // texel_scaled_bias: each cascade's constant scaled as its texel (cascade_bias_scale).
    double constant_scale(const Technique& t, const Light& l, const LightProjection& projection,
                          std::uint32_t layer) const override {
        const Cascades* c = cascades_for(t, l);
        return c ? cascade_bias_scale(projection, layer, c->texel_scaled_bias).y : 1.0;
    }
    std::optional<LookupShader> lookup_shader(const Technique& t, const Light& l) const override {
        if (!cascades_for(t, l)) return std::nullopt;
        return LookupShader{kCascadesLookupComp, sizeof(kCascadesLookupComp), filter_kind(t.filter.type),
                            static_cast<std::uint32_t>(t.filter.size)};
    }
    // Per cascade (4 a vec4): the far end of its slice, its texel, its bias factors.
    void fill_params(gpu::LookupParams& p, const Technique& t, const Light&,
                     const LightProjection& projection) const override {
        p.cascade = glm::vec4(static_cast<float>(projection.cascade_texel.size()),
                              static_cast<float>(projection.cascade_overlap), 0.0f, 0.0f);
        const Cascades* cascades = cascades_of(t);
        const bool texel_scaled = cascades && cascades->texel_scaled_bias;
        for (std::size_t k = 0; k < projection.cascade_texel.size(); ++k) {
            p.cascade_far[k / 4][static_cast<int>(k % 4)] = static_cast<float>(projection.cascade_far[k]);
            p.cascade_texel[k / 4][static_cast<int>(k % 4)] = static_cast<float>(projection.cascade_texel[k]);
            const glm::dvec2 scale = cascade_bias_scale(projection, k, texel_scaled);
            p.cascade_world_scale[k / 4][static_cast<int>(k % 4)] = static_cast<float>(scale.x);
            p.cascade_constant_scale[k / 4][static_cast<int>(k % 4)] = static_cast<float>(scale.y);
        }
    }

  private:
    std::optional<glm::dvec2> reduce_view_depth(RasterStats& stats);

    const SceneOnGpu& s_;
    const VulkanContext& ctx_;
    std::optional<glm::dvec2> samples_;  // this render's SDSM range, when reduced
    // SDSM's reduction, made on first use.
    DescriptorSets sdsm_sets_;
    UniquePipelineLayout sdsm_layout_;
    UniquePipeline sdsm_pipeline_;
    GpuBuffer sdsm_range_;
    GpuTimestamps sdsm_timer_;
};

// SDSM (Lauritzen, Salvi and Lefohn, I3D 2011): one compute pass over the camera pass's pixels
// reduces the view depth of every visible sample to its least and greatest, timed as
// "sdsm_reduce"; the cascades' splits are then placed between them. Unset when no pixel sees a
// surface (the camera's range is used).
std::optional<glm::dvec2> CascadesVariant::reduce_view_depth(RasterStats& stats) {
    if (!sdsm_pipeline_) {
        sdsm_sets_.reserve(1);
        sdsm_range_ = create_buffer(ctx_, 2 * sizeof(std::uint32_t), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true);
        std::array<DescriptorResource, kSdsmBindings.size()> r{};
        r[0].image = {VK_NULL_HANDLE, s_.gbuffer_prim.view.get(), VK_IMAGE_LAYOUT_GENERAL};
        r[1].buffer = {s_.positions.buffer.get(), 0, VK_WHOLE_SIZE};
        r[2].buffer = {s_.indices.buffer.get(), 0, VK_WHOLE_SIZE};
        r[3].buffer = {sdsm_range_.buffer.get(), 0, VK_WHOLE_SIZE};
        sdsm_sets_.write(0, r);
        sdsm_layout_ =
            make_pipeline_layout(ctx_, sdsm_sets_.layout(), sizeof(gpu::SdsmParams), VK_SHADER_STAGE_COMPUTE_BIT);
        sdsm_pipeline_ =
            make_compute_pipeline(ctx_, sdsm_layout_.get(), kCascadesSdsmComp, sizeof(kCascadesSdsmComp), {});
        sdsm_timer_.ensure(2);
    }
    const Scenario& sc = s_.scenario;
    const Camera& cam = sc.camera;
    const glm::dvec2 plane = ndc_to_image_plane(cam, sc.width, sc.height);
    gpu::SdsmParams params{};
    params.cam_forward = glm::vec4(glm::vec3(cam.forward), cam.type == ProjectionType::perspective ? 1.0f : 0.0f);
    params.cam_right = glm::vec4(glm::vec3(cam.right), static_cast<float>(plane.x));
    params.cam_up = glm::vec4(glm::vec3(cam.up), static_cast<float>(plane.y));
    params.image = glm::vec4(sc.width, sc.height, 1.0f / sc.width, 1.0f / sc.height);
    const std::uint32_t empty[2] = {0xFFFFFFFFu, 0u};
    std::memcpy(sdsm_range_.mapped, empty, sizeof(empty));
    ctx_.submit_and_wait([&](VkCommandBuffer cmd) {
        sdsm_timer_.reset(cmd, 0, 2);
        sdsm_timer_.write(cmd, 0);
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, sdsm_pipeline_.get());
        VkDescriptorSet set = sdsm_sets_[0];
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, sdsm_layout_.get(), 0, 1, &set, 0, nullptr);
        vkCmdPushConstants(cmd, sdsm_layout_.get(), VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(params), &params);
        vkCmdDispatch(cmd, (s_.width + 7) / 8, (s_.height + 7) / 8, 1);
        sdsm_timer_.write(cmd, 1);
        memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
    });
    sdsm_timer_.read(0, 2);
    stats.gpu_ms.add("sdsm_reduce", sdsm_timer_.ms(0, 1), kSdsmReduce);
    std::uint32_t range[2];
    std::memcpy(range, sdsm_range_.mapped, sizeof(range));
    if (range[0] > range[1]) return std::nullopt;
    const auto unordered = [](std::uint32_t u) {
        const std::uint32_t bits = (u & 0x80000000u) != 0 ? u & 0x7FFFFFFFu : ~u;
        float f;
        std::memcpy(&f, &bits, sizeof(f));
        return static_cast<double>(f);
    };
    return glm::dvec2(unordered(range[0]), unordered(range[1]));
}

std::unique_ptr<TechniqueFamily> make_cascaded_family(const SceneOnGpu& scene) {
    DepthMapVariants variants;
    variants.push_back(std::make_unique<CascadesVariant>(scene));
    return make_depth_map_core(scene, std::move(variants));
}

}  // namespace

FamilyEntry cascaded_family_entry() {
    // The depth map's keys, scoring and drawing, with a layer per cascade for directional lights.
    FamilyEntry e = depth_map_family_entry();
    e.name = "cascaded";
    e.description =
        "cascaded shadow maps: a directional light's view depth split into technique.cascades.count slices, one "
        "map each (resolution, bias and filter per cascade); other lights drawn as depth_map draws them";
    e.parse = [](JsonObject& o, Technique& t) {
        parse_depth_map_keys(o, t);
        if (o.has("area_samples") && o.integer("area_samples", 0, 256) > 0)
            o.fail("area_samples", "only the averaged_area family draws area samples (\"family\": \"averaged_area\")");
        Cascades c;
        if (o.has("cascades")) {
            JsonObject co = o.object("cascades");
            c = parse_cascades(co);
        }
        t.family_parameters = std::make_shared<const Cascades>(c);
    };
    e.make = make_cascaded_family;
    e.hints = [](const Technique& t) {
        ScoringHints h = depth_map_family_entry().hints(t);
        h.layer_report = "cascades";
        return h;
    };
    e.write = [](const Technique& t, nlohmann::json& j) {
        j.update(depth_map_keys_json(t));
        j["area_samples"] = 0;
        const Cascades* c = cascades_of(t);
        j["cascades"] = cascades_json(c ? *c : Cascades{});
    };
    e.memory = [](const Technique& t) {
        RasterMemory m = depth_map_family_entry().memory(t);
        const Cascades* c = cascades_of(t);
        m.directional_layers = c ? c->count : Cascades{}.count;
        return m;
    };
    // raster.json: with SDSM, the view depths the splits were placed between.
    e.describe_light = [](const Technique& t, const Light& light, const RasterLightStats& stats) {
        nlohmann::json j = depth_map_family_entry().describe_light(t, light, stats);
        if (const auto& r = stats.projection.sdsm_range) j["sdsm"] = {{"near_m", r->x}, {"far_m", r->y}};
        return j;
    };
    for (const char* key :
         {"cascades.count", "cascades.split", "cascades.lambda", "cascades.first_far", "cascades.max_distance",
          "cascades.overlap", "cascades.fit", "cascades.stabilize", "cascades.sdsm", "cascades.texel_scaled_bias"})
        e.sweep_keys.push_back(key);
    // tune.json says per knob how a cascaded technique applies it per cascade (docs/tune.md).
    for (KnobDecl& k : e.knobs)
        k.describe = [key = k.key](const Technique& t) {
            nlohmann::json j = nlohmann::json::object();
            if (const char* scaling = cascade_bias_scaling(t, key); *scaling) j["cascades"] = scaling;
            return j;
        };
    return e;
}

}  // namespace penumbra::raster
