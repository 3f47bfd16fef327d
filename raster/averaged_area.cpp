// The averaged-hard-shadows family (reference 001; raster/area_lights.h): each area light is
// drawn as technique.area_samples point lights spread over it by the depth-map family, and
// their verdicts are averaged. Punctual lights pass through unchanged, with their lookups.
#include <algorithm>

#include "common/memory_estimate.h"
#include "raster/area_lights.h"
#include "raster/technique_family.h"

namespace penumbra::raster {

namespace {

// Area-light samples drawn in one pass of the depth-map family: bounds the memory and the
// allocations of a render whatever area_samples is (one V buffer per drawn sample).
constexpr std::size_t kSamplesPerPass = kAveragedSamplesAtOnce;  // common/memory_estimate.h: the estimate follows it

// area_samples of a technique that names "family": "averaged_area" without it (the
// averaged-hard-shadows preset's count).
constexpr int kDefaultAreaSamples = 16;

// `part`'s times and warnings added to `into`.
void add_stats(RasterStats& into, const RasterStats& part) {
    into.hw2x2 = part.hw2x2;
    into.gpu_ms.add(part.gpu_ms);
    into.setup_s += part.setup_s;
    into.render_s += part.render_s;
    into.warnings.insert(into.warnings.end(), part.warnings.begin(), part.warnings.end());
}

class AveragedAreaFamily final : public TechniqueFamily {
  public:
    explicit AveragedAreaFamily(const SceneOnGpu& scene)
        : punctual_(make_depth_map_family(scene)), samples_(make_depth_map_family(scene)) {}

    void render(const Technique& t, std::span<const Light> lights, const RenderOptions& options, RasterFrame& frame,
                RasterStats& stats) override {
        const ExpandedLights expanded = expand_area_lights({lights.begin(), lights.end()}, t);
        // Lights drawn once keep their lookups; the samples of an averaged light are drawn V
        // only (no one sample's lookups explain their mean).
        std::vector<Light> once, sampled;
        for (std::size_t li = 0; li < lights.size(); ++li) {
            auto& into = expanded.count[li] == 1 ? once : sampled;
            const auto first = expanded.lights.begin() + static_cast<std::ptrdiff_t>(expanded.first[li]);
            into.insert(into.end(), first, first + static_cast<std::ptrdiff_t>(expanded.count[li]));
        }
        // Each drawn light takes its scenario light's own bias (Technique::lights), in drawing order.
        Technique once_t = t, sampled_t = t;
        if (!t.lights.empty()) {
            once_t.lights.clear();
            sampled_t.lights.clear();
            for (std::size_t li = 0; li < lights.size(); ++li) {
                const LightOverride own = li < t.lights.size() ? t.lights[li] : LightOverride{};
                auto& into = expanded.count[li] == 1 ? once_t.lights : sampled_t.lights;
                into.insert(into.end(), expanded.count[li], own);
            }
        }
        RasterResult drawn_once;
        punctual_->render(once_t, once, options, drawn_once.frame, drawn_once.stats);
        add_stats(stats, drawn_once.stats);

        // The samples' V summed per light in drawing order, then divided: the mean.
        RenderOptions v_only = options;
        v_only.lookups = false;
        std::vector<RasterLightImage> sums;
        std::vector<RasterLightStats> folded;
        std::size_t light = 0, in_light = 0;  // the averaged light and sample being folded
        std::vector<std::size_t> averaged;    // scenario index of each averaged light
        for (std::size_t li = 0; li < lights.size(); ++li)
            if (expanded.count[li] > 1) averaged.push_back(li);
        for (std::size_t start = 0; start < sampled.size(); start += kSamplesPerPass) {
            const std::size_t end = std::min(sampled.size(), start + kSamplesPerPass);
            RasterResult part;
            Technique part_t = sampled_t;
            if (!sampled_t.lights.empty())
                part_t.lights.assign(sampled_t.lights.begin() + static_cast<std::ptrdiff_t>(start),
                                     sampled_t.lights.begin() + static_cast<std::ptrdiff_t>(end));
            samples_->render(part_t, std::span(sampled).subspan(start, end - start), v_only, part.frame, part.stats);
            add_stats(stats, part.stats);
            for (std::size_t j = 0; j < end - start; ++j) {
                RasterLightImage& img = part.frame.lights[j];
                const RasterLightStats& ls = part.stats.lights[j];
                if (in_light == 0) {
                    sums.push_back(std::move(img));
                    folded.push_back(ls);
                } else {
                    std::vector<float>& sum = sums.back().V;
                    for (std::size_t i = 0; i < sum.size(); ++i) sum[i] += img.V[i];
                    RasterLightStats& f = folded.back();
                    f.layers_sampled |= ls.layers_sampled;
                    f.layers_rendered += ls.layers_rendered;
                    f.map_reused = f.map_reused && ls.map_reused;
                    f.gpu_ms.add(ls.gpu_ms);
                }
                if (++in_light == expanded.count[averaged[light]]) {
                    for (float& v : sums.back().V) v /= static_cast<float>(in_light);
                    ++light;
                    in_light = 0;
                }
            }
        }

        // Back in the scenario's order.
        std::size_t next_once = 0, next_averaged = 0;
        for (std::size_t li = 0; li < lights.size(); ++li) {
            if (expanded.count[li] == 1) {
                frame.lights.push_back(std::move(drawn_once.frame.lights[next_once]));
                stats.lights.push_back(std::move(drawn_once.stats.lights[next_once]));
                ++next_once;
            } else {
                frame.lights.push_back(std::move(sums[next_averaged]));
                stats.lights.push_back(std::move(folded[next_averaged]));
                ++next_averaged;
            }
        }
    }

  private:
    // One depth-map family each: the punctual lights' maps stay in place between renders.
    std::unique_ptr<TechniqueFamily> punctual_, samples_;
};

}  // namespace

std::unique_ptr<TechniqueFamily> make_averaged_area_family(const SceneOnGpu& scene) {
    return std::make_unique<AveragedAreaFamily>(scene);
}

FamilyEntry averaged_area_family_entry() {
    // The depth map's keys and scoring, plus area_samples.
    FamilyEntry e = depth_map_family_entry();
    e.name = "averaged_area";
    e.description =
        "area lights as the average of technique.area_samples hard shadow maps from points spread over each light "
        "(reference 001)";
    e.parse = [](JsonObject& o, Technique& t) {
        parse_depth_map_keys(o, t);
        t.area_samples = static_cast<int>(o.integer("area_samples", kDefaultAreaSamples, 1, 256));
    };
    e.write = [](const Technique& t, nlohmann::json& j) {
        j.update(depth_map_keys_json(t));
        j["area_samples"] = t.area_samples;
    };
    e.memory = [](const Technique& t) {
        RasterMemory m = depth_map_family_entry().memory(t);
        m.area_samples = t.area_samples;
        return m;
    };
    e.describe_light = [](const Technique& t, const Light& light, const RasterLightStats&) {
        if (!is_area_light(light.type)) return nlohmann::json::object();
        return nlohmann::json{{"area", {{"method", "averaged_hard_shadows"}, {"maps", t.area_samples}}}};
    };
    e.sweep_keys.push_back("area_samples");
    e.make = make_averaged_area_family;
    return e;
}

}  // namespace penumbra::raster
