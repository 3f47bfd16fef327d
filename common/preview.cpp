#include "common/preview.h"

#include <cmath>

namespace penumbra {

void VisibilityPreview::row(int y, float* rgb) const {
    static const glm::vec3 kTints[] = {
        {1.0f, 0.86f, 0.62f}, {0.55f, 0.72f, 1.0f}, {0.62f, 1.0f, 0.66f}, {1.0f, 0.62f, 0.85f}, {0.85f, 0.85f, 0.85f}};
    const float share = lights.empty() ? 1.0f : 1.0f / static_cast<float>(lights.size());
    const std::size_t first = static_cast<std::size_t>(y) * static_cast<std::size_t>(width);
    for (std::size_t i = first; i < first + static_cast<std::size_t>(width); ++i, rgb += 3) {
        glm::vec3 c(0.06f, 0.07f, 0.09f);
        if ((*A)[i] != 0) {
            const float shape = N ? 0.6f + 0.4f * std::abs((*N)[i].y) : 1.0f;
            glm::vec3 light(lights.empty() ? 1.0f : 0.0f);
            bool uncertain = false;
            for (std::size_t li = 0; li < lights.size(); ++li) {
                light += share * (*lights[li].V)[i] * kTints[li % 5];
                uncertain |= lights[li].U && (*lights[li].U)[i] != 0;
            }
            c = uncertain ? glm::vec3(0.95f, 0.1f, 0.9f) : shape * (0.1f + 0.85f * light);
        }
        for (int k = 0; k < 3; ++k) rgb[k] = c[k];
    }
}

}  // namespace penumbra
