// How much constant depth bias receiver-plane bias needs on a device: the acne fraction of a
// plane under a 35-degree sun (nothing occludes it, so every dark pixel is acne), per depth
// format and constant (units of the format's r), with receiver_plane on; slope bias 2 without
// it for reference. docs/raster.md ("Receiver-plane bias per device") has the numbers measured.
// Run: build/bench/receiver_plane_probe [--device D]
#include <cmath>
#include <cstdio>
#include <string>

#include "raster/raster.h"
#include "tests/test_support.h"

int main(int argc, char** argv) {
    using namespace penumbra;
    raster::ContextOptions co;
    if (argc == 3 && std::string(argv[1]) == "--device") {
        co.device = argv[2];
    } else if (argc != 1) {
        std::fprintf(stderr, "usage: receiver_plane_probe [--device D]\n");
        return 2;
    }
    try {
        test::SceneBuilder b;
        b.quad({-10, 0, -10}, {-10, 0, 10}, {10, 0, 10}, {10, 0, -10});
        const double elev = 35.0 * 3.14159265358979323846 / 180.0;
        Scenario sc = test::make_scenario(b.build(), test::look_at({0, 8, 8}, {0, 0, 0}, 50),
                                          {test::directional({std::cos(elev), -std::sin(elev), 0.3})}, 320, 240);
        raster::VulkanContext ctx(co);
        raster::RasterSession session(sc, ctx);
        std::printf("device: %s (%s); 1024^2 map, acne fraction per constant bias (units of r)\n",
                    ctx.info().name.c_str(), ctx.info().driver.c_str());
        for (const char* format : {"d16", "d24", "d32"})
            for (bool plane : {true, false}) {
                std::printf("%s %-22s", format, plane ? "receiver_plane" : "slope 2 (reference)");
                for (double c : {0.0, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0}) {
                    nlohmann::json bias = {{"constant", c}};
                    if (plane)
                        bias["receiver_plane"] = true;
                    else
                        bias["slope"] = 2.0;
                    const raster::RasterResult r =
                        session.render(raster::parse_technique(
                                           {{"resolution", 1024}, {"depth_format", format}, {"bias", bias}}, "probe"),
                                       {.lookups = false});
                    std::size_t surface = 0, dark = 0;
                    for (std::size_t i = 0; i < r.frame.pixel_count(); ++i) {
                        if (r.frame.prim[i] == kNoPrimitive) continue;
                        ++surface;
                        dark += r.frame.lights[0].V[i] < 1.0f;
                    }
                    std::printf("  c%-3g %.4f", c, static_cast<double>(dark) / static_cast<double>(surface));
                }
                std::printf("\n");
            }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "receiver_plane_probe: %s\n", e.what());
        return 3;
    }
    return 0;
}
