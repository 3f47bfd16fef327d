// RasterSession speed: a cold render (a session made for one technique: scene upload, camera
// pass, pipelines, maps, buffers, then the render) against the Nth render on a warm session,
// as tune and sweep pay it. Both in the same run, as a ratio (the machine is shared and noisy).
//
// Scene: the bundled default scenario with only its directional light, 1280 x 720 px, 2048^2
// map, on the chosen Vulkan device (lavapipe unless --device or $PENUMBRA_VK_DEVICE). The warm
// renders alternate between techniques of one kind of change, so that each render really
// redoes what that change needs:
//   slope     bias.slope changes: shadow pass + lookup (the map must be drawn again)
//   world     bias.world changes: lookup only (the map is still in place)
//   filter    filter.type changes: a lookup pipeline per filter (cached after the first)
// Wall clock of render() per call, including the read-back: with every lookup (what validate
// reads) and with V alone (RenderOptions::lookups = false, what tune's and sweep's objectives
// read).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "bench/raster_bench_args.h"
#include "common/scenario.h"
#include "common/stopwatch.h"
#include "raster/raster.h"

namespace {

using namespace penumbra;
using bench::median;

raster::Technique technique(const nlohmann::json& change) {
    nlohmann::json j = {{"resolution", 2048}, {"bias", {{"slope", 1.5}}}};
    j.merge_patch(change);
    return raster::parse_technique(j, "bench");
}

}  // namespace

int main(int argc, char** argv) {
    const auto args = bench::parse_raster_bench_args(argc, argv, "raster_session_bench", 7, false);
    if (!args) return 2;
    const int repeat = args->repeat;
    try {
        Scenario sc = load_scenario(args->scenario);
        sc.lights.resize(1);
        raster::ContextOptions co;
        co.device = args->device;
        raster::VulkanContext ctx(co);
        std::printf("device: %s (%s)\nscene: %zu triangles, %dx%d px, 1 directional light, 2048^2 map; median of %d\n",
                    ctx.info().name.c_str(), ctx.info().driver.c_str(), sc.scene.triangle_count(), sc.width, sc.height,
                    repeat);
        std::printf("ratios against the cold run with lookups (what validate and run_raster pay)\n");
        std::printf("%-8s %-8s %10s %10s %8s\n", "change", "output", "median ms", "min ms", "/cold");
        double cold_s = 0;
        for (bool lookups : {true, false}) {
            raster::RenderOptions options;
            options.lookups = lookups;
            const char* output = lookups ? "lookups" : "V only";
            std::vector<double> cold;
            for (int r = 0; r < repeat; ++r) {
                auto t0 = SteadyClock::now();
                raster::RasterSession session(sc, ctx);
                session.render(technique(nlohmann::json::object()), options);
                cold.push_back(seconds_since(t0));
            }
            if (lookups) cold_s = median(cold);
            std::printf("%-8s %-8s %10.1f %10.1f %8.2f\n", "cold", output, median(cold) * 1e3,
                        *std::min_element(cold.begin(), cold.end()) * 1e3, median(cold) / cold_s);
            const std::vector<std::pair<std::string, std::vector<nlohmann::json>>> changes = {
                {"slope", {{{"bias", {{"slope", 1.0}}}}, {{"bias", {{"slope", 2.0}}}}}},
                {"world", {{{"bias", {{"world", 0.01}}}}, {{"bias", {{"world", 0.02}}}}}},
                {"filter", {{{"filter", {{"type", "pcf"}}}}, {{"filter", {{"type", "poisson"}}}}}}};
            for (const auto& [name, variants] : changes) {
                raster::RasterSession session(sc, ctx);
                for (const auto& v : variants) session.render(technique(v), options);  // first use builds
                std::vector<double> warm;
                for (int r = 0; r < repeat; ++r) {
                    auto t0 = SteadyClock::now();
                    session.render(technique(variants[static_cast<std::size_t>(r) % variants.size()]), options);
                    warm.push_back(seconds_since(t0));
                }
                std::printf("%-8s %-8s %10.1f %10.1f %8.2f\n", name.c_str(), output, median(warm) * 1e3,
                            *std::min_element(warm.begin(), warm.end()) * 1e3, median(warm) / cold_s);
            }
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "raster_session_bench: %s\n", e.what());
        return 3;
    }
    return 0;
}
