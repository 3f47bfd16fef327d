// Stencil shadow volumes (docs/raster.md, "Shadow volumes"): Crow 1977, counted in the stencil
// buffer (Heidmann 1991), z-fail with capped volumes and points at infinity so that the camera
// may stand inside one (Carmack's reverse; Everitt & Kilgard 2002, "Practical and Robust
// Stenciled Shadow Volumes"). The silhouettes and volumes are built on the CPU, once per scene
// and light; this header is what the renderer and the tests read of them.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>
#include <span>
#include <vector>

#include "common/scene.h"
#include "raster/technique.h"

namespace penumbra::raster {

// What a mesh that is not a closed 2-manifold casts (`shadow_volume.open_meshes`).
enum class OpenMeshRule {
    skip,     // casts nothing: its volume would not be closed, so its counts would be wrong
    include,  // every triangle casts as a two-sided sheet: a capped prism each, closed by construction
};
// How the stencil counts the volumes (`shadow_volume.method`).
enum class StencilMethod {
    zfail,  // Carmack's reverse: count the faces behind the surface (right with the camera inside a volume)
    zpass,  // Heidmann 1991: count the faces in front (wrong wherever the camera is inside a volume)
};
const char* to_string(OpenMeshRule r);
const char* to_string(StencilMethod m);

struct ShadowVolumeParameters final : FamilyParameters {
    OpenMeshRule open_meshes = OpenMeshRule::include;
    StencilMethod method = StencilMethod::zfail;
};
// The family's parameters when `t` is drawn by it, else null.
const ShadowVolumeParameters* shadow_volume_parameters(const Technique& t);

inline constexpr std::uint32_t kNoMesh = 0xFFFFFFFFu;

// A mesh: the triangles of one glTF node connected through shared edges (vertices welded by
// exact position), with the edges that keep it from being a closed 2-manifold.
struct MeshTopology {
    std::uint32_t node = 0;
    std::uint32_t first_triangle = 0;  // its lowest triangle index
    std::size_t triangles = 0;
    std::size_t open_edges = 0;          // used by one triangle (a boundary)
    std::size_t non_manifold_edges = 0;  // used by three or more, or by two in the same direction
    bool closed() const { return open_edges == 0 && non_manifold_edges == 0; }
};

struct SceneTopology {
    std::vector<MeshTopology> meshes;
    std::vector<std::uint32_t> mesh_of;  // per triangle; kNoMesh for a degenerate (welded) one
    std::vector<std::uint32_t> welded;   // per scene vertex: the welded vertex id
};
SceneTopology scene_topology(const Scene& scene);

// One light's volumes, a triangle list of homogeneous camera-relative points (w = 0 at infinity).
struct ShadowVolumeGeometry {
    std::vector<glm::vec4> vertices;
    std::size_t caster_triangles = 0;           // triangles whose prism is drawn
    std::size_t silhouette_edges = 0;           // side quads drawn (an edge counted as often as it is used)
    std::size_t cap_triangles = 0;              // near and far caps
    std::vector<std::uint32_t> skipped_meshes;  // open meshes left out (OpenMeshRule::skip), indices into meshes
};

// The light's position relative to the frame (`light_rel`, spot and point lights), or its
// direction (directional). `positions` are the scene's vertices as drawn (camera-relative).
// Each caster triangle contributes a prism oriented towards the light (near cap, far cap at
// infinity, three sides); sides shared by two prisms with opposite orientation cancel, so a
// closed mesh draws its silhouette alone. A closed mesh casts from its triangles facing away
// from the light (the near caps then lie on unlit faces, never on a lit one); an included open
// mesh from every triangle.
//
// `finite_reach_m` > 0 extrudes to finite points instead, that far from the light (spot, point)
// or from the vertex (directional, whose far cap is then drawn too): an orthographic camera
// projects a point at infinity to clip w = 0, which no rasteriser can draw, so its volumes end
// beyond the scene (volume_reach says how far).
ShadowVolumeGeometry build_shadow_volume(std::span<const glm::vec3> positions, const Scene& scene,
                                         const SceneTopology& topology, const Light& light, const glm::dvec3& light_rel,
                                         OpenMeshRule rule, double finite_reach_m = 0);

// How far an orthographic camera's volumes reach (build_shadow_volume's `finite_reach_m`), the
// scene's bounds relative to the frame as `center_rel` and `radius`: a directional prism spans
// the scene's diameter twice, so its far cap lies beyond every receiver; a spot or point light's
// far vertices lie 10^4 times beyond the scene's farthest point from the light, so the far cap
// of any triangle whose plane passes farther than 10^-4 of its vertices' distance from the light
// lies beyond every receiver (nearer to edge-on, a sliver of its shadow may be cut off).
double volume_reach(const Light& light, const glm::dvec3& light_rel, const glm::dvec3& center_rel, double radius);

}  // namespace penumbra::raster
