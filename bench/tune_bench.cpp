// tune's cost and quality, each against a baseline in the same run (the machine is shared and
// noisy):
//   1. One evaluation (a warm render with lookups + the objective's counts) against a bare warm
//      render of V alone with the same technique (the least a render can cost on this device).
//      Scene: the bundled default scenario, its directional light only (--all-lights: all
//      three), 1280 x 720 px, 2048^2 map; the evaluations alternate two slope biases so that each
//      one draws its map again.
//   2. With --grid N: the search against an exhaustive N x N grid of constant x slope on the same
//      scenario: evaluations each made, and the objective each reached (peter-panning rate,
//      subject to acne <= 0.001).
// Run: build/bench/tune_bench [--repeat 5] [--device D] [--scenario FILE] [--all-lights]
//      [--grid N] [--budget N] [--resolution R]
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "bench/raster_bench_args.h"
#include "common/scenario.h"
#include "common/stopwatch.h"
#include "metrics/gpu_classification.h"
#include "tune/tune.h"

namespace {

using namespace penumbra;

void print_result(const char* name, const tune::TuneResult& r, const tune::TuneOptions& o) {
    if (!r.winner) {
        std::printf("%-7s %5zu evaluations: nothing feasible (best worst-acne %.5f)\n", name, r.evaluations.size(),
                    r.evaluations[r.best_reachable].worst_acne);
        return;
    }
    const auto& e = r.evaluations[*r.winner];
    std::printf("%-7s %5zu evaluations: constant %.4g slope %.4g  worst acne %.5f  %s %.6f  %s %.4g m\n", name,
                r.evaluations.size(), e.setting[0], e.setting[1], e.worst_acne, o.objective.minimize.c_str(),
                e.minimized, o.objective.then.c_str(), e.then);
}

}  // namespace

int main(int argc, char** argv) {
    int repeat = 5, grid = 0, budget = 80, resolution = 2048;
    bool all_lights = false;
    std::string device;
    std::filesystem::path scenario_file = test::data_dir() / "default/scenario.json";
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&] { return i + 1 < argc ? argv[++i] : nullptr; };
        const char* v = nullptr;
        if (a == "--all-lights") {
            all_lights = true;
        } else if ((a == "--repeat" || a == "--grid" || a == "--budget" || a == "--resolution" || a == "--device" ||
                    a == "--scenario") &&
                   (v = next())) {
            if (a == "--repeat") repeat = std::max(1, std::atoi(v));
            if (a == "--grid") grid = std::max(2, std::atoi(v));
            if (a == "--budget") budget = std::max(1, std::atoi(v));
            if (a == "--resolution") resolution = std::max(16, std::atoi(v));
            if (a == "--device") device = v;
            if (a == "--scenario") scenario_file = v;
        } else {
            std::fprintf(stderr,
                         "usage: tune_bench [--repeat N] [--device D] [--scenario FILE] [--all-lights] [--grid N] "
                         "[--budget N] [--resolution R]\n");
            return 2;
        }
    }
    try {
        Scenario sc = load_scenario(scenario_file);
        if (!all_lights) sc.lights.resize(1);
        raster::ContextOptions co;
        co.device = device;
        raster::VulkanContext ctx(co);
        raster::Technique base =
            raster::parse_technique({{"preset", "d3d12-textbook"}, {"resolution", resolution}}, "bench");
        tune::TuneOptions options;
        options.validate.oracle.progress = false;
        // The grid comparison of docs/tune.md ("Measured"): peter-panning under the acne cap, one
        // bias for all lights, as it was measured.
        options.objective.minimize = "rates.peter_panning";
        options.shared_bias = true;
        const std::vector<Scenario> scenarios = {sc};
        std::printf("device: %s (%s)\nscene: %zu triangles, %dx%d px, %zu light(s), %d^2 %s map; median of %d\n",
                    ctx.info().name.c_str(), ctx.info().driver.c_str(), sc.scene.triangle_count(), sc.width, sc.height,
                    sc.lights.size(), resolution, raster::to_string(base.depth_format), repeat);

        // 1. One evaluation (with lookups; from V alone) against a bare V-only render, and the
        // evaluation with lookups scored on the CPU against the device's preferred scorer.
        const char* given = std::getenv("PENUMBRA_SCORER");
        const std::string asked = given ? given : "";
        ::setenv("PENUMBRA_SCORER", "cpu", 1);
        tune::Evaluator ev_cpu(scenarios, base, options, ctx);
        if (asked.empty())
            ::unsetenv("PENUMBRA_SCORER");
        else
            ::setenv("PENUMBRA_SCORER", asked.c_str(), 1);
        const metrics::Scorer scorer = metrics::preferred_scorer(ctx);
        std::printf("scorer: %s (the device's preferred; $PENUMBRA_SCORER overrides)\n",
                    metrics::to_string(scorer).data());
        tune::Evaluator ev(scenarios, base, options, ctx);
        tune::TuneOptions v_options = options;
        v_options.lookups = false;
        tune::Evaluator ev_v(scenarios, base, v_options, ctx);
        raster::RasterSession bare(sc, ctx);
        std::vector<double> eval_s, render_s, count_s, v_s, bare_s, cpu_s, cpu_count_s;
        std::vector<double> bare_setup_s, bare_submit_s, bare_gpu_ms;  // where a bare render's wall clock goes
        for (int r = 0; r < repeat + 1; ++r) {
            tune::Setting s(options.knobs.size());  // constant, slope
            s[0] = 1000;
            s[1] = r % 2 ? 1.5 : 2.5;
            const tune::Evaluation e = ev.evaluate(s);
            const tune::Evaluation e_cpu = ev_cpu.evaluate(s);
            if (e_cpu.lights.size() != e.lights.size() || e_cpu.worst_acne != e.worst_acne ||
                e_cpu.minimized != e.minimized)
                std::printf("MISMATCH: the CPU and %s scorers disagree\n", metrics::to_string(scorer).data());
            const tune::Evaluation ev_only = ev_v.evaluate(s);
            raster::RenderOptions ro;
            ro.lookups = false;
            ro.reuse_maps = false;
            const auto t0 = SteadyClock::now();
            const raster::RasterResult br = bare.render(tune::apply_setting(base, options.knobs, s, 0), ro);
            const double b = seconds_since(t0);
            if (r > 0) {
                bare_setup_s.push_back(br.stats.setup_s);
                bare_submit_s.push_back(br.stats.render_s);
                bare_gpu_ms.push_back(br.stats.gpu_ms.total());
            }
            if (r == 0) continue;  // the first builds pipelines and maps
            eval_s.push_back(e.seconds);
            render_s.push_back(e.render_s);
            count_s.push_back(e.count_s);
            v_s.push_back(ev_only.seconds);
            cpu_s.push_back(e_cpu.seconds);
            cpu_count_s.push_back(e_cpu.count_s);
            bare_s.push_back(b);
        }
        const double m = bench::median(eval_s), mv = bench::median(v_s), mb = bench::median(bare_s);
        std::printf("bare V-only render          %8.1f ms (set-up %.1f ms, submit and wait %.1f ms, GPU %.1f ms)\n",
                    1e3 * mb, 1e3 * bench::median(bare_setup_s), 1e3 * bench::median(bare_submit_s),
                    bench::median(bare_gpu_ms));
        std::printf("evaluation, lookups         %8.1f ms (render %.1f ms + counts %.1f ms)  ratio %.2f\n", 1e3 * m,
                    1e3 * bench::median(render_s), 1e3 * bench::median(count_s), m / mb);
        std::printf("evaluation, V only          %8.1f ms  ratio %.2f\n", 1e3 * mv, mv / mb);
        const double mc = bench::median(cpu_s);
        std::printf("evaluation, lookups, cpu    %8.1f ms (counts %.1f ms)  ratio %.2f; %s/cpu %.3f\n", 1e3 * mc,
                    1e3 * bench::median(cpu_count_s), mc / mb, metrics::to_string(scorer).data(), m / mc);

        // 2. The search against the grid.
        if (grid > 0) {
            options.budget = budget;
            const auto t0 = SteadyClock::now();
            const tune::TuneResult s = tune::tune(scenarios, base, options, ctx);
            const double search_s = seconds_since(t0);
            const auto t1 = SteadyClock::now();
            const tune::TuneResult g = tune::grid_search(scenarios, base, options, ctx, grid);
            const double grid_s = seconds_since(t1);
            print_result("search", s, options);
            print_result("grid", g, options);
            if (s.winner && g.winner) {
                const double os = s.evaluations[*s.winner].minimized, og = g.evaluations[*g.winner].minimized;
                std::printf("search/grid: evaluations %.3f, objective %.4f (%+.2f%%), wall %.1f s / %.1f s\n",
                            static_cast<double>(s.evaluations.size()) / static_cast<double>(g.evaluations.size()),
                            og > 0 ? os / og : (os == 0 ? 1.0 : 0.0), og > 0 ? 100 * (os / og - 1) : 0.0, search_s,
                            grid_s);
            }
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "tune_bench: %s\n", e.what());
        return 1;
    }
    return 0;
}
