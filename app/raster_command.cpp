// `penumbra raster`: render the scenario's shadows with a technique; `penumbra devices`.
#include <fmt/format.h>

#include <memory>

#include "app/cli.h"
#include "common/errors.h"
#include "common/output_files.h"
#include "common/stopwatch.h"
#include "raster/raster.h"
#include "raster/raster_output.h"
#include "raster/technique_family.h"
#include "report/frame_files.h"

namespace penumbra::cli {
namespace {

int run_raster_command(const std::filesystem::path& scenario_file, const Common& c, const TechniqueArgs& t) {
    const ThreadLimit limit(c);
    auto t0 = SteadyClock::now();
    Scenario scenario = load_for_command(scenario_file, c);
    raster::Technique technique = resolve_technique(scenario, t);
    say_preset_differences(technique, c.quiet);
    check_run_memory(scenario, c, false, &technique, false);
    raster::RasterTimings timings;
    timings.threads = static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
    timings.load_s = seconds_since(t0);

    auto t1 = SteadyClock::now();
    raster::ContextOptions co;
    co.device = t.device;
    raster::VulkanContext ctx(co);
    timings.device_s = seconds_since(t1);
    raster::RasterResult result = raster::run_raster(scenario, technique, ctx);

    OutputTransaction out(c.out);
    report::write_raster_outputs(out, scenario, technique, result, timings);
    out.commit();
    if (!c.quiet) {
        const auto& s = result.stats;
        for (const auto& w : s.warnings) fmt::print(stderr, "warning: {}\n", w);
        // A family without a map (shadow volumes, planar projection): its passes are all GPU time.
        const std::string map = raster::family_of(technique).draws_maps
                                    ? fmt::format("{}^2 {} map; GPU shadow {:.2f} ms", technique.resolution,
                                                  raster::to_string(technique.depth_format), s.gpu_ms["shadow"])
                                    : fmt::format("{}, no map; GPU {:.2f} ms", s.family, s.gpu_ms.total());
        fmt::print("raster: {}x{} px, {} lights on {}; {}, camera {:.2f} ms\n", scenario.width, scenario.height,
                   scenario.lights.size(), s.device.name, map, s.camera_ms + s.gpu_ms["lookup"]);
        fmt::print("results: {}/raster.exr, raster.json, raster.png\n", c.out.string());
    }
    return kExitSuccess;
}

int run_devices_command() {
    for (const auto& d : raster::list_devices())
        fmt::print("{}: {} ({}, Vulkan {}, {}){}\n", d.index, d.name, d.type, d.api_version, d.driver,
                   d.lavapipe ? " [default]" : "");
    return kExitSuccess;
}

}  // namespace

Subcommand add_raster_command(CLI::App& parent) {
    struct Args {
        std::filesystem::path scenario;
        Common common;
        TechniqueArgs technique;
    };
    auto a = std::make_shared<Args>();
    CLI::App* cmd = parent.add_subcommand("raster", "Render the scenario's shadows with a technique (Vulkan)");
    add_scenario(cmd, a->scenario);
    add_common(cmd, a->common);
    add_size(cmd, a->common);
    add_technique(cmd, a->technique);
    describe_outputs(
        cmd,
        "Outputs (in --out): raster.exr (A, prim; per light V, the layer each pixel used and the depth-map\nlookups), "
        "raster.json (the resolved technique, device, views per light, GPU times) and raster.png.",
        "penumbra raster data/default/scenario.json --out raster-out --preset d3d12-textbook");
    return {cmd, [a] { return run_raster_command(a->scenario, a->common, a->technique); }};
}

Subcommand add_devices_command(CLI::App& parent) {
    CLI::App* cmd = parent.add_subcommand("devices", "List the Vulkan devices --device can choose");
    describe_outputs(cmd,
                     "Outputs: a line per Vulkan device on stdout (index, name, type, driver); nothing is written.",
                     "penumbra devices");
    return {cmd, [] { return run_devices_command(); }};
}

}  // namespace penumbra::cli
