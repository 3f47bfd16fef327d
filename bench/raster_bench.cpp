// Raster path speed: GPU time of the shadow pass and the camera pass (camera raster + per-light
// lookup) at shadow-map resolutions 1024^2 ... 8192^2, 1280 x 720 pixels, on the chosen Vulkan
// device (lavapipe unless --device or $PENUMBRA_VK_DEVICE says otherwise).
//
// Scene: the bundled default scenario with only its directional light (one map per run), and
// a 131k-triangle terrain version of it (--terrain) to load the rasteriser. Median of --repeat
// runs per resolution; wall clock includes submission and waiting, not setup.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "bench/raster_bench_args.h"
#include "common/scenario.h"
#include "raster/raster.h"

namespace {

using namespace penumbra;
using bench::median;

void add_terrain(Scene& s, int grid) {
    const double extent = 16.0;
    std::uint32_t base = static_cast<std::uint32_t>(s.positions.size());
    for (int j = 0; j <= grid; ++j)
        for (int i = 0; i <= grid; ++i) {
            double x = -extent / 2 + extent * i / grid, z = -extent / 2 + extent * j / grid;
            glm::dvec3 p(x, -0.05 + 0.04 * std::sin(3.1 * x) * std::cos(2.3 * z), z);
            s.positions.push_back(p);
            s.bounds.grow(p);
        }
    for (int j = 0; j < grid; ++j)
        for (int i = 0; i < grid; ++i) {
            std::uint32_t a = base + j * (grid + 1) + i, b = a + 1, c = a + grid + 1, d = c + 1;
            s.triangles.push_back({a, c, b});
            s.triangles.push_back({b, c, d});
            for (int k = 0; k < 2; ++k) {
                s.double_sided.push_back(1);
                s.triangle_node.push_back(0);
            }
        }
}

}  // namespace

int main(int argc, char** argv) {
    const auto args = bench::parse_raster_bench_args(argc, argv, "raster_bench", 3, true);
    if (!args) return 2;
    const int repeat = args->repeat;
    try {
        Scenario sc = load_scenario(args->scenario);
        sc.lights.resize(1);  // the directional light: one map per run
        if (args->terrain) add_terrain(sc.scene, 256);
        raster::ContextOptions co;
        co.device = args->device;
        raster::VulkanContext ctx(co);
        std::printf("device: %s (%s)\nscene: %zu triangles, %dx%d px, 1 directional light\n", ctx.info().name.c_str(),
                    ctx.info().driver.c_str(), sc.scene.triangle_count(), sc.width, sc.height);
        std::printf("%-10s %12s %14s %12s %12s\n", "map", "shadow ms", "camera+lookup", "lookup ms", "wall ms");
        for (int res : {1024, 2048, 4096, 8192}) {
            raster::Technique t = raster::parse_technique({{"resolution", res}, {"bias", {{"slope", 1.5}}}}, "bench");
            std::vector<double> shadow, camera, lookup, wall;
            raster::run_raster(sc, t, ctx);  // warm-up: pipeline compilation, first-touch memory
            for (int r = 0; r < repeat; ++r) {
                raster::RasterResult out = raster::run_raster(sc, t, ctx);
                shadow.push_back(out.stats.shadow_ms);
                camera.push_back(out.stats.camera_ms + out.stats.lookup_ms);
                lookup.push_back(out.stats.lookup_ms);
                wall.push_back(out.stats.render_s * 1e3);
            }
            std::printf("%5d^2    %12.2f %14.2f %12.2f %12.2f\n", res, median(shadow), median(camera), median(lookup),
                        median(wall));
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "raster_bench: %s\n", e.what());
        return 3;
    }
    return 0;
}
