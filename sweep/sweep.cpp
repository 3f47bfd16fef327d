#include "sweep/sweep.h"

#include <fmt/format.h>

#include <algorithm>
#include <future>

#include "common/errors.h"
#include "common/stopwatch.h"
#include "metrics/gpu_classification.h"
#include "metrics/metric_table.h"
#include "raster/raster_output.h"

namespace penumbra::sweep {
namespace {

// The GPU milliseconds of a render's shadow: every pass the family timed (the depth map's
// shadow passes, lookups and cube-face mask; a new family's passes by their names). The camera
// pass is drawn once per session and is not part of a configuration. A production render's
// passes are what an engine pays (depth-only maps, V alone): kProductionMsIncludes.
double shadow_cost_ms(const raster::RasterStats& s) {
    return s.gpu_ms.total();
}

}  // namespace

std::vector<std::string> verdict_columns(const Scenario& scenario) {
    // The visible rates first, as gates, hints and tune read them (issue #53), every wrong pixel's
    // beside them; wrong_fraction stays the first column (merge and the Pareto plot read it).
    std::vector<std::string> c = {"wrong_fraction", "mae"};
    for (auto cls : metrics::kErrorClasses) c.push_back("rates_visible." + std::string(metrics::to_string(cls)));
    for (auto cls : metrics::kErrorClasses) c.push_back("rates." + std::string(metrics::to_string(cls)));
    c.push_back("perceptual.mean");
    if (std::any_of(scenario.lights.begin(), scenario.lights.end(), [](const Light& l) { return is_soft_light(l); })) {
        c.push_back("soft.penumbra_mae");
        c.push_back("soft.penumbra_width_error");
    }
    return c;
}

Table run_sweep(const Scenario& scenario, const std::string& scenario_name, std::span<const std::string> keys,
                std::span<const Config> configs, std::size_t total, Shard shard, const SweepOptions& options,
                const raster::VulkanContext& ctx, const std::string& fingerprint) {
    Table t;
    t.fingerprint = fingerprint;
    t.scenario = scenario_name;
    t.keys.assign(keys.begin(), keys.end());
    t.columns = verdict_columns(scenario);
    t.total = total;
    t.repeat = options.repeat;
    // The verdict's scorer: the GPU's where it wins on this device (docs/sweep.md, "Scoring on
    // the GPU"); counts identical either way.
    const metrics::Scorer scorer_kind = metrics::preferred_scorer(ctx);
    t.device = {{"name", ctx.info().name},
                {"type", ctx.info().type},
                {"driver", ctx.info().driver},
                {"scorer", metrics::to_string(scorer_kind)},
                {"timestamps", raster::timestamps_json(ctx.info())}};
    // One calibration's deviation differs from run to run: shards of one device must still merge.
    t.device["timestamps"].erase("calibration_deviation_ns");
    t.shard = shard;
    const auto t0 = SteadyClock::now();
    auto oracle = std::make_shared<const OracleRun>(oracle_for(scenario, options.validate));
    raster::RasterSession session(scenario, ctx);
    t.setup_s = seconds_since(t0);
    ValidateOptions diagnostic = options.validate;
    diagnostic.render.lookups = true;
    diagnostic.render.reuse_maps = false;  // a timing: every pass is drawn
    raster::RenderOptions production;
    production.lookups = false;
    production.reuse_maps = false;
    production.read_back = false;  // timings only: the output is discarded where it lies
    production.camera_images = false;
    raster::RenderOptions timed = diagnostic.render;
    timed.read_back = false;
    timed.camera_images = false;
    std::unique_ptr<metrics::GpuScorer> scorer;
    const metrics::Gate no_gate;
    std::vector<const metrics::Metric*> metrics;
    for (const auto& c : t.columns) metrics.push_back(metrics::find_metric(c));
    for (const Config& c : configs) {
        const auto tc = SteadyClock::now();
        Row row;
        row.index = c.index;
        row.values = c.values;
        row.technique = c.technique.to_json();
        // Warm-up (kWarmUpRenders of each kind, discarded): the verdict's render also builds
        // (and, on lavapipe, compiles) the pipelines and counts as the first diagnostic one; the
        // production pipelines are built by the first production render.
        std::optional<metrics::FrameScore> score;
        metrics::DeferredPerceptual perceptual;
        if (scorer_kind == metrics::Scorer::gpu) {
            // The camera images go to the scorer once per camera pass (a new precision draws another).
            raster::RenderOptions verdict = timed;
            verdict.camera_images = !scorer;
            raster::RasterResult rr = session.render(c.technique, verdict);
            if (scorer && !scorer->knows_camera(rr.stats)) {
                verdict.camera_images = true;
                rr = session.render(c.technique, verdict);
            }
            row.verdict_render_s = seconds_since(tc);
            if (!scorer) scorer = std::make_unique<metrics::GpuScorer>(ctx, oracle->frame, rr.frame);
            score = scorer->score(
                rr,
                scoring_options(scenario, c.technique, options.validate.tolerance, options.validate.visible_threshold),
                false, &perceptual);
        }
        // The CPU's verdict: on a CPU device, or for a family that reads its output back.
        if (!score) score = validate(scenario, c.technique, no_gate, diagnostic, &session, oracle).score;
        row.verdict_s = seconds_since(tc);
        // The perceptual error (CPU work) runs while the timed renders wait on the GPU.
        std::future<void> perceptual_done = std::async(std::launch::async, [&perceptual, &score, &row] {
            const auto tp = SteadyClock::now();
            perceptual.run(*score);
            row.perceptual_s = seconds_since(tp);
        });
        auto timed_render = [&](const raster::RenderOptions& o) {
            const raster::RasterResult r = session.render(c.technique, o);
            row.timed_setup_s += r.stats.setup_s;
            row.timed_submit_s += r.stats.render_s;
            return shadow_cost_ms(r.stats);
        };
        auto td = SteadyClock::now();
        for (int k = 1; k < kWarmUpRenders; ++k) timed_render(timed);
        for (int k = 0; k < options.repeat; ++k) row.diagnostic_ms.push_back(timed_render(timed));
        row.diagnostic_s = seconds_since(td);
        td = SteadyClock::now();
        for (int k = 0; k < kWarmUpRenders; ++k) timed_render(production);
        for (int k = 0; k < options.repeat; ++k) row.production_ms.push_back(timed_render(production));
        row.production_s = seconds_since(td);
        td = SteadyClock::now();
        perceptual_done.get();
        row.perceptual_wait_s = seconds_since(td);
        row.lights = nlohmann::json::array();
        for (const auto& l : score->lights) row.lights.push_back(metrics::to_json(l));
        for (const metrics::Metric* m : metrics) {
            double sum = 0, weight = 0;
            for (const auto& l : score->lights)
                if (auto v = metrics::value_of(*m, l)) {
                    sum += *v * static_cast<double>(l.pixels.scored);
                    weight += static_cast<double>(l.pixels.scored);
                }
            row.verdict.push_back(weight > 0 ? sum / weight : 0.0);
        }
        row.seconds = seconds_since(tc);
        t.rows.push_back(std::move(row));
        if (options.progress) options.progress(t.rows.back(), t.rows.size(), configs.size());
    }
    return t;
}

}  // namespace penumbra::sweep
