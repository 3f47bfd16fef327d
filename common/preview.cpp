#include "common/preview.h"

#include <glm/vec3.hpp>

namespace penumbra {

std::vector<float> visibility_preview(const std::vector<float>& A, const std::vector<float>& relief,
                                      const std::vector<PreviewLight>& lights) {
    static const glm::vec3 kTints[] = {
        {1.0f, 0.86f, 0.62f}, {0.55f, 0.72f, 1.0f}, {0.62f, 1.0f, 0.66f}, {1.0f, 0.62f, 0.85f}, {0.85f, 0.85f, 0.85f}};
    const std::size_t n = A.size();
    const float share = lights.empty() ? 1.0f : 1.0f / static_cast<float>(lights.size());
    std::vector<float> rgb(3 * n);
    for (std::size_t i = 0; i < n; ++i) {
        glm::vec3 c(0.06f, 0.07f, 0.09f);
        if (A[i] != 0) {
            float shape = relief.empty() ? 1.0f : relief[i];
            glm::vec3 light(lights.empty() ? 1.0f : 0.0f);
            bool uncertain = false;
            for (std::size_t li = 0; li < lights.size(); ++li) {
                light += share * (*lights[li].V)[i] * kTints[li % 5];
                uncertain |= lights[li].U && (*lights[li].U)[i] != 0;
            }
            c = uncertain ? glm::vec3(0.95f, 0.1f, 0.9f) : shape * (0.1f + 0.85f * light);
        }
        for (int k = 0; k < 3; ++k) rgb[3 * i + k] = c[k];
    }
    return rgb;
}

}  // namespace penumbra
