// The scenario file of docs/scenario.md: scene (and its scale), image, camera, lights, optional receivers,
// technique and gate.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/model_placement.h"
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

// Most frames a camera path may ask for (each is a trace and a render).
inline constexpr int kMaxPathFrames = 10000;

// One key of a camera path: the camera, with the look-at target it was given (a glTF camera's is
// one metre ahead), so that frames between keys interpolate what the user wrote.
struct CameraKey {
    Camera camera;
    glm::dvec3 target{0.0};
};

// "camera_path" (docs/scenario.md): `frames` cameras, linear between the keys. Frame 0 is keys[0],
// the last frame the last key, the others spread evenly along the keys' parameter.
struct CameraPath {
    int frames = 0;
    std::vector<CameraKey> keys;
};

// The camera of frame `frame` (0 ... path.frames - 1): eye, target, up and the scalars (field of
// view, half-extents, znear, zfar) each linear between the two keys around it; the basis is then
// made again by look_at_basis. Returns std::nullopt where that basis is degenerate (the target
// meets the eye, or up turns parallel to the view direction).
std::optional<Camera> path_camera(const CameraPath& path, int frame);

struct Scenario {
    std::filesystem::path file;        // the scenario JSON
    std::filesystem::path scene_file;  // the (first) glTF it names, resolved
    std::vector<ModelPlacement> models;  // every glTF of "scene", placed; scene_file is models[0].file
    std::string label;                 // file name for messages
    int width = 0, height = 0;
    Camera camera;                                        // the path's first frame when only "camera_path" is given
    std::optional<CameraPath> camera_path;                // validate judges every frame of it (pipeline/camera_path.h)
    std::vector<Light> lights;                            // from the scenario, or the glTF's when "lights": "gltf"
    nlohmann::json technique = nlohmann::json::object();  // raw: validated by the raster path
    nlohmann::json gate = nlohmann::json::object();       // raw: validated by metrics
    double scale = 1.0;                                   // applied to every model (its units to metres)
    std::vector<Receiver> receivers;                      // added to the scene, already in `scene`
    Scene scene;
};

// Scenario "scale" limits: a factor from the model's units to metres (mm 0.001, km 1000, ...).
inline constexpr double kMinScale = 1e-6, kMaxScale = 1e6;
// Most models one "scene" list may hold.
inline constexpr std::size_t kMaxModels = 256;


// What outputs record as the scenario's "scene": the glTF file's path, or the list of them.
nlohmann::json scene_files_json(const Scenario& scenario);

// Reads and validates everything; throws InputError naming the file and JSON path.
Scenario load_scenario(const std::filesystem::path& file, const ScenarioOptions& options = {});

}  // namespace penumbra
