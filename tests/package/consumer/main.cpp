// Validates a scenario in-process through the installed penumbra package and prints each
// light's verdict numbers as JSON (what report.json's "lights" holds), for the package test to
// compare with the command line's. With --compare IMAGE, the verdict of penumbra::compare on
// that engine image instead (the package test passes `penumbra raster`'s raster.exr).
#include <penumbra/penumbra.h>

#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

int main(int argc, char** argv) {
    const bool compare = argc == 4 && std::string(argv[2]) == "--compare";
    if (argc != 2 && !compare) {
        std::fprintf(stderr, "usage: consumer SCENARIO [--compare IMAGE]\n");
        return 2;
    }
    try {
        const penumbra::Scenario sc = penumbra::load_scenario(argv[1]);
        if (compare) {
            std::vector<std::size_t> all;
            for (std::size_t li = 0; li < sc.lights.size(); ++li) all.push_back(li);
            const penumbra::EngineFrame frame =
                penumbra::load_engine_frame(sc, argv[3], all, std::nullopt, penumbra::DepthSpace::linear);
            penumbra::CompareOptions options;
            options.validate.use_cache = false;
            const penumbra::ValidateResult r = penumbra::compare(sc, frame, options);
            nlohmann::json lights = nlohmann::json::array();
            for (const auto& l : r.score.lights) lights.push_back(penumbra::metrics::to_json(l));
            std::cout << nlohmann::json{{"version", penumbra::version_string()}, {"lights", lights}}.dump() << "\n";
            return 0;
        }
        const auto technique = penumbra::raster::parse_technique(sc.technique, "technique", sc.lights);
        const auto gate =
            penumbra::metrics::parse_gate(sc.gate, "gate", sc.lights, penumbra::metrics::GateOrigin::scenario);
        penumbra::ValidateOptions options;
        options.use_cache = false;
        const penumbra::ValidateResult r = penumbra::validate(sc, technique, gate, options);
        nlohmann::json lights = nlohmann::json::array();
        for (const auto& l : r.score.lights) lights.push_back(penumbra::metrics::to_json(l));
        std::cout << nlohmann::json{{"version", penumbra::version_string()}, {"lights", lights}}.dump() << "\n";
        return r.passed() ? 0 : 1;
    } catch (const penumbra::InputError& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 2;
    }
}
