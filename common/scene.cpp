#include "common/scene.h"

#include <glm/geometric.hpp>

namespace penumbra {

const char* to_string(LightType type) {
    switch (type) {
        case LightType::directional: return "directional";
        case LightType::spot: return "spot";
        case LightType::point: return "point";
        case LightType::rect: return "rect";
        case LightType::disk: return "disk";
        case LightType::sphere: return "sphere";
    }
    return "?";
}

void Bounds::grow(const glm::dvec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
}

double Bounds::radius() const {
    return empty() ? 0.0 : 0.5 * glm::length(hi - lo);
}

}  // namespace penumbra
