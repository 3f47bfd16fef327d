// Visibility pictures a person can read, shared by the oracle and raster outputs so the two
// look alike side by side.
#pragma once

#include <vector>

namespace penumbra {

struct PreviewLight {
    const std::vector<float>* V = nullptr;
    const std::vector<float>* U = nullptr;  // ambiguity flags, may be null
};

// Linear RGB, row-major. Each light adds its own tint where it reaches the surface, so a shadow
// shows the colour of the light it blocks as missing; ambiguous pixels are magenta. `relief`
// (per pixel, may be empty) darkens by surface orientation.
std::vector<float> visibility_preview(const std::vector<float>& A, const std::vector<float>& relief,
                                      const std::vector<PreviewLight>& lights);

}  // namespace penumbra
