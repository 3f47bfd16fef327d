// Visibility pictures a person can read, shared by the oracle and raster outputs so the two
// look alike side by side.
#pragma once

#include <glm/vec3.hpp>
#include <vector>

namespace penumbra {

struct PreviewLight {
    const std::vector<float>* V = nullptr;
    const std::vector<float>* U = nullptr;  // ambiguity flags, may be null
};

// Linear RGB, row-major. Each light adds its own tint where it reaches the surface, so a shadow
// shows the colour of the light it blocks as missing; ambiguous pixels are magenta. With
// normals, relief darkens by surface orientation (0.6 + 0.4 |N.y|).
struct VisibilityPreview {
    int width = 0;
    const std::vector<float>* A = nullptr;
    const std::vector<glm::vec3>* N = nullptr;  // may be null: no relief
    std::vector<PreviewLight> lights;

    // Row y: `width` pixels, 3 floats each. Computed row by row, so a large preview needs no
    // image-sized buffer (image_io's row-wise write_png).
    void row(int y, float* rgb) const;
};

}  // namespace penumbra
