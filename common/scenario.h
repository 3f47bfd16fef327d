// The scenario file of docs/scenario.md: scene (and its scale), image, camera, lights, optional receivers,
// technique and gate.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/ranges.h"
#include "common/receivers.h"
#include "common/scene.h"

namespace penumbra {

inline constexpr int kMaxImageSide = 16384;
inline constexpr long long kMaxImagePixels = 8192LL * 8192LL;

struct ScenarioOptions {
    bool allow_external_paths = false;
    std::uint64_t max_memory_bytes = UINT64_MAX;  // for the scene's triangles (GltfLoadOptions)
};

struct Scenario {
    std::filesystem::path file;        // the scenario JSON
    std::filesystem::path scene_file;  // the glTF it names, resolved
    std::string label;                 // file name for messages
    int width = 0, height = 0;
    Camera camera;
    std::vector<Light> lights;                            // from the scenario, or the glTF's when "lights": "gltf"
    nlohmann::json technique = nlohmann::json::object();  // raw: validated by the raster path
    nlohmann::json gate = nlohmann::json::object();       // raw: validated by metrics
    double scale = 1.0;                                   // applied to the glTF scene (its units to metres)
    std::vector<Receiver> receivers;                      // added to the scene, already in `scene`
    Scene scene;
};

// Scenario "scale" limits: a factor from the model's units to metres (mm 0.001, km 1000, ...).
inline constexpr double kMinScale = 1e-6, kMaxScale = 1e6;

// Multiplies the glTF scene (positions, bounds, the cameras and lights its nodes place) by
// `scale` about the origin: what a scale on the glTF root would do.
void scale_scene(Scene& scene, double scale);

// Reads and validates everything; throws InputError naming the file and JSON path.
Scenario load_scenario(const std::filesystem::path& file, const ScenarioOptions& options = {});

}  // namespace penumbra
