#include "common/scene.h"

#include <glm/geometric.hpp>

#include "common/receivers.h"

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

std::uint32_t Scene::add_triangle(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, bool is_double_sided) {
    const auto base = static_cast<std::uint32_t>(positions.size());
    for (const glm::dvec3& p : {a, b, c}) {
        positions.push_back(p);
        bounds.grow(p);
    }
    triangles.push_back({base, base + 1, base + 2});
    double_sided.push_back(is_double_sided);
    triangle_node.push_back(0);
    return static_cast<std::uint32_t>(triangles.size() - 1);
}

std::string Scene::node_label(std::uint32_t node) const {
    if (node == kReceiverNode) return "receivers";
    return node < node_labels.size() ? node_labels[node] : "node " + std::to_string(node);
}

double Bounds::radius() const {
    return empty() ? 0.0 : 0.5 * glm::length(hi - lo);
}

}  // namespace penumbra
