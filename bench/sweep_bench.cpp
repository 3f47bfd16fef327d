// sweep's cost and its table on a device without penumbra's command line (the GPU bundle):
// one set-up (oracle from the cache or traced, the session) + N configurations, each a verdict
// (a diagnostic render with lookups + the metrics) and --repeat timed renders of each kind.
// Prints the set-up and per-configuration wall clock, resident memory per configuration (a
// session must not grow per render), then sweep.csv on stdout.
// --scorer cpu|gpu picks the verdict's scorer (metrics/gpu_classification.h; default: the
// device's preferred one); the one used is printed with the device's timestamp clocks.
// Run: build/bench/sweep_bench [--scenario FILE] [--terrain-grid N] [--device D] [--repeat 3]
//      [--scorer cpu|gpu] [--set KEY=V ...] --vary KEY=V1,V2,... [--vary ...]
#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "bench/raster_bench_args.h"
#include "common/scenario.h"
#include "sweep/sweep.h"

namespace {

double peak_rss_mb() {
    rusage u{};
    ::getrusage(RUSAGE_SELF, &u);
    return static_cast<double>(u.ru_maxrss) / 1024.0;  // kilobytes on Linux
}

}  // namespace

int main(int argc, char** argv) {
    using namespace penumbra;
    std::filesystem::path scenario_file = test::data_dir() / "default/scenario.json";
    std::string device;
    int repeat = 3, terrain = 0;
    std::vector<std::string> vary, sets;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (i + 1 >= argc) {
            std::fprintf(stderr, "sweep_bench: %s needs a value\n", a.c_str());
            return 2;
        }
        const std::string v = argv[++i];
        if (a == "--scenario")
            scenario_file = v;
        else if (a == "--device")
            device = v;
        else if (a == "--repeat")
            repeat = std::max(1, std::atoi(v.c_str()));
        else if (a == "--terrain-grid")
            terrain = std::max(1, std::atoi(v.c_str()));
        else if (a == "--vary")
            vary.push_back(v);
        else if (a == "--set")
            sets.push_back(v);
        else if (a == "--scorer")
            ::setenv("PENUMBRA_SCORER", v.c_str(), 1);
        else {
            std::fprintf(stderr,
                         "usage: sweep_bench [--scenario F] [--terrain-grid N] [--device D] [--repeat N] [--set K=V] "
                         "--vary K=V,...\n");
            return 2;
        }
    }
    try {
        Scenario sc = load_scenario(scenario_file);
        if (terrain > 0) bench::add_terrain(sc.scene, terrain);
        std::vector<sweep::Axis> axes;
        std::vector<std::string> keys;
        for (const auto& v : vary) {
            axes.push_back(sweep::parse_axis(v));
            keys.push_back(axes.back().key);
        }
        nlohmann::json base = sc.technique;
        for (const auto& s : sets) raster::apply_override(base, s);
        const auto configs = sweep::expand(base, axes, sc.lights);
        raster::ContextOptions co;
        co.device = device;
        raster::VulkanContext ctx(co);
        sweep::SweepOptions options;
        options.repeat = repeat;
        options.validate.oracle.progress = false;
        // Resident memory after each configuration: a session must not grow per render
        // (issue #32). Read from /proc/self/statm (resident pages).
        std::vector<double> rss_mb;
        const double page_mb = static_cast<double>(::sysconf(_SC_PAGESIZE)) / (1 << 20);
        auto resident_mb = [page_mb] {
            long size = 0, resident = 0;
            if (std::FILE* f = std::fopen("/proc/self/statm", "r")) {
                if (std::fscanf(f, "%ld %ld", &size, &resident) != 2) resident = 0;
                std::fclose(f);
            }
            return static_cast<double>(resident) * page_mb;
        };
        options.progress = [&](const sweep::Row& r, std::size_t done, std::size_t of) {
            rss_mb.push_back(resident_mb());
            std::fprintf(stderr, "[%zu/%zu] %.2f s, resident %.1f MB\n", done, of, r.seconds, rss_mb.back());
        };
        const sweep::Table t =
            sweep::run_sweep(sc, scenario_file.string(), keys, configs, configs.size(), {}, options, ctx);
        double sum = 0;
        for (const auto& r : t.rows) sum += r.seconds;
        std::printf("# device: %s (%s); %zu triangles, %dx%d px, %zu lights; repeat %d\n", ctx.info().name.c_str(),
                    ctx.info().driver.c_str(), sc.scene.triangle_count(), sc.width, sc.height, sc.lights.size(),
                    repeat);
        std::printf("# scorer %s; timestamps %s\n", t.device.value("scorer", "?").c_str(),
                    t.device.value("timestamps", nlohmann::json::object()).dump().c_str());
        std::printf("# set-up %.2f s (oracle %s + session); %zu configurations %.2f s, %.3f s each\n", t.setup_s,
                    "from the cache or traced", t.rows.size(), sum, sum / static_cast<double>(t.rows.size()));
        // Where a configuration's wall clock goes (medians over the configurations after the
        // first, which builds pipelines): the verdict, the timed renders of each kind with their
        // warm-ups (their families' set-up, submit-and-wait, and GPU time), the perceptual wait.
        if (t.rows.size() > 1) {
            auto med = [&](auto field) {
                std::vector<double> v;
                for (std::size_t i = 1; i < t.rows.size(); ++i) v.push_back(field(t.rows[i]));
                return bench::median(v);
            };
            const double renders = 2.0 * (repeat + sweep::kWarmUpRenders) - 1;
            std::printf(
                "# per configuration (median, ms): total %.1f = verdict %.1f (render %.1f) + diagnostic renders %.1f + "
                "production "
                "renders %.1f + perceptual wait %.1f (perceptual %.1f, beside the renders); timed renders (%.0f): "
                "set-up %.1f, submit-and-wait %.1f, GPU "
                "(timed repeats) %.1f\n",
                1e3 * med([](const sweep::Row& r) { return r.seconds; }),
                1e3 * med([](const sweep::Row& r) { return r.verdict_s; }),
                1e3 * med([](const sweep::Row& r) { return r.verdict_render_s; }),
                1e3 * med([](const sweep::Row& r) { return r.diagnostic_s; }),
                1e3 * med([](const sweep::Row& r) { return r.production_s; }),
                1e3 * med([](const sweep::Row& r) { return r.perceptual_wait_s; }),
                1e3 * med([](const sweep::Row& r) { return r.perceptual_s; }), renders,
                1e3 * med([](const sweep::Row& r) { return r.timed_setup_s; }),
                1e3 * med([](const sweep::Row& r) { return r.timed_submit_s; }), med([](const sweep::Row& r) {
                    double g = 0;
                    for (double v : r.diagnostic_ms) g += v;
                    for (double v : r.production_ms) g += v;
                    return g;
                }));
        }
        if (rss_mb.size() >= 20) {
            // Growth per configuration from the 10th on (the first ones fill caches and pools).
            const double per = (rss_mb.back() - rss_mb[9]) / static_cast<double>(rss_mb.size() - 10);
            std::printf(
                "# resident after configuration 10: %.1f MB, after %zu: %.1f MB (%.3f MB per configuration); "
                "peak %.1f MB\n",
                rss_mb[9], rss_mb.size(), rss_mb.back(), per, peak_rss_mb());
        } else {
            std::printf("# peak resident %.1f MB\n", peak_rss_mb());
        }
        std::fputs(sweep::sweep_csv(t).c_str(), stdout);
        // Timings to trust: how far each configuration's repeats spread ((max - min) / median).
        std::printf("# spread of the repeats, production / diagnostic (* beyond %.0f%%):\n",
                    sweep::kRepeatSpreadMargin * 100);
        for (const auto& r : t.rows) {
            std::string label;
            for (const auto& v : r.values) label += (label.empty() ? "" : ",") + v;
            std::printf("#   %s: %.3f / %.3f%s\n", label.c_str(), sweep::spread(r.production_ms),
                        sweep::spread(r.diagnostic_ms), sweep::repeats_disagree(r) ? " *" : "");
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "sweep_bench: %s\n", e.what());
        return 1;
    }
    return 0;
}
