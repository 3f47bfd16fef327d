// Simple receivers a scenario adds to its glTF scene (docs/scenario.md, "Receivers"): a ground
// plane or a box to catch the model's shadows, without editing the model. They become triangles
// of the one Scene the oracle and the raster path both draw.
#pragma once

#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "common/scene.h"

namespace penumbra {

enum class ReceiverType { plane, box };

struct Receiver {
    ReceiverType type = ReceiverType::plane;
    glm::dvec3 center{0.0};
    glm::dvec3 normal{0, 1, 0};  // plane: unit normal of its front face
    glm::dvec3 size{1.0};        // plane: extents along plane_axes() (z unused); box: x, y, z extents
};

// triangle_node of a receiver's triangles: they come from no glTF node.
inline constexpr std::uint32_t kReceiverNode = UINT32_MAX;

// A plane's in-plane axes (u, v), unit, with u x v = normal: u is the world axis least aligned
// with the normal, made perpendicular to it (X for a horizontal plane, so that v is -Z).
void plane_axes(const glm::dvec3& normal, glm::dvec3& u, glm::dvec3& v);

// Appends the receiver's triangles: a plane as two double-sided triangles (seen from either
// side), a box as twelve single-sided triangles facing outward (a closed solid).
void add_receiver(Scene& scene, const Receiver& receiver);

}  // namespace penumbra
