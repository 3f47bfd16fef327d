// Scenes of several models (docs/scenario.md, "Scenes of several models"): each glTF file of a
// scenario's "scene" is stood upright, scaled, rotated and moved into the scenario's world, then
// appended to the one triangle soup the oracle and the raster path share.
#pragma once

#include <filesystem>
#include <glm/gtc/quaternion.hpp>
#include <glm/vec3.hpp>

#include "common/scene.h"

namespace penumbra {

// Where one model goes. world = translation + rotation · (scale · U · p), U the turn that makes a
// Z-up model's +Z glTF's +Y (a −90° rotation about +X: (x, y, z) → (x, z, −y)), identity for +Y.
struct ModelPlacement {
    std::filesystem::path file;  // resolved
    std::string label;           // what messages call it ("scene[1]: crate.glb")
    glm::dvec3 translation{0.0};
    glm::dquat rotation{1, 0, 0, 0};  // w, x, y, z
    double scale = 1.0;               // the model's units to metres (the scenario's "scale" included)
    bool z_up = false;
    bool moves() const { return z_up || translation != glm::dvec3(0.0) || rotation != glm::dquat(1, 0, 0, 0); }
};

// Multiplies the glTF scene (positions, bounds, the cameras and lights its nodes place) by
// `scale` about the origin: what a scale on the glTF root would do.
void scale_scene(Scene& scene, double scale);

// Applies `placement` to everything the model's nodes place: triangles (bounds made again),
// glTF cameras (eye and basis; znear, zfar, xmag, ymag scaled) and KHR_lights_punctual lights.
// A placement that only scales is scale_scene's multiplication, bit for bit.
void place_model(Scene& scene, const ModelPlacement& placement);

// Appends `part` to `scene`: its vertices, triangles (indices offset), per-triangle materials and
// nodes (node indices offset past `scene`'s, so that meshes of two models stay apart), cameras,
// lights and warnings (prefixed by `label` when it is not empty), and grows the bounds.
void append_model(Scene& scene, Scene&& part, const std::string& label);

// The ±90° turn of a Z-up model: a point of the model in glTF's +Y-up frame.
inline glm::dvec3 z_up_to_y_up(const glm::dvec3& p) { return {p.x, p.z, -p.y}; }

}  // namespace penumbra
