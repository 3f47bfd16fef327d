// The verdict per light on a device, for comparing devices: validate each scenario with its own
// technique (no cache, nothing written) and print every light's class counts. Used to check
// that a GPU gives lavapipe's verdicts (docs/raster.md, "Verdicts on two devices").
// Run: build/bench/class_counts [--device D] SCENARIO...
#include <cstdio>
#include <string>
#include <vector>

#include "pipeline/validate.h"

int main(int argc, char** argv) {
    using namespace penumbra;
    ValidateOptions options;
    options.use_cache = false;
    std::vector<std::string> scenarios;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--device" && i + 1 < argc)
            options.device = argv[++i];
        else
            scenarios.push_back(a);
    }
    if (scenarios.empty()) {
        std::fprintf(stderr, "usage: class_counts [--device D] SCENARIO...\n");
        return 2;
    }
    try {
        for (const auto& file : scenarios) {
            const Scenario sc = load_scenario(file);
            const raster::Technique technique = raster::parse_technique(sc.technique, sc.label, sc.lights);
            const ValidateResult r = validate(sc, technique, metrics::Gate{}, options);
            std::printf("%s on %s (%s):\n", file.c_str(), r.raster.stats.device.name.c_str(),
                        technique.preset.empty() ? "technique" : technique.preset.c_str());
            for (std::size_t li = 0; li < r.score.lights.size(); ++li) {
                const metrics::LightScore& s = r.score.lights[li];
                std::printf("  light %zu (%s): scored %llu", li, to_string(sc.lights[li].type),
                            static_cast<unsigned long long>(s.pixels.scored));
                for (metrics::PixelClass c : metrics::kErrorClasses)
                    std::printf(", %s %llu", std::string(metrics::to_string(c)).c_str(),
                                static_cast<unsigned long long>(s.count(c)));
                std::printf("\n");
            }
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "class_counts: %s\n", e.what());
        return 3;
    }
    return 0;
}
