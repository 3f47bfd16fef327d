// Where each light's shadow map looks: the fits of docs/raster.md ("fit") for directional lights,
// the cone for spot lights, six 90-degree faces for point lights. Pure double-precision math
// (no Vulkan), in the camera-centred frame the raster path renders in.
#pragma once

#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/scene.h"
#include "raster/cascades.h"
#include "raster/technique.h"

namespace penumbra::raster {

struct LightProjection {
    bool perspective = false;
    // Per layer (1, or 6 cube faces +X -X +Y -Y +Z -Z): Vulkan clip space (depth 0..1, no y
    // flip) from positions relative to the frame origin.
    std::vector<glm::dmat4> view_proj;
    std::vector<glm::dvec3> axis;  // per layer: unit forward axis of the light's view
    double metres_per_texel = 0;   // orthographic: texel size (larger of the two axes)
    // perspective: texel size per metre of depth along the axis, 2 tan(fov/2) / resolution
    double metres_per_texel_per_metre = 0;
    double near = 0, far = 0;     // metres along the axis (orthographic: from the box's front face)
    glm::dvec2 half_extent{0.0};  // orthographic: half width and height of the box, metres
    std::vector<std::string> warnings;
    // A cascaded directional light (fit_cascades): per layer, its texel size, the slice of view
    // depth it serves (metres from the camera), and its box's light-space corner (x, y, world
    // frame: what `stabilize` snaps to whole texels). Empty for any other projection.
    std::vector<double> cascade_texel, cascade_near, cascade_far;
    std::vector<glm::dvec2> cascade_origin;
    std::vector<glm::dvec2> cascade_half_extent;
    std::vector<double> cascade_depth_range;  // metres of light depth its map's [0, 1] spans
    double cascade_overlap = 0;               // fraction of a cascade blended with the next
    // SDSM (cascades.sdsm): the view depths, metres, the splits were placed between (the visible
    // samples' range, padded and clamped to the camera's); unset without SDSM.
    std::optional<glm::dvec2> sdsm_range;
};

// Cascades with texel_scaled_bias (raster/cascades.h): the factors cascade k's world bias (x) and
// hardware constant bias (y) are multiplied by; (1, 1) for the first cascade and without it.
glm::dvec2 cascade_bias_scale(const LightProjection& lp, std::size_t k, bool texel_scaled);

// How a shadow view projects (docs/raster.md, "Adding a technique family").
enum class ViewKind { ortho, perspective, cube_face, cascade };
const char* to_string(ViewKind k);

// One view a light's shadow is drawn from: a layer of its map. A family gives each light a list
// of them (the depth map: one ortho or perspective view, or six cube faces); lookups name the
// view each pixel used by its index (DepthMapLookups::layer).
struct ShadowView {
    ViewKind kind = ViewKind::ortho;
    std::string name;  // "+x" … "-z" for cube faces, else empty
    // Vulkan clip space (depth 0..1) from positions relative to the frame origin.
    glm::dmat4 view_proj{1.0};
    glm::dvec3 axis{0.0};  // unit forward axis
    // Texel size: ortho and cascade in metres; perspective and cube face per metre of depth
    // along the axis (2 tan(fov/2) / resolution).
    double metres_per_texel = 0, metres_per_texel_per_metre = 0;
    double near = 0, far = 0;              // metres along the axis
    glm::dvec2 half_extent{0.0};           // ortho, cascade: half width and height of the box, metres
    double split_near = 0, split_far = 0;  // cascade: the slice of camera view depth it serves, metres
};

// The views of a depth map's projection, one per layer: a perspective one of six layers is a cube.
std::vector<ShadowView> shadow_views(const LightProjection& lp);

// Largest distance along the unit `axis` from `eye` to a corner of `box`.
double farthest_along(const Bounds& box, const glm::dvec3& eye, const glm::dvec3& axis);

// `origin` is the world position of the frame the vertices are expressed in (the camera eye).
// `shadow_distance` > 0 ends the camera_frustum fit at that view depth (engines' "shadow
// distance"): receivers beyond it fall outside the map.
LightProjection fit_light(const Light& light, const Scene& scene, const Camera& camera, int image_width,
                          int image_height, Fit fit, int resolution, const glm::dvec3& origin,
                          double shadow_distance = 0);

// A directional light's cascades (raster/cascades.h): one orthographic layer per slice of the
// camera's view depth, fitted by `cascades.fit`, the near plane pulled back to the scene so that
// casters between a slice and the light stay in its map. Throws InputError (exit 2) for a range
// the camera cannot give: an infinite zfar without max_distance, a first_far beyond the range.
// With `samples` (SDSM: the least and greatest view depth of the visible samples, from the GPU
// reduction), the splits lie between them (sdsm_far_bounds), padded by a hundredth of the range
// so that a receiver bias does not push the farthest samples past the last cascade.
LightProjection fit_cascades(const Light& light, const Scene& scene, const Camera& camera, int image_width,
                             int image_height, const Cascades& cascades, int resolution, const glm::dvec3& origin,
                             const std::optional<glm::dvec2>& samples = std::nullopt);

// The fit technique `t` draws `light` with, and every command that reasons about its map uses
// (the depth-map core, engines/engine_units.cpp): the cascades of a cascaded technique's sun
// (fit_cascades, with SDSM's `samples` when given), else fit_light with the technique's fit,
// resolution and shadow distance.
LightProjection fit_for_technique(const Light& light, const Scene& scene, const Camera& camera, int image_width,
                                  int image_height, const Technique& t, const glm::dvec3& origin,
                                  const std::optional<glm::dvec2>& samples = std::nullopt);

// Technique precision world_float32 (docs/raster.md, "precision"): `lp` was fitted with origin 0,
// so its matrices map world positions; each is rounded to float32, as an engine keeps it, and
// then re-expressed in double for positions relative to `origin` (the camera eye). The rounding
// of the light's world-space translation, megametres from the origin, is kept.
void round_to_world_float32(LightProjection& lp, const glm::dvec3& origin);

}  // namespace penumbra::raster
