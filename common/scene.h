// The scene penumbra judges: triangles in double-precision world space, lights and cameras.
// Conventions follow glTF 2.0 (right-handed, +Y up, metres, cameras look down local -Z).
#pragma once

#include <cstdint>
#include <glm/common.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <string>
#include <vector>

#include "common/alpha_coverage.h"

namespace penumbra {

enum class LightType { directional, spot, point, rect, disk, sphere };
const char* to_string(LightType type);
inline bool is_area_light(LightType t) {
    return t == LightType::rect || t == LightType::disk || t == LightType::sphere;
}

struct Light {
    LightType type = LightType::directional;
    glm::dvec3 position{0.0};         // spot, point; centre of rect, disk, sphere
    glm::dvec3 direction{0.0};        // directional, spot: unit direction light travels
    double outer_cone_rad = 0;        // spot: half-angle of the cone
    double inner_cone_rad = 0;        // spot: shading only, no effect on visibility
    glm::dvec3 u{0.0}, v{0.0};        // rect: full edge vectors; emits towards u x v
    glm::dvec3 normal{0.0};           // disk: unit emitting normal
    double radius = 0;                // disk, sphere
    double angular_diameter_rad = 0;  // directional: the sun's disk, full angle (0: punctual; docs/oracle.md 8b)
    std::string origin;               // where it came from, for messages ("lights[2]", "gltf node 4")
};

// Whether V of the light is a fraction of an extent (an area light's surface, or a sun's disk
// of directions) that the oracle samples with a confidence bound and the metrics score as a
// soft shadow (docs/oracle.md).
inline bool is_soft_light(const Light& l) {
    return is_area_light(l.type) || (l.type == LightType::directional && l.angular_diameter_rad > 0);
}

enum class ProjectionType { perspective, orthographic };

struct Camera {
    ProjectionType type = ProjectionType::perspective;
    glm::dvec3 eye{0.0};
    glm::dvec3 forward{0, 0, -1}, right{1, 0, 0}, up{0, 1, 0};  // orthonormal
    double yfov_rad = 0.785398;                                 // perspective
    double xmag = 1, ymag = 1;                                  // orthographic half-extents
    double znear = 0.1, zfar = 1e30;
};

struct Bounds {
    glm::dvec3 lo{1e300}, hi{-1e300};
    // Inline: the loader calls it for every vertex of every triangle.
    void grow(const glm::dvec3& p) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    bool empty() const { return lo.x > hi.x; }
    glm::dvec3 center() const { return (lo + hi) * 0.5; }
    double radius() const;
};

// A flattened triangle soup; triangle index = primitive id in every output (oracle and raster).
inline constexpr std::size_t kMaxNodeLabelBytes = 64;   // of a node's name, in messages
inline constexpr std::uint32_t kNoCutout = UINT32_MAX;  // Scene::triangle_cutout of an opaque triangle

struct Scene {
    std::vector<glm::dvec3> positions;         // world space
    std::vector<glm::u32vec3> triangles;       // counter-clockwise = front face
    std::vector<std::uint8_t> double_sided;    // per triangle (glTF material.doubleSided)
    std::vector<std::uint32_t> triangle_node;  // per triangle: glTF node index
    std::vector<std::string> node_labels;      // per node index: "nodes[4] \"Terrain\"", for messages (may be short)
    std::vector<Camera> cameras;               // glTF cameras, placed by their first node; index = camera index
    std::vector<bool> camera_placed;           // false where no node of the scene uses that camera
    std::vector<Light> lights;                 // KHR_lights_punctual, placed by nodes
    // Cut-outs (alphaMode MASK) and blended materials (BLEND), common/alpha_coverage.h. All
    // empty in a scene without one, so
    // that such a scene costs nothing; otherwise triangle_cutout has one entry per triangle
    // (kNoCutout where opaque) and texcoords and vertex_alpha one per vertex.
    std::vector<CutoutMaterial> cutout_materials;
    std::vector<AlphaTexture> alpha_textures;
    std::vector<std::uint32_t> triangle_cutout;  // index into cutout_materials, or kNoCutout
    std::vector<glm::vec2> texcoords;            // the set each cut-out's baseColorTexture names
    std::vector<float> vertex_alpha;             // COLOR_0's alpha (1 where absent)
    Bounds bounds;
    std::vector<std::string> warnings;  // skipped points/lines, degenerate triangles, ...

    std::size_t triangle_count() const { return triangles.size(); }
    // Whether any triangle is MASK or BLEND (the arrays below are filled), and whether any is MASK.
    bool has_cutouts() const { return !triangle_cutout.empty(); }
    bool has_masks() const;
    // The MASK or BLEND material of triangle t, or nullptr where it is opaque.
    const CutoutMaterial* alpha_material_of(std::size_t t) const {
        if (t >= triangle_cutout.size() || triangle_cutout[t] == kNoCutout) return nullptr;
        return &cutout_materials[triangle_cutout[t]];
    }
    // The cut-out (MASK) material of triangle t, or nullptr where it is opaque or blended.
    const CutoutMaterial* cutout_of(std::size_t t) const {
        const CutoutMaterial* m = alpha_material_of(t);
        return m && m->mode == AlphaMode::mask ? m : nullptr;
    }
    // Whether the surface of cut-out triangle t is opaque at barycentrics (b1, b2) of its second
    // and third vertices, and whether that would change within reach_texels.
    CoverageAnswer cutout_coverage(std::size_t t, double b1, double b2, double reach_texels) const;
    // Grows triangle_cutout, texcoords and vertex_alpha to the triangles and vertices there are
    // (opaque, uv 0, alpha 1): called before the first cut-out is added and after the last.
    void pad_cutout_arrays();
    // What messages call a node (Scene::triangle_node's values): its label, "receivers", or "node N".
    std::string node_label(std::uint32_t node) const;
    // Appends a triangle with three vertices of its own (node 0) and grows the bounds; returns
    // its index. For scenes built in code (the stress cases, the tests).
    std::uint32_t add_triangle(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, bool double_sided);
};

}  // namespace penumbra
