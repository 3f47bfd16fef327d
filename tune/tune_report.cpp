#include "tune/tune_report.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "common/version.h"
#include "metrics/metric_table.h"
#include "raster/technique_family.h"

namespace penumbra::tune {
namespace {

// r of float depth at `depth`: 2^(e - 23), e the exponent of depth (Vulkan spec, "Depth Bias";
// D3D12's "Depth Bias" uses the same definition for D32_FLOAT).
double float_r(double depth) {
    if (!(depth > 0)) return std::ldexp(1.0, -149);
    int e = 0;
    std::frexp(depth, &e);  // depth = m x 2^e, m in [0.5, 1): IEEE exponent is e - 1
    return std::ldexp(1.0, e - 1 - 23);
}

nlohmann::json light_outcomes(const Evaluation& e) {
    nlohmann::json a = nlohmann::json::array();
    for (const auto& o : e.lights)
        a.push_back({{"scenario", o.scenario},
                     {"light", o.light},
                     {"acne", o.acne},
                     {"acne_rate", o.acne_rate},
                     {"visible_acne", o.visible.acne},
                     {"visible_peter_panning", o.visible.peter_panning},
                     {"visible_light_bleeding", o.visible.light_bleeding},
                     {"minimized", o.minimized},
                     {"then", o.then},
                     {"scored", o.scored}});
    return a;
}

nlohmann::json evaluation_json(const Evaluation& e, const KnobSet& knobs) {
    return {{"setting", to_json(e.setting, knobs)},
            {"worst_acne", e.worst_acne},
            {"minimized", e.minimized},
            {"then", e.then},
            {"feasible", e.feasible},
            {"visible_acne", e.visible.acne},
            {"visible_peter_panning", e.visible.peter_panning},
            {"visible_light_bleeding", e.visible.light_bleeding},
            {"seconds", e.seconds},
            {"lights", light_outcomes(e)}};
}

nlohmann::json revalidation_json(std::span<const Revalidation> rs, std::span<const std::string> files) {
    nlohmann::json a = nlohmann::json::array();
    for (std::size_t k = 0; k < rs.size(); ++k) {
        nlohmann::json before = nlohmann::json::array(), after = nlohmann::json::array();
        // Each light's score, with the visible error tune's rule compares.
        auto with_visible = [](const ValidateResult& v, std::size_t li) {
            nlohmann::json j = metrics::to_json(v.score.lights[li]);
            const VisibleBiasError e = visible_bias_error(v.score.lights[li]);
            j["visible_bias_error"] = {{"acne", e.acne},
                                       {"peter_panning", e.peter_panning},
                                       {"light_bleeding", e.light_bleeding},
                                       {"sum", e.sum()}};
            return j;
        };
        for (std::size_t li = 0; li < rs[k].before.score.lights.size(); ++li)
            before.push_back(with_visible(rs[k].before, li));
        for (std::size_t li = 0; li < rs[k].after.score.lights.size(); ++li)
            after.push_back(with_visible(rs[k].after, li));
        a.push_back(
            {{"scenario", k < files.size() ? files[k] : rs[k].scenario->label}, {"before", before}, {"after", after}});
    }
    return a;
}

}  // namespace

namespace {

Revalidation revalidate_one(const Scenario& s, raster::RasterSession& session,
                            const std::shared_ptr<const OracleRun>& oracle, const raster::Technique& before,
                            const raster::Technique& after, const ValidateOptions& options) {
    const metrics::Gate no_gate;
    Revalidation r;
    r.scenario = &s;
    r.before = validate(s, before, no_gate, options, &session, oracle);
    r.after = validate(s, after, no_gate, options, &session, oracle);
    return r;
}

}  // namespace

std::vector<Revalidation> revalidate(std::span<const Scenario> scenarios, const raster::Technique& before,
                                     const raster::Technique& after, const ValidateOptions& options,
                                     const raster::VulkanContext& ctx) {
    std::vector<Revalidation> out;
    for (const Scenario& s : scenarios) {
        raster::RasterSession session(s, ctx);
        out.push_back(revalidate_one(s, session, std::make_shared<const OracleRun>(oracle_for(s, options)), before,
                                     after, options));
    }
    return out;
}

std::vector<Revalidation> revalidate(Evaluator& ev, const raster::Technique& before, const raster::Technique& after,
                                     const ValidateOptions& options) {
    std::vector<Revalidation> out;
    for (TuneScene& scene : ev.scenes())
        out.push_back(revalidate_one(*scene.scenario, *scene.session, scene.oracle, before, after, options));
    return out;
}

std::vector<std::pair<std::size_t, std::string>> worse_lights(std::span<const Revalidation> rs,
                                                              std::span<const std::string> files) {
    std::vector<std::pair<std::size_t, std::string>> out;
    auto named = [&](std::size_t li) {
        return std::any_of(out.begin(), out.end(), [&](const auto& w) { return w.first == li; });
    };
    for (std::size_t k = 0; k < rs.size(); ++k) {
        const metrics::FrameScore &b = rs[k].before.score, &a = rs[k].after.score;
        const std::string name = k < files.size() ? files[k] : rs[k].scenario->label;
        for (std::size_t li = 0; li < a.lights.size() && li < b.lights.size(); ++li) {
            if (named(li)) continue;
            const VisibleBiasError vb = visible_bias_error(b.lights[li]);
            const VisibleBiasError va = visible_bias_error(a.lights[li]);
            const double pb = b.lights[li].perceptual.mean, pa = a.lights[li].perceptual.mean;
            if (va.sum() > vb.sum() + 1e-12)
                out.emplace_back(li, fmt::format("{} light {}: {} {:.6f} against the start's {:.6f}", name, li,
                                                 VisibleBiasError::label(va, vb), va.sum(), vb.sum()));
            else if (pa > pb + 1e-12)
                out.emplace_back(li, fmt::format("{} light {}: perceptual error mean {:.6f} against the start's {:.6f}",
                                                 name, li, pa, pb));
        }
    }
    return out;
}

std::vector<Revalidation> revalidate_never_worse(Evaluator& ev, const raster::Technique& start, TuneResult& r,
                                                 const TuneOptions& options, std::span<const std::string> files) {
    std::vector<Revalidation> rs = revalidate(ev, start, r.recommended, options.validate);
    const auto worse = worse_lights(rs, files);
    if (worse.empty()) return rs;
    keep_start(r, start, options, worse);
    return revalidate(ev, start, r.recommended, options.validate);
}

std::vector<ApiBias> api_units(std::span<const Revalidation> revalidations) {
    std::vector<ApiBias> out;
    for (std::size_t si = 0; si < revalidations.size(); ++si) {
        const ValidateResult& v = revalidations[si].after;
        const raster::Technique& t = v.technique;
        const RasterFrame& f = v.raster.frame;
        for (std::size_t li = 0; li < f.lights.size(); ++li) {
            const auto& lk = f.lights[li].lookups;
            if (!lk) continue;
            const raster::Bias bias = t.bias_for(li);
            ApiBias b;
            b.scenario = si;
            b.light = li;
            b.median_depth = median_at_surface(lk->ref_depth, f.A, false);
            b.depth_to_m = median_at_surface(lk->depth_to_m, f.A, true);
            b.footprint_m = median_at_surface(lk->footprint_m, f.A, true);
            const double r_format = t.depth_format == raster::DepthFormat::d32
                                        ? float_r(b.median_depth)
                                        : raster::depth_resolution(t.depth_format);
            b.depth_offset = bias.constant * r_format;
            b.vk_constant = bias.constant;
            b.vk_slope = b.d3d12_slope = b.gl_factor = bias.slope;
            b.vk_clamp = b.d3d12_clamp = bias.clamp;
            b.gl_units = bias.constant;
            b.d3d12_depth_bias_d24 = std::llround(b.depth_offset / raster::depth_resolution(raster::DepthFormat::d24));
            b.d3d12_depth_bias_d32 = std::llround(b.depth_offset / float_r(b.median_depth));
            b.constant_m = b.depth_offset * b.depth_to_m;
            b.world_m = bias.world;
            b.normal_offset_texels = bias.normal_offset;
            b.normal_offset_m = bias.normal_offset * b.footprint_m;
            out.push_back(b);
        }
    }
    return out;
}

nlohmann::json to_json(const Setting& s, const KnobSet& knobs) {
    nlohmann::json j = nlohmann::json::object();
    for (std::size_t i = 0; i < knobs.size(); ++i) {
        if (knobs[i].scale == raster::KnobScale::on_off)
            j[knobs[i].name] = s[i] != 0;
        else
            j[knobs[i].name] = s[i];
    }
    return j;
}

nlohmann::json tune_json(const TuneReport& r) {
    const TuneResult& res = r.result;
    const KnobSet& knobs = r.options.knobs;
    nlohmann::json knob_info = nlohmann::json::array();
    for (const raster::KnobDecl& k : knobs) {
        nlohmann::json info = {{"name", k.name}};
        if (k.scale == raster::KnobScale::on_off)
            info["values"] = {false, true};
        else
            info.update({{"unit", k.unit}, {"range", {k.lower, k.upper}}, {"scale", raster::to_string(k.scale)}});
        // What the start's family adds (a cascaded technique: whether the value is scaled by
        // each cascade's texel, docs/tune.md), from its own declaration of the knob.
        const auto& declared = raster::family_of(r.start).knobs;
        auto own =
            std::find_if(declared.begin(), declared.end(), [&](const raster::KnobDecl& d) { return d.name == k.name; });
        if (own != declared.end() && own->describe) info.update(own->describe(r.start));
        knob_info.push_back(info);
    }
    nlohmann::json evaluations = nlohmann::json::array();
    for (const auto& e : res.evaluations) evaluations.push_back(evaluation_json(e, knobs));
    nlohmann::json units = nlohmann::json::array();
    for (const ApiBias& b : r.units) {
        units.push_back({{"scenario", b.scenario},
                         {"light", b.light},
                         {"median_depth", b.median_depth},
                         {"footprint_m", b.footprint_m},
                         {"vulkan",
                          {{"format", raster::to_string(res.recommended.depth_format)},
                           {"depthBiasConstantFactor", b.vk_constant},
                           {"depthBiasSlopeFactor", b.vk_slope},
                           {"depthBiasClamp", b.vk_clamp}}},
                         {"d3d12",
                          {{"DepthBias_D24", b.d3d12_depth_bias_d24},
                           {"DepthBias_D32", b.d3d12_depth_bias_d32},
                           {"SlopeScaledDepthBias", b.d3d12_slope},
                           {"DepthBiasClamp", b.d3d12_clamp}}},
                         {"opengl", {{"glPolygonOffset_factor", b.gl_factor}, {"glPolygonOffset_units", b.gl_units}}},
                         {"world",
                          {{"constant_m", b.constant_m},
                           {"world_bias_m", b.world_m},
                           {"normal_offset_texels", b.normal_offset_texels},
                           {"normal_offset_m", b.normal_offset_m}}}});
        if (!b.engine.is_null()) units.back()["engine"] = b.engine;
    }
    nlohmann::json front = nlohmann::json::array();
    for (std::size_t i : res.front) front.push_back(i);
    const std::size_t chosen = res.chosen();
    // Per-light mode: each light's search, its choice, and whether it kept the start.
    nlohmann::json lights = nlohmann::json::array(), settings = nlohmann::json::array();
    for (std::size_t li = 0; li < res.per_light.size(); ++li) {
        const TuneResult& rl = res.per_light[li];
        nlohmann::json evs = nlohmann::json::array(), fr = nlohmann::json::array();
        for (const auto& e : rl.evaluations) evs.push_back(evaluation_json(e, knobs));
        for (std::size_t i : rl.front) fr.push_back(i);
        const nlohmann::json setting = to_json(rl.evaluations[rl.chosen()].setting, knobs);
        settings.push_back(setting);
        lights.push_back({{"light", li},
                          {"chosen", rl.chosen()},
                          {"setting", setting},
                          {"feasible", rl.winner.has_value()},
                          {"start_evaluation", 0},
                          {"kept_start", rl.kept_start},
                          {"why", rl.why},
                          {"budget_exhausted", rl.budget_exhausted},
                          {"front", fr},
                          {"evaluations", evs}});
    }
    const bool per_light = !res.per_light.empty();
    bool feasible = res.winner.has_value();
    if (per_light) {
        feasible = true;
        for (const auto& rl : res.per_light) feasible = feasible && rl.winner.has_value();
    }
    const std::string capped = r.options.objective.visible() ? "visible acne rate" : "rates.acne";
    nlohmann::json j = {
        {"version", version_string()},
        {"scenarios", r.scenario_files},
        {"holdout_scenarios", r.holdout_files},
        {"objective",
         {{"minimize", r.options.objective.minimize},
          {"then", r.options.objective.then},
          {"subject_to",
           fmt::format("{} <= {} on every scenario and light (a cap)", capped, r.options.objective.max_acne)},
          {"visible_threshold", r.options.validate.visible_threshold},
          {"never_worse_than_start",
           "per light: visible acne + peter-panning, and the mean perceptual error at re-validation"},
          {"max_acne", r.options.objective.max_acne},
          {"tie", r.options.objective.tie},
          {"pooling", per_light ? "per light: mean over every scenario, weighted by scored pixels"
                                : "mean over every scenario and light, weighted by scored pixels"},
          {"ties_broken_towards", "the smaller bias"}}},
        {"knobs", knob_info},
        {"reference_footprint_m", res.footprint_m},
        {"budget", r.options.budget},
        {"budget_exhausted", res.budget_exhausted},
        {"feasible", feasible},
        {"mode", per_light ? "per_light" : "shared_bias"},
        {"start", r.start.to_json()},
        {"start_evaluation", res.start ? nlohmann::json(*res.start) : nlohmann::json()},
        {"lights", lights},
        {"recommendation",
         {{"evaluation", per_light ? nlohmann::json() : nlohmann::json(chosen)},
          {"kept_start", res.kept_start},
          {"why", res.why},
          {"setting", per_light                 ? settings
                      : res.evaluations.empty() ? nlohmann::json()
                                                : to_json(res.evaluations[chosen].setting, knobs)},
          {"technique", res.recommended.to_json()},
          {"units", units}}},
        {"evaluations", evaluations},
        {"front", front},
        {"revalidation", revalidation_json(r.tuned, r.scenario_files)},
        {"holdout", revalidation_json(r.holdout, r.holdout_files)},
        {"seconds", r.seconds},
    };
    return j;
}

std::string pareto_csv(const TuneReport& r) {
    const KnobSet& knobs = r.options.knobs;
    std::string s = "light,evaluation";
    for (const raster::KnobDecl& k : knobs) s += fmt::format(",{}", k.name);
    s += fmt::format(",worst_acne,{},{},feasible,on_front,chosen,start\n", r.options.objective.minimize,
                     r.options.objective.then);
    // One row per evaluation of each light's search (per-light mode), or of the shared search.
    auto rows = [&](const TuneResult& res, const std::string& light) {
        for (std::size_t i = 0; i < res.evaluations.size(); ++i) {
            const Evaluation& e = res.evaluations[i];
            s += fmt::format("{},{}", light, i);
            for (std::size_t k = 0; k < knobs.size(); ++k)
                s += knobs[k].scale == raster::KnobScale::on_off ? fmt::format(",{}", e.setting[k] != 0)
                                                                 : fmt::format(",{:.9g}", e.setting[k]);
            const bool front = std::find(res.front.begin(), res.front.end(), i) != res.front.end();
            s += fmt::format(",{:.9g},{:.9g},{:.9g},{},{},{},{}\n", e.worst_acne, e.minimized, e.then, e.feasible,
                             front, i == res.chosen(), res.start && i == *res.start);
        }
    };
    if (r.result.per_light.empty()) rows(r.result, "all");
    for (std::size_t li = 0; li < r.result.per_light.size(); ++li) rows(r.result.per_light[li], std::to_string(li));
    return s;
}

}  // namespace penumbra::tune
