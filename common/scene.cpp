#include "common/scene.h"

#include <algorithm>
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
    if (has_cutouts()) pad_cutout_arrays();
    return static_cast<std::uint32_t>(triangles.size() - 1);
}

std::string Scene::node_label(std::uint32_t node) const {
    if (node == kReceiverNode) return "receivers";
    return node < node_labels.size() ? node_labels[node] : "node " + std::to_string(node);
}

bool Scene::has_masks() const {
    return has_cutouts() && std::any_of(cutout_materials.begin(), cutout_materials.end(),
                                        [](const CutoutMaterial& m) { return m.mode == AlphaMode::mask; });
}

void Scene::pad_cutout_arrays() {
    triangle_cutout.resize(triangles.size(), kNoCutout);
    texcoords.resize(positions.size(), glm::vec2(0.0f));
    vertex_alpha.resize(positions.size(), 1.0f);
}

CoverageAnswer Scene::cutout_coverage(std::size_t t, double b1, double b2, double reach_texels) const {
    const CutoutMaterial& m = cutout_materials[triangle_cutout[t]];
    const glm::u32vec3& tri = triangles[t];
    const double b0 = 1.0 - b1 - b2;
    const glm::dvec2 uv =
        b0 * glm::dvec2(texcoords[tri.x]) + b1 * glm::dvec2(texcoords[tri.y]) + b2 * glm::dvec2(texcoords[tri.z]);
    const double alpha = b0 * vertex_alpha[tri.x] + b1 * vertex_alpha[tri.y] + b2 * vertex_alpha[tri.z];
    const AlphaTexture* texture = m.texture >= 0 ? &alpha_textures[static_cast<std::size_t>(m.texture)] : nullptr;
    return judge_coverage(m, texture, uv, alpha, reach_texels);
}

double Bounds::radius() const {
    return empty() ? 0.0 : 0.5 * glm::length(hi - lo);
}

}  // namespace penumbra
