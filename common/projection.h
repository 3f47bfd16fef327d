// The camera's view and projection in the graphics APIs' conventions, and the depth-buffer value
// they give a view depth and back: one definition for `penumbra camera`, which prints the matrices
// an engine renders with, and `compare`, which reads that engine's depth buffer (docs/compare.md).
// A perspective camera may have an infinite far plane (glTF: no zfar); its matrices are then the
// infinite-far limit. (The raster path's camera matrix is its own: reversed depth, its far plane
// pulled in to the scene, never seen outside penumbra; raster/raster.cpp.)
#pragma once

#include <array>

#include "common/scene.h"

namespace penumbra {

enum class ClipConvention {
    gl,      // NDC z in [-1, 1], NDC y up
    vulkan,  // NDC z in [0, 1], NDC y down (row 0 at the top without a viewport flip)
    d3d,     // NDC z in [0, 1], NDC y up (the viewport maps +y to row 0)
};

using Mat4 = std::array<std::array<double, 4>, 4>;  // [row][column], column vectors: clip = P * V * x

class CameraProjection {
  public:
    // `scene`: where an orthographic camera without zfar puts its far plane (it has no
    // infinite-far limit): 1% beyond the scene's box along the view axis.
    CameraProjection(const Camera& camera, int width, int height, const Bounds& scene);

    double znear() const { return near_; }
    // The far plane the matrices use: the camera's zfar, +inf for a perspective camera without
    // one, the scene's far side for an orthographic one without one.
    double zfar() const { return far_; }
    bool zfar_from_scene() const { return far_from_scene_; }

    // World to view: right-handed, the camera looking down -Z (glTF), +Y up.
    Mat4 view() const;
    // View to clip in the convention's NDC ranges.
    Mat4 matrix(ClipConvention convention) const;

    // The depth-buffer value (window depth in [0, 1]: GL's with glDepthRange(0, 1), which is
    // Vulkan's and D3D's NDC z) of a point at view depth z along the forward axis.
    double window_depth(double view_depth) const;
    // Its inverse; NaN for a value outside [0, 1) (1 is the far plane: no surface).
    double view_depth(double window_depth) const;

  private:
    const Camera& camera_;
    double sx_, sy_;  // ndc_to_image_plane
    double near_, far_;
    bool far_from_scene_ = false;
};

}  // namespace penumbra
