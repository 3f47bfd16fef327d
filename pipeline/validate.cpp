#include "pipeline/validate.h"

#include <fmt/format.h>
#include <tbb/global_control.h>

#include <array>
#include <cmath>
#include <memory>

#include "common/json_reader.h"
#include "common/stopwatch.h"
#include "common/version.h"
#include "oracle/oracle_cache.h"
#include "oracle/oracle_output.h"
#include "raster/technique_family.h"

namespace penumbra {

report::ReportInputs report_inputs(const Scenario& scenario, const ValidateResult& r,
                                   const nlohmann::json& oracle_info) {
    report::ReportInputs in;
    in.version = version_string();
    in.command_line = command_line();
    in.scenario = &scenario;
    in.scenario_file = scenario.file;
    in.technique = r.engine.is_null() ? r.technique.to_json() : nlohmann::json{{"engine", r.engine}};
    in.raster = r.raster_info;
    in.oracle = oracle_info;
    in.scoring = r.scoring;
    in.timing = r.timing;
    in.gate = r.gate ? &*r.gate : nullptr;
    in.fingerprint = scenario_fingerprint(scenario);  // penumbra diff tells scenarios apart by it
    in.facts = r.facts;
    return in;
}

std::vector<metrics::ScoringOptions> scoring_options(const Scenario& scenario, const raster::Technique& technique,
                                                     double tolerance, double visible_threshold) {
    metrics::ScoringOptions so;
    so.tolerance = static_cast<float>(tolerance);
    so.visible_threshold = static_cast<float>(visible_threshold);
    const raster::ScoringHints hints = raster::family_of(technique).hints(technique);
    so.filter_reach_texels = static_cast<float>(hints.filter_reach_texels);
    so.depth_quantum = static_cast<float>(hints.depth_quantum);
    so.light_bleeding = hints.light_bleeding;
    if (hints.exact) so.texel_footprint_m = so.bias_reach_m = 0.0f;
    std::vector<metrics::ScoringOptions> scoring(scenario.lights.size(), so);
    for (std::size_t li = 0; li < scoring.size(); ++li) scoring[li].soft = is_soft_light(scenario.lights[li]);
    return scoring;
}

std::optional<std::string> no_lights_warning(const Scenario& scenario) {
    if (!scenario.lights.empty()) return std::nullopt;
    return fmt::format("{}: the scenario has no lights: nothing is shadowed and nothing is scored", scenario.label);
}

namespace {

// oracle.json's "cache": where the entry lives and how much the cache holds, so that a user sees
// what the reuse costs on disk (docs/outputs.md).
nlohmann::json cache_info(const OracleCache& cache, const std::string& key, bool hit) {
    nlohmann::json j = {{"hit", hit}, {"key", key}, {"dir", cache.dir().string()}};
    if (cache.dir().empty()) return j;
    std::uint64_t total = 0, bytes = 0;
    const std::vector<CacheEntry> entries = cache.entries();
    for (const CacheEntry& e : entries) {
        total += e.bytes;
        if (e.key == key) bytes = e.bytes;
    }
    if (bytes > 0) {
        j["file"] = path_text(cache.entry(key));
        j["bytes"] = bytes;
    }
    j["entries"] = entries.size();
    j["total_bytes"] = total;
    j["max_bytes"] = cache.max_bytes();
    return j;
}

// report.json's per-layer metrics of a layered light (the `cascades` of a cascaded one: docs/raster.md,
// "Cascaded shadow maps"): the pixels each layer's lookups judged, by the layer they recorded, with
// their counts and rates.
nlohmann::json layer_metrics(const raster::RasterLightStats& stats, const RasterLightImage& image,
                             const metrics::LightErrorImage& errors, const std::vector<float>& A) {
    const std::size_t n = stats.views.size();
    std::vector<std::array<std::uint64_t, metrics::kErrorClasses.size()>> counts(n);
    std::vector<std::uint64_t> surface(n, 0), scored(n, 0);
    for (std::size_t i = 0; i < A.size(); ++i) {
        const std::uint32_t layer = image.lookups->layer[i];
        if (A[i] == 0 || layer >= n) continue;  // no surface, or beyond the last layer
        ++surface[layer];
        const auto c = static_cast<metrics::PixelClass>(errors.cls[i]);
        const std::size_t k = metrics::error_class_index(c);
        if (c == metrics::PixelClass::correct || k < counts[layer].size()) ++scored[layer];
        if (k < counts[layer].size()) ++counts[layer][k];
    }
    nlohmann::json out = nlohmann::json::array();
    for (std::size_t layer = 0; layer < n; ++layer) {
        const raster::ShadowView& v = stats.views[layer];
        nlohmann::json c = nlohmann::json::object(), r = nlohmann::json::object();
        for (std::size_t k = 0; k < metrics::kErrorClasses.size(); ++k) {
            const std::string name(metrics::to_string(metrics::kErrorClasses[k]));
            c[name] = counts[layer][k];
            r[name] = scored[layer] ? static_cast<double>(counts[layer][k]) / static_cast<double>(scored[layer]) : 0.0;
        }
        out.push_back({{"index", layer},
                       {"near_m", v.split_near},
                       {"far_m", v.split_far},
                       {"texel_m", v.metres_per_texel},
                       {"pixels", {{"surface", surface[layer]}, {"scored", scored[layer]}}},
                       {"counts", c},
                       {"rates", r}});
    }
    return out;
}

}  // namespace

OracleRun oracle_for(const Scenario& scenario, const ValidateOptions& options) {
    auto t0 = SteadyClock::now();
    OracleCache cache(!options.use_cache           ? std::filesystem::path()
                      : !options.cache_dir.empty() ? options.cache_dir
                                                   : OracleCache::default_dir(),
                      options.cache_max_bytes ? *options.cache_max_bytes : OracleCache::default_max_bytes());
    const std::string key = oracle_cache_key(scenario, options.oracle);
    OracleRun o;
    // The cache keeps neither P, N nor depth: a caller that writes oracle.exr traces.
    std::string damaged;
    if (!options.keep_oracle_frame) {
        CacheRequest request{scenario.width, scenario.height, {}, scenario.scene.triangles.size()};
        for (const Light& l : scenario.lights) request.light_types.push_back(to_string(l.type));
        if (auto hit = cache.load(key, &damaged, &request)) {
            o.frame = std::move(hit->frame);
            o.info = std::move(hit->info);
            o.info["cache"] = cache_info(cache, key, true);
            o.cached = true;
            o.seconds = seconds_since(t0);
            return o;
        }
    }
    OracleResult result = run_oracle(scenario, options.oracle);
    o.info = oracle_json(scenario, result, {});
    o.seconds = seconds_since(t0);
    o.warning = cache.store(key, result.frame, o.info);
    if (!damaged.empty()) o.warning = o.warning ? damaged + "; " + *o.warning : damaged;
    o.info["cache"] = cache_info(cache, key, false);
    o.frame = std::move(result.frame);
    return o;
}

ValidateResult validate(const Scenario& scenario, const raster::Technique& technique, const metrics::Gate& gate,
                        const ValidateOptions& options, raster::RasterSession* session,
                        std::shared_ptr<const OracleRun> oracle) {
    ValidateResult r;
    r.technique = technique;
    if (options.progress && !oracle) options.progress->phase("the truth (traced, or read from the cache)");
    r.oracle = oracle ? std::move(oracle) : std::make_shared<const OracleRun>(oracle_for(scenario, options));
    if (r.oracle->warning) r.warnings.push_back(*r.oracle->warning);

    std::unique_ptr<raster::VulkanContext> ctx;
    std::unique_ptr<raster::RasterSession> own;
    if (options.progress) options.progress->phase(fmt::format("drawing the {} technique", technique.family));
    if (!session) {
        auto t1 = SteadyClock::now();
        raster::ContextOptions co;
        co.device = options.device;
        ctx = std::make_unique<raster::VulkanContext>(co);
        r.raster_timings.device_s = seconds_since(t1);
        own = std::make_unique<raster::RasterSession>(scenario, *ctx);
        session = own.get();
    }
    // The command's --threads (app/cli.h, ThreadLimit) bounds the oracle, the raster and the metrics alike.
    r.raster_timings.threads =
        static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
    auto t2 = SteadyClock::now();
    r.raster = session->render(technique, options.render);
    r.raster_s = seconds_since(t2) + (own ? own->setup_s() : 0.0);
    r.warnings.insert(r.warnings.end(), r.raster.stats.warnings.begin(), r.raster.stats.warnings.end());

    auto t3 = SteadyClock::now();
    if (options.progress) options.progress->phase("scoring every pixel");
    r.scoring = scoring_options(scenario, technique, options.tolerance, options.visible_threshold);
    r.score = metrics::score_frames(r.oracle->frame, r.raster.frame, r.scoring);
    r.metrics_s = seconds_since(t3);

    r.raster_info = raster::raster_json(scenario, technique, r.raster, r.raster_timings);
    r.timing = {{"oracle_s", r.oracle->seconds},
                {"oracle_cached", r.oracle->cached},
                {"raster_s", r.raster_s},
                {"device_s", r.raster_timings.device_s},
                {"raster_ms",
                 {{"shadow", r.raster.stats.gpu_ms["shadow"]},
                  {"camera", r.raster.stats.camera_ms + r.raster.stats.gpu_ms["lookup"]},
                  {"lookup", r.raster.stats.gpu_ms["lookup"]}}},
                {"metrics_s", r.metrics_s}};
    if (!gate.checks.empty()) r.gate = metrics::evaluate_gate(gate, r.score.lights);
    make_report(scenario, r);
    const std::vector<std::string> facing = facing_warnings(r.facing);
    r.warnings.insert(r.warnings.end(), facing.begin(), facing.end());
    return r;
}

namespace {

// The scene's cut-outs as report.json states them (docs/design.md): what the truth and the
// shadow pass test alpha on.
nlohmann::json cutouts_json(const Scene& scene) {
    std::vector<std::uint64_t> triangles(scene.cutout_materials.size(), 0);
    for (std::uint32_t c : scene.triangle_cutout)
        if (c != kNoCutout) ++triangles[c];
    nlohmann::json materials = nlohmann::json::array();
    std::uint64_t total = 0;
    for (std::size_t k = 0; k < scene.cutout_materials.size(); ++k) {
        const CutoutMaterial& m = scene.cutout_materials[k];
        nlohmann::json j = {{"material", m.label},
                            {"alpha_mode", m.mode == AlphaMode::mask ? "MASK" : "BLEND"},
                            {"triangles", triangles[k]},
                            {"alpha_cutoff", m.cutoff},
                            {"factor_alpha", m.factor_alpha},
                            {"filter", m.nearest ? "nearest" : "linear"}};
        if (m.texture >= 0) {
            const AlphaTexture& t = scene.alpha_textures[static_cast<std::size_t>(m.texture)];
            j["image"] = {{"label", t.label}, {"width", t.width}, {"height", t.height}};
        }
        materials.push_back(std::move(j));
        total += triangles[k];
    }
    return {{"triangles", total}, {"materials", std::move(materials)}};
}

}  // namespace

void make_report(const Scenario& scenario, ValidateResult& r) {
    r.facing = facing_of(scenario, r.oracle->frame, r.oracle->info);
    const raster::FamilyEntry& family = raster::family_of(r.technique);
    // The shadow pass's culling, where it culls casters: a fact the hint of missing shadows uses.
    const raster::ScoringHints hints = family.hints(r.technique);
    r.facts = {r.facing.share(),
               family.draws_maps && r.technique.cull != raster::Cull::none ? raster::to_string(r.technique.cull) : "",
               hints.false_lit_cure};
    r.report = report::report_json(report_inputs(scenario, r, r.oracle->info), r.score);
    r.report["facing"] = to_json(r.facing);
    if (scenario.scene.has_cutouts()) r.report["cutouts"] = cutouts_json(scenario.scene);
    if (nlohmann::json d = raster::preset_differences(r.technique); !d.empty())
        r.report["preset_differences"] = std::move(d);
    const std::string& layer_report = hints.layer_report;
    for (std::size_t li = 0; li < r.raster.stats.lights.size() && li < r.report["lights"].size(); ++li) {
        const raster::RasterLightStats& ls = r.raster.stats.lights[li];
        const RasterLightImage& image = r.raster.frame.lights[li];
        if (layer_report.empty() || ls.views.empty() || ls.views[0].split_far <= 0 || !image.lookups) continue;
        r.report["lights"][li][layer_report] = layer_metrics(ls, image, r.score.images[li], r.raster.frame.A);
        if (const auto& sdsm = ls.projection.sdsm_range)  // SDSM: the range the splits were placed in
            r.report["lights"][li]["sdsm"] = {{"near_m", sdsm->x}, {"far_m", sdsm->y}};
    }
}

std::string validate_junit(const Scenario& scenario, const ValidateResult& result) {
    return report::junit_xml(report_inputs(scenario, result, result.oracle->info));
}

}  // namespace penumbra
