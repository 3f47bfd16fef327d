// glTF 2.0 scene input (.gltf and .glb) with every check tinygltf leaves to its user.
#pragma once

#include <filesystem>

#include "common/scene.h"

namespace penumbra {

struct GltfLoadOptions {
    // External buffer URIs resolve only inside the scene file's folder unless this is set.
    bool allow_external_paths = false;
};

// Loads and flattens the default scene. Throws InputError naming the file and the glTF
// element ("scene.gltf: accessors[3]: ...") for anything malformed.
Scene load_gltf(const std::filesystem::path& file, const GltfLoadOptions& options = {});

// Largest world-space coordinate accepted, in metres: beyond it float conversion of even
// camera-relative coordinates loses all meaning.
inline constexpr double kMaxCoordinate = 1e15;

}  // namespace penumbra
