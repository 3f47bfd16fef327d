// libFuzzer target: a scenario file next to a small valid scene (scene.glb: a quad, a camera
// node and a KHR_lights_punctual spot light), so fuzzed scenarios reach the camera and light
// checks, "gltf_camera" and "lights": "gltf".
#include <nlohmann/json.hpp>

#include "common/output_files.h"
#include "common/scenario.h"
#include "fuzz_support.h"

namespace {

void write_scene() {
    // Two triangles: positions (4 x VEC3 float) then indices (6 x uint16), as a data: URI.
    const float pos[12] = {-1, 0, -1, 1, 0, -1, 1, 0, 1, -1, 0, 1};
    const std::uint16_t idx[6] = {0, 2, 1, 0, 3, 2};
    std::string bin(reinterpret_cast<const char*>(pos), sizeof pos);
    bin.append(reinterpret_cast<const char*>(idx), sizeof idx);
    nlohmann::json doc = {
        {"asset", {{"version", "2.0"}}},
        {"extensionsUsed", {"KHR_lights_punctual"}},
        {"scene", 0},
        {"scenes", {{{"nodes", {0, 1, 2}}}}},
        {"nodes",
         {{{"mesh", 0}},
          {{"camera", 0}, {"translation", {0, 2, 5}}},
          {{"translation", {0, 3, 0}},
           {"rotation", {-0.7071068, 0, 0, 0.7071068}},
           {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}}}},
        {"meshes", {{{"primitives", {{{"attributes", {{"POSITION", 0}}}, {"indices", 1}}}}}}},
        {"accessors",
         {{{"bufferView", 0}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"}},
          {{"bufferView", 1}, {"componentType", 5123}, {"count", 6}, {"type", "SCALAR"}}}},
        {"bufferViews", {{{"buffer", 0}, {"byteLength", 48}}, {{"buffer", 0}, {"byteOffset", 48}, {"byteLength", 12}}}},
        {"buffers",
         {{{"byteLength", bin.size()},
           {"uri", "data:application/octet-stream;base64," + penumbra::base64_encode(bin)}}}},
        {"cameras", {{{"type", "perspective"}, {"perspective", {{"yfov", 0.8}, {"znear", 0.1}}}}}},
        {"extensions",
         {{"KHR_lights_punctual", {{"lights", {{{"type", "spot"}, {"spot", {{"outerConeAngle", 0.6}}}}}}}}}}};
    const std::string text = doc.dump();
    penumbra::fuzz::write_file("scene.glb", reinterpret_cast<const std::uint8_t*>(text.data()), text.size());
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    penumbra::fuzz::stand_in_for_images();
    using namespace penumbra;
    static const bool scene_written = (write_scene(), true);
    (void)scene_written;
    const auto file = fuzz::write_file("scenario.json", data, size);
    fuzz::expect_input_errors_only([&] {
        ScenarioOptions options;
        options.max_memory_bytes = fuzz::kMaxMemory;
        load_scenario(file, options);
    });
    return 0;
}
