#include "common/camera.h"

#include <cmath>
#include <glm/geometric.hpp>

namespace penumbra {

bool look_at_basis(const glm::dvec3& eye, const glm::dvec3& target, const glm::dvec3& up, Camera& camera) {
    glm::dvec3 f = target - eye;
    double lf = glm::length(f);
    if (!(lf > 0) || !std::isfinite(lf)) return false;
    f /= lf;
    glm::dvec3 r = glm::cross(f, up);
    double lr = glm::length(r);
    double lu = glm::length(up);
    // Reject an up vector (nearly) parallel to the view direction: the roll is undefined.
    if (!(lu > 0) || !(lr > 1e-9 * lu)) return false;
    r /= lr;
    camera.eye = eye;
    camera.forward = f;
    camera.right = r;
    camera.up = glm::cross(r, f);
    return true;
}

glm::dvec2 ndc_to_image_plane(const Camera& camera, int width, int height) {
    if (camera.type == ProjectionType::orthographic) return {camera.xmag, camera.ymag};
    double tan_half = std::tan(0.5 * camera.yfov_rad);
    return {tan_half * static_cast<double>(width) / height, tan_half};
}

PrimaryRays::PrimaryRays(const Camera& camera, int width, int height)
    : camera_(camera), inv_w2_(2.0 / width), inv_h2_(2.0 / height) {
    glm::dvec2 s = ndc_to_image_plane(camera, width, height);
    sx_ = s.x;
    sy_ = s.y;
}

PrimaryRay primary_ray(const Camera& camera, int width, int height, double px, double py) {
    return PrimaryRays(camera, width, height).at(px, py);
}

}  // namespace penumbra
