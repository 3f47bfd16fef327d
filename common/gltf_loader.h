// glTF 2.0 scene input (.gltf and .glb) with every check tinygltf leaves to its user.
#pragma once

#include <cstdint>
#include <filesystem>

#include "common/ranges.h"
#include "common/scene.h"

namespace penumbra {

struct GltfLoadOptions {
    // External buffer URIs resolve only inside the scene file's folder unless this is set.
    bool allow_external_paths = false;
    // Refuse, before flattening, a scene whose triangles would need more memory than this.
    std::uint64_t max_memory_bytes = UINT64_MAX;
};

// Loads and flattens the default scene. Throws InputError naming the file and the glTF
// element ("scene.gltf: accessors[3]: ...") for anything malformed.
Scene load_gltf(const std::filesystem::path& file, const GltfLoadOptions& options = {});

}  // namespace penumbra
