// The scenario file of docs/scenario.md: scene, image, camera, lights, optional technique and gate.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/ranges.h"
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
    Scene scene;
};

// Reads and validates everything; throws InputError naming the file and JSON path.
Scenario load_scenario(const std::filesystem::path& file, const ScenarioOptions& options = {});

}  // namespace penumbra
