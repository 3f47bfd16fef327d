#include "common/camera.h"

#include <cmath>

#include <glm/geometric.hpp>

namespace penumbra {

bool look_at_basis(const glm::dvec3& eye, const glm::dvec3& target, const glm::dvec3& up,
                   Camera& camera) {
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

PrimaryRay primary_ray(const Camera& camera, int width, int height, double px, double py) {
    // NDC of the sample point; pixel centres are at (x + 0.5, y + 0.5), row 0 at the top.
    double nx = 2.0 * px / width - 1.0;
    double ny = 1.0 - 2.0 * py / height;
    PrimaryRay ray;
    if (camera.type == ProjectionType::perspective) {
        double tan_half = std::tan(0.5 * camera.yfov_rad);
        double aspect = static_cast<double>(width) / height;
        ray.origin = glm::dvec3(0.0);
        ray.direction = camera.forward + (nx * tan_half * aspect) * camera.right +
                        (ny * tan_half) * camera.up;
    } else {
        ray.origin = (nx * camera.xmag) * camera.right + (ny * camera.ymag) * camera.up;
        ray.direction = camera.forward;
    }
    return ray;
}

}  // namespace penumbra
