// What `penumbra init` decides about a model: the framing (the bounding sphere projects inside
// the image), the sun's angles, the ground plane and the unit warning's thresholds.
#include "common/framing.h"

#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>

#include "common/camera.h"

namespace penumbra {
namespace {

Bounds box(glm::dvec3 lo, glm::dvec3 hi) {
    Bounds b;
    b.grow(lo);
    b.grow(hi);
    return b;
}

// How far the bounding sphere stays inside the four side planes of the view frustum, in radii:
// >= 0 when the whole sphere projects inside the image.
double sphere_clearance(const Camera& cam, int w, int h, const Bounds& b) {
    const glm::dvec2 s = ndc_to_image_plane(cam, w, h);
    const glm::dvec3 c = b.center() - cam.eye;
    const double x = glm::dot(c, cam.right), y = glm::dot(c, cam.up), z = glm::dot(c, cam.forward);
    // Inside the frustum: |x| <= s.x z and |y| <= s.y z; a plane's distance is (s z - |x|) / sqrt(1 + s^2).
    const double dx = (s.x * z - std::abs(x)) / std::sqrt(1 + s.x * s.x);
    const double dy = (s.y * z - std::abs(y)) / std::sqrt(1 + s.y * s.y);
    return std::min(dx, dy) / b.radius() - 1.0;
}

TEST(Framing, TheBoundingSphereProjectsInsideTheFrame) {
    const Bounds models[] = {box({-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5}), box({995, -5, 6}, {1005, -4.9, 7}),
                             box({0, 0, 0}, {0.2, 30, 0.2}), box({-372, -181, -140}, {372, 92, 128}),
                             box({1e7, 0, 1e7}, {1e7 + 1e-3, 2e-3, 1e7 + 1e-3})};
    const int sizes[][2] = {{1280, 720}, {720, 1280}, {64, 64}, {4000, 100}, {100, 4000}};
    for (const Bounds& b : models) {
        for (const auto& wh : sizes) {
            const ModelView v = frame_bounds(b, wh[0], wh[1]);
            Camera cam;
            ASSERT_TRUE(look_at_basis(v.eye, v.target, {0, 1, 0}, cam));
            cam.yfov_rad = v.yfov_deg * M_PI / 180;
            cam.znear = v.znear;
            const double clearance = sphere_clearance(cam, wh[0], wh[1], b);
            SCOPED_TRACE(testing::Message() << "bounds " << b.lo.x << ".." << b.hi.x << ", " << wh[0] << "x" << wh[1]);
            EXPECT_GE(clearance, 0.0);  // inside the frame (0 = tangent to its nearer edge)
            // ... and framed, not lost in it: with the default 2% margin it nearly touches an edge.
            EXPECT_LE(clearance, 0.03);
            // In front of the near plane, all of it.
            EXPECT_GT(glm::dot(b.center() - cam.eye, cam.forward) - b.radius(), cam.znear);
            EXPECT_NEAR(glm::length(v.target - b.center()), 0.0, 1e-9 * glm::length(b.center()) + 1e-12);
            EXPECT_GT(v.eye.y, v.target.y);  // from above
        }
    }
}

TEST(Framing, TheSunsAnglesAreMeasuredFromPlusZTowardsPlusX) {
    const glm::dvec3 front = direction_from_angles(0, 0), right = direction_from_angles(0, 90);
    EXPECT_NEAR(front.z, 1, 1e-15);
    EXPECT_NEAR(right.x, 1, 1e-15);
    EXPECT_NEAR(direction_from_angles(90, 17).y, 1, 1e-15);
    const glm::dvec3 d = direction_from_angles(30, 45);
    EXPECT_NEAR(glm::length(d), 1, 1e-15);
    EXPECT_NEAR(std::asin(d.y) * 180 / M_PI, 30, 1e-12);
}

TEST(Framing, TheGroundLiesUnderTheModel) {
    const Bounds b = box({1, 2, 3}, {3, 4, 7});
    const Receiver g = ground_plane(b);
    EXPECT_EQ(g.type, ReceiverType::plane);
    EXPECT_EQ(g.center, glm::dvec3(2, 2, 5));
    EXPECT_EQ(g.normal, glm::dvec3(0, 1, 0));
    EXPECT_DOUBLE_EQ(g.size.x, 6 * b.radius());
    EXPECT_DOUBLE_EQ(g.size.y, 6 * b.radius());
}

TEST(Framing, PlaneAxesAreOrthonormalAndRightHanded) {
    for (glm::dvec3 n : {glm::dvec3(0, 1, 0), glm::dvec3(0, -1, 0), glm::dvec3(1, 0, 0), glm::dvec3(0, 0, 1),
                         glm::dvec3(1, 1, 1), glm::dvec3(-0.2, 0.1, -3)}) {
        glm::dvec3 u, v;
        plane_axes(n, u, v);
        n = glm::normalize(n);
        EXPECT_NEAR(glm::length(u), 1, 1e-12);
        EXPECT_NEAR(glm::length(v), 1, 1e-12);
        EXPECT_NEAR(glm::dot(u, n), 0, 1e-12);
        EXPECT_NEAR(glm::length(glm::cross(u, v) - n), 0, 1e-12);
    }
    glm::dvec3 u, v;
    plane_axes({0, 1, 0}, u, v);  // documented: a horizontal plane's size is [x, z]
    EXPECT_EQ(u, glm::dvec3(1, 0, 0));
    EXPECT_NEAR(v.z, -1, 1e-15);
}

TEST(Framing, UnitHintsBeyondTheThresholds) {
    const auto cube = [](double side) { return glm::dvec3(side, side, side); };
    // Within [1 cm, 100 m], nothing to say.
    for (double size : {0.01, 0.5, 1.0, 30.0, 100.0}) EXPECT_FALSE(unit_hint(cube(size))) << size;
    // A 745 m engine block: millimetres; a 150 m car: centimetres (1.5 m beats 0.15 m).
    auto mm = unit_hint({745, 273, 268});
    ASSERT_TRUE(mm);
    EXPECT_DOUBLE_EQ(mm->scale, 0.001);
    EXPECT_EQ(mm->unit, "millimetres");
    auto cm = unit_hint(cube(150));
    ASSERT_TRUE(cm);
    EXPECT_DOUBLE_EQ(cm->scale, 0.01);
    EXPECT_EQ(cm->unit, "centimetres");
    EXPECT_TRUE(unit_hint(cube(100.5)));
    // A flat model or a site (a terrain) is large in metres: a 160 m terrain and a 10 km
    // heightfield say nothing; a 2,000 km one is a terrain in millimetres (2 km).
    EXPECT_FALSE(unit_hint({160, 40, 160}, true));
    EXPECT_FALSE(unit_hint({10e3, 300, 10e3}));  // flat by its extents alone
    auto far = unit_hint({2e6, 1e4, 2e6});
    ASSERT_TRUE(far);
    EXPECT_DOUBLE_EQ(far->scale, 0.001);
    // A 0.002 m house: kilometres (2 m); a 0.009 m chair: shrunk 100 times (0.9 m).
    auto km = unit_hint(cube(0.002));
    ASSERT_TRUE(km);
    EXPECT_DOUBLE_EQ(km->scale, 1000);
    EXPECT_EQ(km->unit, "kilometres");
    auto hundred = unit_hint(cube(0.009));
    ASSERT_TRUE(hundred);
    EXPECT_DOUBLE_EQ(hundred->scale, 100);
    EXPECT_FALSE(unit_hint(cube(0)));  // no size, no hint (init refuses an empty model before)
}

// A sheet of two triangles facing `normal`, from lo to hi (an axis-aligned square).
Scene sheet(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d) {
    Scene s;
    s.add_triangle(a, b, c, false);
    s.add_triangle(a, c, d, false);
    return s;
}

TEST(Framing, GuessesZUpFromOpenSurfacesAndFromWhereAModelStands) {
    // A ground facing +Y: glTF's up. The same ground facing +Z (a Z-up export): said, with the lean.
    EXPECT_FALSE(z_up_evidence(sheet({0, 0, 0}, {0, 0, -1}, {1, 0, -1}, {1, 0, 0})));
    const auto z_sheet = sheet({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0});
    auto z = z_up_evidence(z_sheet);
    ASSERT_TRUE(z);
    EXPECT_NE(z->find("100% of its area faces +Z"), std::string::npos) << *z;
    EXPECT_TRUE(looks_like_site(z_sheet));
    EXPECT_NEAR(facing_lean(z_sheet).z, 1, 1e-12);
    // A closed box standing on z = 0 and centred on y: Z-up; the same box standing on y = 0: Y-up.
    const auto box = [](glm::dvec3 lo, glm::dvec3 hi) {
        Scene s;
        Receiver r;
        r.type = ReceiverType::box;
        r.center = 0.5 * (lo + hi);
        r.size = hi - lo;
        add_receiver(s, r);
        return s;
    };
    auto standing = z_up_evidence(box({-0.3, -0.2, 0}, {0.3, 0.2, 1.8}));
    ASSERT_TRUE(standing);
    EXPECT_NE(standing->find("stands on z = 0"), std::string::npos) << *standing;
    EXPECT_FALSE(z_up_evidence(box({-0.3, 0, -0.2}, {0.3, 1.8, 0.2})));
    EXPECT_FALSE(z_up_evidence(box({-1, -1, -1}, {1, 1, 1})));  // centred everywhere: no sign
    EXPECT_FALSE(looks_like_site(box({-1, -1, -1}, {1, 1, 1})));
}

}  // namespace
}  // namespace penumbra
