// What the families judge per pixel on the CPU, in one place: the positions as the session drew
// them (Technique::precision), and the surface point the oracle scores for a pixel with the rule
// that says whether the light reaches it at all (docs/oracle.md, sections 1 and 2). The lookup
// shaders keep the GPU side of the same rules in shaders/lookup_main.glsl.
#pragma once

#include <glm/glm.hpp>
#include <vector>

#include "common/camera.h"
#include "common/scene.h"
#include "raster/technique.h"

namespace penumbra::raster {

// A world position as the session draws it: world_float32 rounds it to float first, as an
// engine's vertex buffer (or light uniform) holds it; camera_relative keeps the double.
glm::dvec3 drawn_world_position(const glm::dvec3& p, Precision precision);
// The scene's positions as the session uploads them (SceneOnGpu::drawn_positions): relative to
// `origin` in double, then float (precision near the camera).
std::vector<glm::vec3> drawn_positions(const Scene& scene, const glm::dvec3& origin, Precision precision);
// A light's position in the same frame, in double.
glm::dvec3 drawn_light_position(const Light& l, const glm::dvec3& origin, Precision precision);

// The receiver point of a pixel: its centre's ray on the plane of the triangle (a, b, c) seen
// there, with the normal (not normalised) of the side the camera sees. Ray, triangle and result
// share one frame.
struct SurfaceSeen {
    glm::dvec3 point, normal;
};
SurfaceSeen surface_seen(const PrimaryRay& ray, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c);
// The oracle's `lightable`: the seen side faces the light (a point or spot at `position`, in the
// surfaces' frame), and a spot's cone holds the point. Elsewhere V is 0 and not scored.
class LightReach {
  public:
    LightReach(const Light& light, const glm::dvec3& position);
    bool lightable(const SurfaceSeen& s) const;

  private:
    const Light& light_;
    glm::dvec3 position_;
    double cos_outer_;
};

}  // namespace penumbra::raster
