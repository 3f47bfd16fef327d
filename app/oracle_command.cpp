// `penumbra oracle`: trace the exact visibility of every light and write the oracle's frame.
#include <fmt/format.h>

#include <future>
#include <memory>
#include <system_error>
#include <thread>

#include "app/cli.h"
#include "common/errors.h"
#include "common/output_files.h"
#include "common/stopwatch.h"
#include "oracle/oracle_output.h"
#include "report/frame_files.h"

namespace penumbra::cli {
namespace {

int run_oracle_command(const std::filesystem::path& scenario_file, const Common& c, const SamplingArgs& a) {
    const ThreadLimit limit(c);
    auto t0 = SteadyClock::now();
    Scenario scenario = load_for_command(scenario_file, c);
    check_run_memory(scenario, c, true, nullptr, false);
    OracleTimings timings;
    timings.load_s = seconds_since(t0);

    // oracle.exr is written while the boundary phase runs (#39), on a thread of its own; its U and
    // boundary_m are filled in once that phase has ended. With --threads 1 it is written after the
    // boundary phase, beside oracle.png, as before: written first on the one thread, it would hide
    // nothing and no longer overlap the preview (2-4% slower on the 2-core VM:
    // docs/history/oracle-speed.md, session 19).
    OutputTransaction out(c.out);
    const bool early = (c.threads > 0 ? static_cast<unsigned>(c.threads) : std::thread::hardware_concurrency()) > 1;
    std::shared_future<void> early_exr;
    OracleTraceDone start_exr;
    if (early)
        start_exr = [&](const OracleFrame& frame) {
            try {
                early_exr = report::start_oracle_exr(out, frame, timings.write_exr_early_s.emplace(0.0));
            } catch (const std::system_error&) {  // no thread to be had: oracle.exr is written afterwards
                timings.write_exr_early_s.reset();
            }
            return early_exr;
        };
    OracleResult result = run_oracle(scenario, oracle_settings(c, a), start_exr);
    // The early write reads the frame's arrays: should anything below throw (a thread refused for
    // the PNG), it must end before `result`, declared before this guard, frees them.
    struct WaitForTheWrite {
        const std::shared_future<void>& write;
        ~WaitForTheWrite() {
            if (write.valid()) write.wait();
        }
    } wait_for_the_write{early_exr};

    report::write_oracle_outputs(out, scenario, result, timings, early_exr);
    out.commit();
    if (!c.quiet) {
        const auto& s = result.stats;
        fmt::print(
            "oracle: {}x{} px, {} triangles, {} lights; trace {:.3f} s, area lights {:.3f} s, boundaries {:.3f} s\n",
            scenario.width, scenario.height, scenario.scene.triangle_count(), scenario.lights.size(), s.trace_s,
            s.area_s, s.boundary_s);
        for (std::size_t li = 0; li < s.lights.size(); ++li) {
            const OracleLightStats& l = s.lights[li];
            fmt::print("  light {} ({}): {} lightable px, {} shadowed, {} ambiguous", li,
                       to_string(scenario.lights[li].type), l.lightable, l.shadowed, l.uncertain);
            if (l.area)
                fmt::print("; {:.1f} rays/px (max {}), {} px refined, {} at the ray cap",
                           l.sampling.rays_per_pixel_mean, l.sampling.rays_per_pixel_max, l.sampling.refined,
                           l.sampling.capped);
            fmt::print("\n");
        }
        fmt::print("results: {}/oracle.exr, oracle.json, oracle.png\n", c.out.string());
    }
    return kExitSuccess;
}

}  // namespace

Subcommand add_oracle_command(CLI::App& parent) {
    struct Args {
        std::filesystem::path scenario;
        Common common;
        SamplingArgs sampling;
    };
    auto a = std::make_shared<Args>();
    CLI::App* cmd = parent.add_subcommand("oracle", "Trace the exact visibility of every light (Embree)");
    add_scenario(cmd, a->scenario);
    add_common(cmd, a->common);
    add_size(cmd, a->common);
    add_sampling(cmd, a->sampling);
    describe_outputs(
        cmd,
        "Outputs (in --out): oracle.exr (A, prim, depth, P, N; per light V, E, U, lightable, occluder and\nboundary "
        "distances), oracle.json (what was traced, rays, timings) and oracle.png (a preview).",
        "penumbra oracle data/default/scenario.json --out oracle-out");
    return {cmd, [a] { return run_oracle_command(a->scenario, a->common, a->sampling); }};
}

}  // namespace penumbra::cli
