// Validates a scenario in-process through the installed penumbra package and prints each
// light's verdict numbers as JSON (what report.json's "lights" holds), for the package test to
// compare with the command line's. With --compare IMAGE, the verdict of penumbra::compare on
// that engine image instead (the package test passes `penumbra raster`'s raster.exr).
#include <penumbra/penumbra.h>

#include <cstdio>
#include <iostream>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace {

// A technique family of the consumer's own, registered through the installed interface: every
// receiver lit, no passes.
class AllLit final : public penumbra::raster::TechniqueFamily {
  public:
    explicit AllLit(const penumbra::raster::SceneOnGpu& s) : pixels_(s.pixels) {}
    void render(const penumbra::raster::Technique&, std::span<const penumbra::Light> lights,
                const penumbra::raster::RenderOptions&, penumbra::RasterFrame& frame,
                penumbra::raster::RasterStats& stats) override {
        for (std::size_t li = 0; li < lights.size(); ++li) {
            frame.lights.push_back({std::vector<float>(pixels_, 1.0f), std::nullopt});
            stats.lights.emplace_back();
        }
    }

  private:
    std::size_t pixels_;
};

void register_all_lit() {
    penumbra::raster::FamilyEntry e;
    e.name = "consumer_all_lit";
    e.description = "every receiver lit (the package test's own family)";
    e.parse = [](penumbra::JsonObject&, penumbra::raster::Technique&) {};
    e.write = [](const penumbra::raster::Technique&, nlohmann::json&) {};
    e.hints = [](const penumbra::raster::Technique&) { return penumbra::raster::ScoringHints{}; };
    e.memory = [](const penumbra::raster::Technique&) { return penumbra::RasterMemory{}; };
    e.make = [](const penumbra::raster::SceneOnGpu& s) { return std::make_unique<AllLit>(s); };
    penumbra::raster::register_technique_family(std::move(e));
}

}  // namespace

int main(int argc, char** argv) {
    const bool compare = argc == 4 && std::string(argv[2]) == "--compare";
    const bool own_family = argc == 3 && std::string(argv[2]) == "--own-family";
    if (argc != 2 && !compare && !own_family) {
        std::fprintf(stderr, "usage: consumer SCENARIO [--compare IMAGE | --own-family]\n");
        return 2;
    }
    try {
        const penumbra::Scenario sc = penumbra::load_scenario(argv[1]);
        if (own_family) {
            // The consumer's family, picked by its key, draws the validate.
            register_all_lit();
            const auto technique =
                penumbra::raster::parse_technique({{"family", "consumer_all_lit"}}, "technique", sc.lights);
            penumbra::ValidateOptions options;
            options.use_cache = false;
            const penumbra::ValidateResult r = penumbra::validate(sc, technique, {}, options);
            std::cout << nlohmann::json{{"family", r.raster.stats.family}, {"technique", technique.to_json()}}.dump()
                      << "\n";
            return 0;
        }
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
