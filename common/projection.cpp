#include "common/projection.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <limits>

#include "common/camera.h"

namespace penumbra {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The far side of the box along the view axis, in view depth.
double farthest_along(const Bounds& box, const Camera& cam) {
    double far = -std::numeric_limits<double>::infinity();
    for (int k = 0; k < 8; ++k) {
        const glm::dvec3 c(k & 1 ? box.hi.x : box.lo.x, k & 2 ? box.hi.y : box.lo.y, k & 4 ? box.hi.z : box.lo.z);
        far = std::max(far, glm::dot(c - cam.eye, cam.forward));
    }
    return far;
}

}  // namespace

CameraProjection::CameraProjection(const Camera& camera, int width, int height, const Bounds& scene)
    : camera_(camera), near_(camera.znear), far_(camera.zfar) {
    const glm::dvec2 s = ndc_to_image_plane(camera, width, height);
    sx_ = s.x;
    sy_ = s.y;
    if (std::isinf(far_) && camera.type == ProjectionType::orthographic) {
        const double extent = scene.empty() ? near_ : farthest_along(scene, camera);
        // Beyond the scene by 1% of its depth (and never at znear): its far side is not clipped.
        far_ = std::max(extent + 0.01 * std::abs(extent - near_), near_) + 1e-6 * std::max(1.0, std::abs(near_));
        far_from_scene_ = true;
    }
}

Mat4 CameraProjection::view() const {
    const Camera& cam = camera_;
    const glm::dvec3 r = cam.right, u = cam.up, b = -cam.forward;
    return {{{r.x, r.y, r.z, -glm::dot(r, cam.eye)},
             {u.x, u.y, u.z, -glm::dot(u, cam.eye)},
             {b.x, b.y, b.z, -glm::dot(b, cam.eye)},
             {0, 0, 0, 1}}};
}

Mat4 CameraProjection::matrix(ClipConvention conv) const {
    const double n = near_, f = far_;
    const bool gl = conv == ClipConvention::gl;
    Mat4 m{};
    m[0][0] = 1.0 / sx_;
    m[1][1] = (conv == ClipConvention::vulkan ? -1.0 : 1.0) / sy_;
    if (camera_.type == ProjectionType::perspective) {
        if (std::isinf(f)) {  // the limit f -> inf of the rows below
            m[2][2] = -1.0;
            m[2][3] = gl ? -2.0 * n : -n;
        } else if (gl) {
            m[2][2] = (f + n) / (n - f);
            m[2][3] = 2.0 * f * n / (n - f);
        } else {
            m[2][2] = f / (n - f);
            m[2][3] = f * n / (n - f);
        }
        m[3][2] = -1.0;
    } else {
        if (gl) {
            m[2][2] = 2.0 / (n - f);
            m[2][3] = (f + n) / (n - f);
        } else {
            m[2][2] = 1.0 / (n - f);
            m[2][3] = n / (n - f);
        }
        m[3][3] = 1.0;
    }
    return m;
}

// Perspective: w = f (z - n) / (z (f - n)), which is 1 - n / z for an infinite f; orthographic:
// w = (z - n) / (f - n).
double CameraProjection::window_depth(double z) const {
    const double n = near_, f = far_;
    if (camera_.type == ProjectionType::orthographic) return (z - n) / (f - n);
    if (std::isinf(f)) return (z - n) / z;
    return f * (z - n) / (z * (f - n));
}

double CameraProjection::view_depth(double w) const {
    if (!(w >= 0.0 && w < 1.0)) return kNaN;
    const double n = near_, f = far_;
    if (camera_.type == ProjectionType::orthographic) return n + w * (f - n);
    if (std::isinf(f)) return n / (1.0 - w);
    return n * f / (f - w * (f - n));
}

}  // namespace penumbra
