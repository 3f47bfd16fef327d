// The scales the fits report, against their geometric meaning (issue 40): a texel's footprint is
// the map's larger side over the resolution (orthographic) or 2 tan(half angle) / resolution per
// metre of depth (perspective), and a perspective layer maps its near plane to depth 0 and its
// far plane to depth 1. The bias reach, the normal offset and the aliasing band all scale with
// these numbers, so a factor 2 here moves every verdict that depends on them.
#include <gtest/gtest.h>

#include <cmath>

#include "raster/light_projection.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

glm::dvec3 clip_of(const glm::dmat4& m, const glm::dvec3& p) {
    const glm::dvec4 c = m * glm::dvec4(p, 1.0);
    return glm::dvec3(c) / c.w;
}

constexpr int kRes = 512;

TEST(FitScale, AnOrthographicTexelIsTheMapsLargerSideOverTheResolution) {
    // A 20 m x 4 m plane under a sun straight down: the map spans 20 m one way, 4 m the other.
    test::SceneBuilder b;
    b.quad({-10, 0, -2}, {-10, 0, 2}, {10, 0, 2}, {10, 0, -2});
    const Scenario sc = test::make_scenario(b.build(), test::look_at({0, 10, 10}, {0, 0, 0}, 40),
                                            {test::directional({0, -1, 0})}, 16, 16);
    const raster::LightProjection lp =
        raster::fit_light(sc.lights[0], sc.scene, sc.camera, 16, 16, raster::Fit::scene_bounds, kRes, sc.camera.eye);
    EXPECT_NEAR(std::max(lp.half_extent.x, lp.half_extent.y), 10.0, 1e-9);
    EXPECT_NEAR(std::min(lp.half_extent.x, lp.half_extent.y), 2.0, 1e-9);
    EXPECT_NEAR(lp.metres_per_texel, 20.0 / kRes, 1e-12);
}

TEST(FitScale, APerspectiveTexelIsTwiceTheTangentOfTheHalfAngleOverTheResolution) {
    test::SceneBuilder b;
    b.quad({-10, 0, -10}, {-10, 0, 10}, {10, 0, 10}, {10, 0, -10});
    const Scene scene = b.build();
    const Camera cam = test::look_at({0, 10, 10}, {0, 0, 0}, 40);
    const glm::dvec3 light_at(0, 6, 0), down(0, -1, 0);
    for (const double half_deg : {20.0, 35.0, 60.0}) {
        const Light spot = test::spot(light_at, down, half_deg);
        const raster::LightProjection lp =
            raster::fit_light(spot, scene, cam, 16, 16, raster::Fit::scene_bounds, kRes, cam.eye);
        const double t = std::tan(half_deg * M_PI / 180.0);
        EXPECT_NEAR(lp.metres_per_texel_per_metre, 2.0 * t / kRes, 1e-12) << half_deg;
        // What that means: at depth d, the cone's edge (d tan(half) off the axis) is the map's edge.
        const double d = 4.0;
        const glm::dvec3 edge = light_at + d * down + glm::dvec3(d * t, 0, 0);
        const glm::dvec3 at_edge = clip_of(lp.view_proj[0], edge - cam.eye);
        EXPECT_NEAR(std::max(std::abs(at_edge.x), std::abs(at_edge.y)), 1.0, 1e-9) << half_deg;
        // The near plane at depth 0, the far plane at depth 1.
        EXPECT_NEAR(clip_of(lp.view_proj[0], light_at + lp.near * down - cam.eye).z, 0.0, 1e-9) << half_deg;
        EXPECT_NEAR(clip_of(lp.view_proj[0], light_at + lp.far * down - cam.eye).z, 1.0, 1e-9) << half_deg;
    }
    // A point light's faces are 90-degree frusta: tan(45 degrees) = 1.
    const raster::LightProjection cube =
        raster::fit_light(test::point(light_at), scene, cam, 16, 16, raster::Fit::scene_bounds, kRes, cam.eye);
    EXPECT_NEAR(cube.metres_per_texel_per_metre, 2.0 / kRes, 1e-12);
    EXPECT_NEAR(clip_of(cube.view_proj[3], light_at + cube.near * down - cam.eye).z, 0.0, 1e-9);  // -Y face
    EXPECT_NEAR(clip_of(cube.view_proj[3], light_at + cube.far * down - cam.eye).z, 1.0, 1e-9);
}

}  // namespace
}  // namespace penumbra
