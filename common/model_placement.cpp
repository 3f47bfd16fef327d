#include "common/model_placement.h"

#include <algorithm>
#include <glm/geometric.hpp>

namespace penumbra {

void scale_scene(Scene& scene, double scale) {
    if (scale == 1.0) return;
    for (glm::dvec3& p : scene.positions) p *= scale;
    if (!scene.bounds.empty()) scene.bounds = {scene.bounds.lo * scale, scene.bounds.hi * scale};
    // The cameras scale with the model so that they show the same picture (inf stays inf).
    for (Camera& c : scene.cameras) {
        c.eye *= scale;
        c.znear *= scale;
        c.zfar *= scale;
        c.xmag *= scale;
        c.ymag *= scale;
    }
    for (Light& l : scene.lights) l.position *= scale;
}

void place_model(Scene& scene, const ModelPlacement& m) {
    if (!m.moves()) {
        scale_scene(scene, m.scale);
        return;
    }
    const glm::dquat r = glm::normalize(m.rotation);
    const auto turn = [&](const glm::dvec3& v) { return r * (m.z_up ? z_up_to_y_up(v) : v); };
    const auto place = [&](const glm::dvec3& p) { return m.translation + turn(m.scale * p); };
    for (glm::dvec3& p : scene.positions) p = place(p);
    // A rotation changes the box: made again from the triangles' corners, as the loader made it.
    scene.bounds = {};
    for (const glm::u32vec3& t : scene.triangles)
        for (int k = 0; k < 3; ++k) scene.bounds.grow(scene.positions[t[k]]);
    for (Camera& c : scene.cameras) {
        c.eye = place(c.eye);
        c.forward = turn(c.forward);
        c.right = turn(c.right);
        c.up = turn(c.up);
        c.znear *= m.scale;
        c.zfar *= m.scale;
        c.xmag *= m.scale;
        c.ymag *= m.scale;
    }
    for (Light& l : scene.lights) {
        l.position = place(l.position);
        l.direction = turn(l.direction);
    }
}

void append_model(Scene& scene, Scene&& part, const std::string& label) {
    if (!label.empty()) {
        for (Light& l : part.lights) l.origin = label + ": " + l.origin;
        for (std::string& w : part.warnings) w = label + ": " + w;
        for (std::string& n : part.node_labels) n = label + ": " + n;
    }
    if (scene.triangles.empty() && scene.positions.empty() && scene.cameras.empty() && scene.lights.empty() &&
        scene.warnings.empty()) {
        scene = std::move(part);
        return;
    }
    // The cut-out arrays cover the triangles and vertices before this part's (opaque) first.
    if (part.has_cutouts() || scene.has_cutouts()) scene.pad_cutout_arrays();
    const auto vertex_base = static_cast<std::uint32_t>(scene.positions.size());
    std::uint32_t node_base = 0;
    for (std::uint32_t n : scene.triangle_node) node_base = std::max(node_base, n + 1);
    scene.positions.insert(scene.positions.end(), part.positions.begin(), part.positions.end());
    for (const glm::u32vec3& t : part.triangles) scene.triangles.push_back(t + glm::u32vec3(vertex_base));
    scene.double_sided.insert(scene.double_sided.end(), part.double_sided.begin(), part.double_sided.end());
    node_base = std::max(node_base, static_cast<std::uint32_t>(scene.node_labels.size()));
    scene.node_labels.resize(node_base);
    for (std::uint32_t n : part.triangle_node) scene.triangle_node.push_back(n + node_base);
    scene.node_labels.insert(scene.node_labels.end(), part.node_labels.begin(), part.node_labels.end());
    scene.cameras.insert(scene.cameras.end(), part.cameras.begin(), part.cameras.end());
    scene.camera_placed.insert(scene.camera_placed.end(), part.camera_placed.begin(), part.camera_placed.end());
    scene.lights.insert(scene.lights.end(), part.lights.begin(), part.lights.end());
    scene.warnings.insert(scene.warnings.end(), part.warnings.begin(), part.warnings.end());
    if (part.has_cutouts()) {
        const auto material_base = static_cast<std::uint32_t>(scene.cutout_materials.size());
        const int texture_base = static_cast<int>(scene.alpha_textures.size());
        for (CutoutMaterial& m : part.cutout_materials) {
            if (m.texture >= 0) m.texture += texture_base;
            if (!label.empty()) m.label = label + ": " + m.label;
            scene.cutout_materials.push_back(std::move(m));
        }
        for (AlphaTexture& t : part.alpha_textures) {
            if (!label.empty()) t.label = label + ": " + t.label;
            scene.alpha_textures.push_back(std::move(t));
        }
        for (std::uint32_t c : part.triangle_cutout)
            scene.triangle_cutout.push_back(c == kNoCutout ? c : c + material_base);
        scene.texcoords.insert(scene.texcoords.end(), part.texcoords.begin(), part.texcoords.end());
        scene.vertex_alpha.insert(scene.vertex_alpha.end(), part.vertex_alpha.begin(), part.vertex_alpha.end());
    } else if (!scene.triangle_cutout.empty()) {
        scene.pad_cutout_arrays();
    }
    if (!part.bounds.empty()) {
        scene.bounds.grow(part.bounds.lo);
        scene.bounds.grow(part.bounds.hi);
    }
}

}  // namespace penumbra
