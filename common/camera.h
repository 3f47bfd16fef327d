// Primary-ray generation shared by the oracle and the raster path (docs/design.md, "Conventions").
#pragma once

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "common/scene.h"

namespace penumbra {

// Builds an orthonormal look-at basis: forward = normalize(target - eye),
// right = normalize(forward x up), up' = right x forward. Returns false when degenerate.
bool look_at_basis(const glm::dvec3& eye, const glm::dvec3& target, const glm::dvec3& up, Camera& camera);

// NDC to the camera's image plane: (tan(yfov/2) * W/H, tan(yfov/2)) at unit depth for a
// perspective camera, (xmag, ymag) for an orthographic one. Every path that projects with the
// camera (oracle rays, the raster camera pass, frustum fits) uses this one definition.
glm::dvec2 ndc_to_image_plane(const Camera& camera, int width, int height);

// A primary ray through the centre of pixel (x, y), relative to the camera eye. The direction
// is not normalised: its component along `forward` is 1, so the hit parameter t is the view
// depth and clipping to [znear, zfar] is clipping in t, exactly as a rasteriser clips.
struct PrimaryRay {
    glm::dvec3 origin;     // relative to camera.eye
    glm::dvec3 direction;  // forward + ...
};
PrimaryRay primary_ray(const Camera& camera, int width, int height, double px, double py);

// The same rays with the per-camera constants computed once (hot loops).
class PrimaryRays {
  public:
    PrimaryRays(const Camera& camera, int width, int height);
    // Inline: the oracle calls it once per pixel in its hot loop.
    PrimaryRay at(double px, double py) const {
        // NDC of the sample point; pixel centres are at (x + 0.5, y + 0.5), row 0 at the top.
        const double nx = px * inv_w2_ - 1.0, ny = 1.0 - py * inv_h2_;
        PrimaryRay ray;
        if (camera_.type == ProjectionType::perspective) {
            ray.origin = glm::dvec3(0.0);
            ray.direction = camera_.forward + (nx * sx_) * camera_.right + (ny * sy_) * camera_.up;
        } else {
            ray.origin = (nx * sx_) * camera_.right + (ny * sy_) * camera_.up;
            ray.direction = camera_.forward;
        }
        return ray;
    }

  private:
    const Camera& camera_;
    double inv_w2_, inv_h2_;  // 2 / width, 2 / height
    double sx_, sy_;          // NDC to camera plane: tan(yfov/2) * aspect, tan(yfov/2) (or xmag, ymag)
};

}  // namespace penumbra
