// The oracle against analytic answers: shadows of random triangles projected onto a plane
// (point light: the planar projection matrix of docs/design.md's reference 001; directional light), a box's
// shadow as the convex hull of its projected corners, spot cones, grazing light, invariance
// under translation, scaling and rotation of the whole scenario, and determinism.
#include "oracle/oracle.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <functional>
#include <future>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/mat4x4.hpp>
#include <random>

#include "common/errors.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

using test::SceneBuilder;

glm::dvec3 world_point(const OracleFrame& f, std::size_t i) {
    return f.frame_origin + glm::dvec3(f.P[i]);
}

double cross2(glm::dvec2 a, glm::dvec2 b, glm::dvec2 c) {
    return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

bool inside_triangle(glm::dvec2 p, glm::dvec2 a, glm::dvec2 b, glm::dvec2 c) {
    double d1 = cross2(a, b, p), d2 = cross2(b, c, p), d3 = cross2(c, a, p);
    return (d1 >= 0 && d2 >= 0 && d3 >= 0) || (d1 <= 0 && d2 <= 0 && d3 <= 0);
}

// Planar projection onto y = 0 from a point light l (reference 001 of docs/design.md, "Projection Shadows"):
// M = [[ly, -lx, 0, 0], [0, 0, 0, 0], [0, -lz, ly, 0], [0, -1, 0, ly]], p = M v / w.
glm::dvec2 project_from_point(const glm::dvec3& l, const glm::dvec3& v) {
    glm::dmat4 m(0.0);  // glm is column-major: m[col][row]
    m[0][0] = l.y;
    m[1][0] = -l.x;
    m[1][2] = -l.z;
    m[2][2] = l.y;
    m[1][3] = -1;
    m[3][3] = l.y;
    glm::dvec4 p = m * glm::dvec4(v, 1.0);
    return {p.x / p.w, p.z / p.w};
}

glm::dvec2 project_along(const glm::dvec3& d, const glm::dvec3& v) {
    glm::dvec3 p = v - (v.y / d.y) * d;
    return {p.x, p.z};
}

struct RandomOccluders {
    SceneBuilder builder;
    std::vector<std::array<glm::dvec3, 3>> tris;
    std::uint32_t ground_first = 0;
};

RandomOccluders random_occluders(unsigned seed) {
    RandomOccluders r;
    r.ground_first = r.builder.quad({-20, 0, 20}, {20, 0, 20}, {20, 0, -20}, {-20, 0, -20}, false);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> pos(-3, 3), h(0.4, 3.0), size(0.15, 1.2), unit(-1, 1);
    for (int i = 0; i < 30; ++i) {
        glm::dvec3 c(pos(rng), h(rng), pos(rng));
        double s = size(rng);
        std::array<glm::dvec3, 3> t;
        for (auto& v : t) v = c + s * glm::dvec3(unit(rng), 0.3 * unit(rng), unit(rng));
        r.builder.triangle(t[0], t[1], t[2]);
        r.tris.push_back(t);
    }
    // A sliver: a thin occluder 5 mm wide and 2 m long.
    std::array<glm::dvec3, 3> sliver{glm::dvec3(-1, 1.0, 1.5), glm::dvec3(1, 1.0, 1.5), glm::dvec3(1, 1.0, 1.505)};
    r.builder.triangle(sliver[0], sliver[1], sliver[2]);
    r.tris.push_back(sliver);
    return r;
}

struct ProjectionCase {
    const char* name;
    bool point_light;
    bool orthographic;
};

class AnalyticProjection : public ::testing::TestWithParam<ProjectionCase> {};

// Every ground pixel's verdict equals the analytic one: shadowed exactly where its point lies
// inside the projection of some occluder. No mismatch is allowed outside ambiguous pixels.
TEST_P(AnalyticProjection, MatchesThePlanarProjectionOfEveryOccluder) {
    const ProjectionCase pc = GetParam();
    RandomOccluders occ = random_occluders(1234);
    const glm::dvec3 light_pos(0.7, 7.5, -0.4);
    const glm::dvec3 light_dir = glm::normalize(glm::dvec3(0.3, -1.0, 0.2));
    Light light = pc.point_light ? test::point(light_pos) : test::directional(light_dir);
    Camera cam =
        pc.orthographic ? test::look_at_ortho({0, 12, 6}, {0, 0, 0}, 6, 4.5) : test::look_at({0, 9, 9}, {0, 0, 0}, 50);
    Scenario sc = test::make_scenario(occ.builder.build(), cam, {light}, 320, 240);
    OracleResult res = run_oracle(sc);
    const OracleFrame& f = res.frame;
    const OracleLightImage& img = f.lights[0];

    std::size_t ground = 0, checked = 0, shadowed = 0, ambiguous = 0, wrong = 0, occluder_checked = 0;
    for (std::size_t i = 0; i < f.pixel_count(); ++i) {
        if (f.prim[i] != occ.ground_first && f.prim[i] != occ.ground_first + 1) continue;
        ++ground;
        ASSERT_EQ(img.lightable[i], 1.0f);
        if (img.U[i] != 0) {
            ++ambiguous;
            continue;
        }
        glm::dvec3 p = world_point(f, i);
        bool expect_shadow = false;
        double nearest = std::numeric_limits<double>::infinity();
        for (const auto& t : occ.tris) {
            glm::dvec2 a, b, c;
            if (pc.point_light) {
                a = project_from_point(light_pos, t[0]), b = project_from_point(light_pos, t[1]),
                c = project_from_point(light_pos, t[2]);
            } else {
                a = project_along(light_dir, t[0]), b = project_along(light_dir, t[1]),
                c = project_along(light_dir, t[2]);
            }
            if (!inside_triangle({p.x, p.z}, a, b, c)) continue;
            expect_shadow = true;
            glm::dvec3 dir = pc.point_light ? glm::normalize(light_pos - p) : -light_dir;
            glm::dvec3 n = glm::cross(t[1] - t[0], t[2] - t[0]);
            nearest = std::min(nearest, glm::dot(n, t[0] - p) / glm::dot(n, dir));
        }
        ++checked;
        bool got_shadow = img.V[i] == 0.0f;
        shadowed += got_shadow;
        if (got_shadow != expect_shadow) {
            ++wrong;
            ADD_FAILURE_AT(__FILE__, __LINE__)
                << pc.name << ": pixel " << i % f.width << "," << i / f.width << " oracle V=" << img.V[i]
                << " analytic " << (expect_shadow ? 0 : 1) << " boundary_m=" << img.boundary_m[i];
            if (wrong > 5) return;
        } else if (expect_shadow) {
            // The occluder distance is the nearest occluder along the ray, in metres.
            // The test's point is the float P of the frame; steep occluders amplify its error.
            EXPECT_NEAR(img.occluder_m[i], nearest, 1e-4 * nearest + 1e-6);
            ++occluder_checked;
        }
    }
    EXPECT_EQ(wrong, 0u);
    EXPECT_GT(ground, 20000u);
    EXPECT_GT(shadowed, checked / 100) << "the test must exercise shadows";
    EXPECT_LT(ambiguous, ground / 500) << "the ambiguous band must stay thin";
    EXPECT_GT(occluder_checked, 1000u);
}

INSTANTIATE_TEST_SUITE_P(Oracle, AnalyticProjection,
                         ::testing::Values(ProjectionCase{"point_perspective", true, false},
                                           ProjectionCase{"point_orthographic", true, true},
                                           ProjectionCase{"directional_perspective", false, false},
                                           ProjectionCase{"directional_orthographic", false, true}),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

// 2D convex hull (Andrew's monotone chain), counter-clockwise.
std::vector<glm::dvec2> convex_hull(std::vector<glm::dvec2> p) {
    std::sort(p.begin(), p.end(), [](auto a, auto b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
    std::vector<glm::dvec2> h(2 * p.size());
    std::size_t k = 0;
    for (std::size_t i = 0; i < p.size(); ++i) {
        while (k >= 2 && cross2(h[k - 2], h[k - 1], p[i]) <= 0) --k;
        h[k++] = p[i];
    }
    for (std::size_t i = p.size() - 1, t = k + 1; i > 0; --i) {
        while (k >= t && cross2(h[k - 2], h[k - 1], p[i - 1]) <= 0) --k;
        h[k++] = p[i - 1];
    }
    h.resize(k - 1);
    return h;
}

bool inside_convex(glm::dvec2 q, const std::vector<glm::dvec2>& hull) {
    for (std::size_t i = 0; i < hull.size(); ++i)
        if (cross2(hull[i], hull[(i + 1) % hull.size()], q) < 0) return false;
    return true;
}

// A box resting on the plane under a low sun (10 degrees): its shadow is the hull of its
// projected corners, with no light leaking in at the contact line, and a convex box never
// shadows its own lit faces.
TEST(Oracle, ContactShadowOfABoxRestingOnThePlaneDoesNotLeak) {
    SceneBuilder b;
    std::uint32_t ground = b.quad({-30, 0, 30}, {30, 0, 30}, {30, 0, -30}, {-30, 0, -30}, false);
    std::uint32_t box = b.box({-0.5, 0, -0.5}, {0.5, 1, 0.5});
    double el = 10 * M_PI / 180, az = 30 * M_PI / 180;
    glm::dvec3 d(std::cos(el) * std::cos(az), -std::sin(el), std::cos(el) * std::sin(az));
    // Look at the contact line on the shadow side from close by.
    Camera cam = test::look_at({2.5, 2.5, 2.0}, {0.6, 0.0, 0.4}, 50);
    Scenario sc = test::make_scenario(b.build(), cam, {test::directional(d)}, 400, 300);
    OracleResult res = run_oracle(sc);
    const OracleFrame& f = res.frame;
    const OracleLightImage& img = f.lights[0];
    std::vector<glm::dvec2> corners;
    for (int i = 0; i < 8; ++i)
        corners.push_back(project_along(d, {i & 1 ? 0.5 : -0.5, i & 2 ? 1.0 : 0.0, i & 4 ? 0.5 : -0.5}));
    auto hull = convex_hull(corners);
    std::size_t wrong = 0, near_contact = 0, box_lit_faces = 0;
    for (std::size_t i = 0; i < f.pixel_count(); ++i) {
        if (img.U[i] != 0 || f.A[i] == 0) continue;
        if (f.prim[i] >= box && f.prim[i] < box + 12) {
            if (img.lightable[i] != 0) {
                ++box_lit_faces;
                EXPECT_EQ(img.V[i], 1.0f) << "lit face of a convex box self-shadowed at pixel " << i;
            }
            continue;
        }
        ASSERT_TRUE(f.prim[i] == ground || f.prim[i] == ground + 1);
        glm::dvec3 p = world_point(f, i);
        bool expect = inside_convex({p.x, p.z}, hull);
        wrong += (img.V[i] == 0.0f) != expect;
        // Within 2 cm of the box's base: where leaks would show.
        if (std::max(std::abs(p.x), std::abs(p.z)) < 0.52) ++near_contact;
    }
    EXPECT_EQ(wrong, 0u);
    EXPECT_GT(near_contact, 100u) << "the camera must see the contact line";
    EXPECT_GT(box_lit_faces, 1000u);
}

struct GrazingCase {
    const char* name;
    bool tessellated;
    double offset;  // scenario translated by (offset, 0, offset)
};

class GrazingLight : public ::testing::TestWithParam<GrazingCase> {};

// Light 89.9 degrees from the normal: no self-shadowing, neither on one pair of huge triangles
// nor on a finely tessellated plane, near the origin or a million metres from it.
TEST_P(GrazingLight, DoesNotSelfShadowAPlane) {
    const GrazingCase gc = GetParam();
    const glm::dvec3 o(gc.offset, 0, gc.offset);
    SceneBuilder b;
    if (gc.tessellated)
        b.grid(o + glm::dvec3(-10, 0, 10), {20, 0, 0}, {0, 0, -20}, 200, 200);
    else
        b.quad(o + glm::dvec3(-1000, 0, 1000), o + glm::dvec3(1000, 0, 1000), o + glm::dvec3(1000, 0, -1000),
               o + glm::dvec3(-1000, 0, -1000), false);
    double el = 0.1 * M_PI / 180;
    Light sun = test::directional({std::cos(el) * 0.6, -std::sin(el), std::cos(el) * -0.8});
    Camera cam = test::look_at(o + glm::dvec3(0, 2, 5), o + glm::dvec3(0, 0, -5), 60);
    Scenario sc = test::make_scenario(b.build(), cam, {sun}, 320, 240);
    OracleResult res = run_oracle(sc);
    const OracleLightImage& img = res.frame.lights[0];
    std::size_t surface = 0, shadowed = 0, ambiguous = 0;
    for (std::size_t i = 0; i < res.frame.pixel_count(); ++i) {
        if (res.frame.A[i] == 0) continue;
        ++surface;
        ASSERT_EQ(img.lightable[i], 1.0f);
        ambiguous += img.U[i] != 0;
        shadowed += img.U[i] == 0 && img.V[i] == 0;
    }
    EXPECT_GT(surface, 30000u);
    EXPECT_EQ(shadowed, 0u);
    EXPECT_EQ(ambiguous, 0u);
}

INSTANTIATE_TEST_SUITE_P(Oracle, GrazingLight,
                         ::testing::Values(GrazingCase{"two_huge_triangles", false, 0},
                                           GrazingCase{"tessellated", true, 0},
                                           GrazingCase{"two_huge_triangles_far", false, 1e6},
                                           GrazingCase{"tessellated_far", true, 1e6}),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

TEST(Oracle, SpotLightsLightOnlyInsideTheirCone) {
    SceneBuilder b;
    b.quad({-20, 0, 20}, {20, 0, 20}, {20, 0, -20}, {-20, 0, -20}, false);
    glm::dvec3 pos(0.5, 4, 0.3), axis = glm::normalize(glm::dvec3(0.2, -1, -0.1));
    double outer = 25 * M_PI / 180;
    Scenario sc =
        test::make_scenario(b.build(), test::look_at({0, 10, 8}, {0, 0, 0}, 50), {test::spot(pos, axis, 25)}, 320, 240);
    OracleResult res = run_oracle(sc);
    const OracleLightImage& img = res.frame.lights[0];
    std::size_t inside = 0, outside = 0;
    for (std::size_t i = 0; i < res.frame.pixel_count(); ++i) {
        if (res.frame.A[i] == 0 || img.U[i] != 0) continue;
        bool in = glm::dot(glm::normalize(world_point(res.frame, i) - pos), axis) >= std::cos(outer);
        EXPECT_EQ(img.lightable[i], in ? 1.0f : 0.0f);
        EXPECT_EQ(img.V[i], in ? 1.0f : 0.0f);
        (in ? inside : outside)++;
    }
    EXPECT_GT(inside, 2000u);
    EXPECT_GT(outside, 5000u);
    EXPECT_LE(res.stats.shadow_rays, res.frame.pixel_count() - outside) << "no shadow rays outside the cone";
}

// A single-sided surface seen from behind is invisible to the camera but still casts a shadow.
TEST(Oracle, SingleSidedSurfacesAreCulledForTheCameraOnly) {
    SceneBuilder b;
    std::uint32_t ground = b.quad({-5, 0, 5}, {5, 0, 5}, {5, 0, -5}, {-5, 0, -5}, false);
    b.quad({-1, 1, -1}, {1, 1, -1}, {1, 1, 1}, {-1, 1, 1}, false);  // faces -y: its back faces the camera
    Scenario sc = test::make_scenario(b.build(), test::look_at_ortho({0, 5, 0}, {0, 0, 0}, 3, 3, {0, 0, -1}),
                                      {test::directional({0, -1, 0})}, 64, 64);
    OracleResult res = run_oracle(sc);
    std::size_t centre = 32 * 64 + 32;
    EXPECT_TRUE(res.frame.prim[centre] == ground || res.frame.prim[centre] == ground + 1);
    EXPECT_EQ(res.frame.lights[0].V[centre], 0.0f);
    EXPECT_NEAR(res.frame.lights[0].occluder_m[centre], 1.0, 1e-6);

    // Every pixel whose first hit is the back face is traced again past it, under either
    // projection, and finds the ground; those re-traces are counted apart from the shadow rays
    // re-judged in double, of which there are none here.
    for (bool perspective : {false, true}) {
        if (perspective) sc.camera = test::look_at({0.3, 5, 0.2}, {0, 0, 0}, 70, {0, 0, -1});
        res = run_oracle(sc);
        std::size_t seen_ground = 0;
        for (std::size_t i = 0; i < res.frame.pixel_count(); ++i) {
            ASSERT_TRUE(res.frame.prim[i] == kNoPrimitive || res.frame.prim[i] == ground ||
                        res.frame.prim[i] == ground + 1)
                << "pixel " << i << " sees the back face";
            seen_ground += res.frame.prim[i] != kNoPrimitive;
        }
        EXPECT_GT(seen_ground, 0u);
        EXPECT_GT(res.stats.culled_retraces, 300u) << (perspective ? "perspective" : "orthographic");
        EXPECT_EQ(res.stats.verified_retraces, 0u);
    }
}

// A ground plane and, at height h, an occluding half-plane over x < 0, seen from straight above
// in 2 cm pixels, 200 x 150 around x = xb, the edge's shadow. Checks V on the ground against
// x < xb, and boundary_m against `expect(p)` (NaN where the test has no analytic answer).
struct StraightEdge {
    std::size_t checked = 0;
    double worst = 0;  // largest |boundary_m - expect|, metres
    std::uint64_t boundary_rays = 0;
};
StraightEdge straight_edge(double h, double xb, const Light& light,
                           const std::function<double(const glm::dvec3&)>& expect) {
    SceneBuilder b;
    std::uint32_t ground = b.quad({-20, 0, 20}, {20, 0, 20}, {20, 0, -20}, {-20, 0, -20}, false);
    b.quad({-20, h, 20}, {0, h, 20}, {0, h, -20}, {-20, h, -20});
    Scenario sc = test::make_scenario(b.build(), test::look_at_ortho({xb, 10, 0}, {xb, 0, 0}, 2, 1.5, {0, 0, -1}),
                                      {light}, 200, 150);
    OracleResult res = run_oracle(sc);
    const OracleFrame& f = res.frame;
    const OracleLightImage& img = f.lights[0];
    StraightEdge out;
    out.boundary_rays = res.stats.boundary_rays;
    for (std::size_t i = 0; i < f.pixel_count(); ++i) {
        if (f.prim[i] != ground && f.prim[i] != ground + 1) continue;
        const glm::dvec3 p = world_point(f, i);
        if (img.U[i] == 0) {
            EXPECT_EQ(img.V[i], p.x < xb ? 0.0f : 1.0f) << "x = " << p.x;
        }
        const double e = expect(p);
        if (std::isnan(e)) continue;
        out.worst = std::max(out.worst, std::abs(img.boundary_m[i] - e));
        ++out.checked;
    }
    return out;
}

// The distance to the nearest shadow boundary, across the light direction: for a straight edge
// at height h under light tilted by theta it is |x - h tan(theta)| cos(theta).
TEST(Oracle, BoundaryDistanceIsExactForAStraightEdge) {
    const double h = 2, theta = 20 * M_PI / 180, xb = h * std::tan(theta);
    StraightEdge r = straight_edge(h, xb, test::directional({std::sin(theta), -std::cos(theta), 0}),
                                   [&](const glm::dvec3& p) { return std::abs(p.x - xb) * std::cos(theta); });
    EXPECT_GT(r.checked, 20000u);
    // Pixel footprint is 2 cm; the boundary is the occluder edge's exact shadow (docs/oracle.md
    // section 6), and P is stored in float.
    EXPECT_LT(r.worst, 1e-6);
    // One straddling pair per row: a ray at its shadowed end and one past the edge's shadow,
    // where bisection took 12.
    EXPECT_EQ(r.boundary_rays, 2u * 150);
}

// The same under a point light at (xl, yl, zl): the edge's shadow is the line x = -xl h / (yl - h).
// In the pixel row at z = zl, the line from a pixel to the light stays in that row's plane, so
// the nearest boundary point is the row's own, at lateral distance yl |x - xb| / |light - p|.
TEST(Oracle, BoundaryDistanceIsExactForAStraightEdgeUnderAPointLight) {
    const double h = 2, xl = -3, yl = 6, xb = -xl * h / (yl - h);
    const double zl = 0.01;  // 150 rows over 3 m: row centres at z = +-0.01, +-0.03, ...
    StraightEdge r = straight_edge(h, xb, test::point({xl, yl, zl}), [&](const glm::dvec3& p) {
        return std::abs(p.z - zl) > 1e-4 ? std::nan("") : yl * std::abs(p.x - xb) / std::hypot(xl - p.x, yl);
    });
    EXPECT_GT(r.checked, 150u);  // the row, less the pixels that see the occluder (x < 0)
    EXPECT_LT(r.worst, 1e-6);
}

// A 2 x 2 m slab floating 3 m over the ground, lit from above, seen obliquely: its shadow's
// outline is in plain view on the ground, and the slab's top face, which shares its rays, lies
// far from that outline in the image (the slab hides a patch of ground farther back). The
// nearest boundary point of a top-face pixel is a light-lateral neighbour only: boundary_m must
// find it all the same. Expected: the lateral distance from the pixel to the exact outline
// (per edge, in closed form), which the located boundary points on it can only exceed by their
// spacing (at most a ground pixel's footprint, under 10 cm here).
class BoundaryAcrossTheImage : public ::testing::TestWithParam<bool> {};

TEST_P(BoundaryAcrossTheImage, IsTheNearestInTheLightsFrame) {
    const bool point = GetParam();
    SceneBuilder b;
    b.quad({-20, 0, 20}, {20, 0, 20}, {20, 0, -20}, {-20, 0, -20}, false);
    const std::uint32_t slab_first = b.box({-1, 3, -1}, {1, 3.2, 1});
    const glm::dvec3 light_pos(0.3, 30, 0.2);
    const Light light = point ? test::point(light_pos) : test::directional({0, -1, 0});
    Scenario sc = test::make_scenario(b.build(), test::look_at({0, 10, 12}, {0, 0, 0}, 50), {light}, 256, 192);
    OracleResult res = run_oracle(sc);
    const OracleFrame& f = res.frame;
    const OracleLightImage& img = f.lights[0];

    // The outline on the ground: the slab's top square seen from the light (a point light above
    // it sees no side face), or straight below it.
    const glm::dvec2 corners[4] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    auto on_ground = [&](glm::dvec2 c) {
        if (!point) return glm::dvec3(c.x, 0, c.y);
        const glm::dvec3 top(c.x, 3.2, c.y);
        return light_pos + (light_pos.y / (light_pos.y - top.y)) * (top - light_pos);
    };
    // Distance from the line through p along u to the outline's edge a + s (z - a), s in [0, 1]:
    // |(a - p + s (z - a)) x u|^2 is a quadratic in s.
    auto expect = [&](const glm::dvec3& p) {
        const glm::dvec3 u = point ? glm::normalize(light_pos - p) : glm::dvec3(0, 1, 0);
        double best = 1e300;
        for (int e = 0; e < 4; ++e) {
            const glm::dvec3 a = on_ground(corners[e]), z = on_ground(corners[(e + 1) % 4]);
            const glm::dvec3 c0 = glm::cross(a - p, u), c1 = glm::cross(z - a, u);
            const double s = std::clamp(-glm::dot(c0, c1) / glm::dot(c1, c1), 0.0, 1.0);
            const glm::dvec3 c = c0 + s * c1;
            best = std::min(best, glm::dot(c, c));
        }
        return std::sqrt(best);
    };

    std::size_t top = 0, ground_near = 0;
    double worst_over = 0, worst_under = 0;
    for (std::size_t i = 0; i < f.pixel_count(); ++i) {
        if (f.A[i] == 0 || img.lightable[i] == 0) continue;
        const bool on_top = f.prim[i] >= slab_first && f.N[i].y > 0.99f;
        const glm::dvec3 p = world_point(f, i);
        const double e = expect(p);
        if (!on_top && e > 1.0) continue;  // the ground near the shadow, and every top-face pixel
        (on_top ? top : ground_near)++;
        ASSERT_TRUE(std::isfinite(img.boundary_m[i])) << "pixel " << i;
        worst_over = std::max(worst_over, img.boundary_m[i] - e);
        worst_under = std::max(worst_under, e - img.boundary_m[i]);
    }
    EXPECT_GT(top, 300u);
    EXPECT_GT(ground_near, 1500u);
    EXPECT_LT(worst_under, 1e-5) << "nearer than the exact outline";
    EXPECT_LT(worst_over, 0.1) << "a located boundary point nearer than the one found was missed";
}

INSTANTIATE_TEST_SUITE_P(Oracle, BoundaryAcrossTheImage, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& p) { return p.param ? "point" : "directional"; });

// Thin bars and posts floating a little over a long ground, seen from near it (the long view of
// docs/raster.md's cascades): near the camera the ground's pixels are far denser in the light's
// chart than its cells, so a cell's 3 x 3 block holds the boundary points of several thin shadows
// side by side. Each shadow is the convex hull of its box's corners projected onto the ground
// from the light, so the exact distance of a ground point is its lateral distance to the
// nearest hull edge (the hulls are disjoint, each wider than a pixel's footprint, and in plain
// view: in front of its caster, before any other's view of the ground). The located points lie
// on those edges, two 4-adjacent pixels apart at most: the nearest is within that spacing of
// the exact nearest point, so boundary_m may exceed the exact distance by the spacing, never
// fall below it.
class BoundaryBesideCrowdedThinShadows : public ::testing::TestWithParam<bool> {};

TEST_P(BoundaryBesideCrowdedThinShadows, IsExact) {
    const bool point = GetParam();
    SceneBuilder b;
    const std::uint32_t ground = b.quad({-40, 0, 2}, {40, 0, 2}, {40, 0, -300}, {-40, 0, -300}, false);
    std::vector<std::pair<glm::dvec3, glm::dvec3>> casters;
    for (int k = 0; k < 4; ++k) {  // bars across the view, 20 cm over the ground, 20 cm apart
        const double z = -3.5 - 0.2 * k, x = 0.1 * k;
        casters.push_back({{-2.5 + x, 0.2, z - 0.05}, {0.5 + x, 0.23, z + 0.05}});
    }
    for (int k = 0; k < 8; ++k) {  // posts, 4 cm thick, 10 cm over it, 25 cm apart
        const double x = 1.4 + 0.25 * k, z = -4.5 - 0.05 * k;
        casters.push_back({{x - 0.02, 0.1, z - 0.02}, {x + 0.02, 1.5, z + 0.02}});
    }
    for (const auto& c : casters) b.box(c.first, c.second);
    // The light comes from behind the casters, so their shadows fall towards the camera.
    const glm::dvec3 sun = glm::normalize(glm::dvec3(-0.25, 1, -0.35)), lamp = glm::dvec3(0, 0, -4) + 20.0 * sun;
    Camera cam = test::look_at({0, 1.7, 2}, {0, 1.0, -60}, 50);
    cam.znear = 0.1;
    cam.zfar = 300;
    const Light light = point ? test::point(lamp) : test::directional(-sun);
    Scenario sc = test::make_scenario(b.build(), cam, {light}, 480, 300);
    OracleResult res = run_oracle(sc);
    const OracleFrame& f = res.frame;
    const OracleLightImage& img = f.lights[0];

    // The hulls on the ground (x, z), and the lateral distance from p to a point q.
    std::vector<std::vector<glm::dvec2>> hulls;
    for (const auto& [lo, hi] : casters) {
        std::vector<glm::dvec2> v;
        for (int c = 0; c < 8; ++c) {
            const glm::dvec3 corner(c & 1 ? hi.x : lo.x, c & 2 ? hi.y : lo.y, c & 4 ? hi.z : lo.z);
            v.push_back(point ? project_from_point(lamp, corner) : project_along(-sun, corner));
        }
        std::sort(v.begin(), v.end(),
                  [](glm::dvec2 u, glm::dvec2 w) { return u.x < w.x || (u.x == w.x && u.y < w.y); });
        std::vector<glm::dvec2> h(16);  // Andrew's monotone chain
        std::size_t k = 0;
        for (std::size_t i = 0; i < v.size(); ++i) {
            while (k >= 2 && cross2(h[k - 2], h[k - 1], v[i]) <= 0) --k;
            h[k++] = v[i];
        }
        for (std::size_t i = v.size() - 1, t = k + 1; i-- > 0;) {
            while (k >= t && cross2(h[k - 2], h[k - 1], v[i]) <= 0) --k;
            h[k++] = v[i];
        }
        h.resize(k - 1);
        hulls.push_back(h);
    }
    auto to_light = [&](const glm::dvec3& p) { return point ? glm::normalize(lamp - p) : sun; };
    auto lateral = [&](const glm::dvec3& p, const glm::dvec3& q) {
        return glm::length(glm::cross(q - p, to_light(p)));
    };
    // Per hull edge a z: |(a - p + s (z - a)) x u|^2 is a quadratic in s.
    auto expect = [&](const glm::dvec3& p) {
        const glm::dvec3 u = to_light(p);
        double best = 1e300;
        for (const auto& h : hulls)
            for (std::size_t e = 0; e < h.size(); ++e) {
                const glm::dvec3 a(h[e].x, 0, h[e].y), z(h[(e + 1) % h.size()].x, 0, h[(e + 1) % h.size()].y);
                const glm::dvec3 c0 = glm::cross(a - p, u), c1 = glm::cross(z - a, u);
                const double s = std::clamp(-glm::dot(c0, c1) / glm::dot(c1, c1), 0.0, 1.0);
                best = std::min(best, glm::length(c0 + s * c1));
            }
        return best;
    };

    // The located points' spacing: the farthest apart two 4-adjacent ground pixels near a shadow are.
    const auto W = static_cast<std::size_t>(f.width);
    auto near_ground = [&](std::size_t i) {
        return f.A[i] != 0 && img.lightable[i] != 0 && f.prim[i] < ground + 2 && expect(world_point(f, i)) < 0.5;
    };
    double spacing = 0;
    for (std::size_t i = 0; i < f.pixel_count(); ++i)
        if (near_ground(i))
            for (const std::size_t j : {i + 1, i + W})
                if (j < f.pixel_count() && (j % W) != 0 && near_ground(j))
                    spacing = std::max(spacing, lateral(world_point(f, i), world_point(f, j)));
    ASSERT_GT(spacing, 0);
    EXPECT_LT(spacing, 0.15);

    std::size_t checked = 0, over = 0;
    double worst_over = 0, worst_under = 0;
    for (std::size_t i = 0; i < f.pixel_count(); ++i) {
        if (!near_ground(i)) continue;
        ++checked;
        const double e = expect(world_point(f, i));
        const double d = img.boundary_m[i];
        worst_under = std::max(worst_under, e - d);
        worst_over = std::max(worst_over, d - e);
        if (d - e > spacing) {
            if (over < 5) ADD_FAILURE() << "pixel " << i << ": boundary_m " << d << ", exact " << e;
            ++over;
        }
    }
    EXPECT_GT(checked, 5000u);
    EXPECT_EQ(over, 0u) << "of " << checked << " pixels near the shadows; spacing " << spacing << " m, worst "
                        << worst_over << " m over";
    EXPECT_LT(worst_under, 1e-5) << "nearer than the exact outline";

    // and the same answer on any number of threads.
    OracleSettings one, many;
    one.threads = 1;
    many.threads = 16;
    const OracleResult a = run_oracle(sc, one), c = run_oracle(sc, many);
    const std::vector<float>&ba = a.frame.lights[0].boundary_m, &bc = c.frame.lights[0].boundary_m;
    ASSERT_EQ(ba.size(), bc.size());
    EXPECT_EQ(std::memcmp(ba.data(), bc.data(), ba.size() * sizeof(float)), 0);
}

INSTANTIATE_TEST_SUITE_P(Oracle, BoundaryBesideCrowdedThinShadows, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& p) { return p.param ? "point" : "directional"; });

// ---- invariance ---------------------------------------------------------------------------

Scenario invariance_scene(int width = 320, int height = 180) {
    SceneBuilder b;
    b.quad({-10, 0, 10}, {10, 0, 10}, {10, 0, -10}, {-10, 0, -10}, false);
    b.box({-2.5, 0, -0.5}, {-1.5, 1, 0.5});                                            // resting on the plane
    b.box({0.2, 0, -1.51}, {0.22, 2.5, -1.49});                                        // a 2 cm pole
    b.quad({-0.4, 1.6, -1.5}, {0.8, 1.6, -1.5}, {0.8, 2.2, -1.5}, {-0.4, 2.2, -1.5});  // zero-thickness sign
    b.box({-3.3, 2.1, -0.3}, {-1.3, 2.3, 0.7});                                        // floating slab over the box
    b.grid({1, 0.3, 1}, {2.5, 0.6, 0}, {0, 0.05, -2}, 8, 8);                           // a tilted, tessellated ramp
    std::vector<Light> lights{test::directional({0.35, -0.7, -0.45}), test::point({1.0, 3.2, 2.5}),
                              test::spot({-3.5, 5.0, 3.5}, {0.55, -1.0, -0.55}, 40)};
    return test::make_scenario(b.build(), test::look_at({4.5, 4.0, 9.0}, {0, 0.6, 0}, 45), lights, width, height);
}

// Applies x -> s * R x + t to everything positional in the scenario.
Scenario transformed(Scenario sc, double s, const glm::dmat3& r, const glm::dvec3& t) {
    for (auto& p : sc.scene.positions) p = s * (r * p) + t;
    Camera& c = sc.camera;
    c.eye = s * (r * c.eye) + t;
    c.forward = r * c.forward;
    c.right = r * c.right;
    c.up = r * c.up;
    c.znear *= s;
    c.zfar *= s;
    for (auto& l : sc.lights) {
        l.position = s * (r * l.position) + t;
        l.direction = r * l.direction;
    }
    return sc;
}

struct InvarianceCase {
    const char* name;
    double scale;
    double angle_deg;
    double translation;
};

class Invariance : public ::testing::TestWithParam<InvarianceCase> {};

TEST_P(Invariance, GivesTheSameVerdictOutsideAmbiguousPixels) {
    const InvarianceCase ic = GetParam();
    Scenario base = invariance_scene();
    glm::dmat3 r(glm::rotate(glm::dmat4(1.0), ic.angle_deg * M_PI / 180, glm::normalize(glm::dvec3(1, 2, 3))));
    Scenario moved =
        transformed(base, ic.scale, r, glm::dvec3(ic.translation, -0.5 * ic.translation, 0.7 * ic.translation));
    OracleResult a = run_oracle(base), b = run_oracle(moved);
    std::size_t pixels = a.frame.pixel_count(), prim_differs = 0, compared = 0, wrong = 0, ambiguous = 0, shadowed = 0;
    for (std::size_t i = 0; i < pixels; ++i) {
        if (a.frame.prim[i] != b.frame.prim[i]) {
            ++prim_differs;
            continue;
        }
        if (a.frame.A[i] == 0) continue;
        for (std::size_t li = 0; li < a.frame.lights.size(); ++li) {
            const auto &la = a.frame.lights[li], &lb = b.frame.lights[li];
            if (la.U[i] != 0 || lb.U[i] != 0) {
                ++ambiguous;
                continue;
            }
            ++compared;
            bool same = la.V[i] == lb.V[i] && la.lightable[i] == lb.lightable[i];
            wrong += !same;
            if (!same && wrong < 5)
                ADD_FAILURE() << ic.name << ": light " << li << " pixel " << i % a.frame.width << ","
                              << i / a.frame.width << " V " << la.V[i] << " vs " << lb.V[i] << ", boundary "
                              << la.boundary_m[i];
            if (same && la.V[i] == 0 && la.lightable[i] != 0) {
                ++shadowed;
                // Embree's t carries an absolute float error of ~eps x the scene's coordinates (10 m).
                EXPECT_NEAR(lb.occluder_m[i], ic.scale * la.occluder_m[i], ic.scale * (1e-4 * la.occluder_m[i] + 1e-5));
            }
        }
    }
    EXPECT_EQ(wrong, 0u);
    EXPECT_LT(prim_differs, pixels / 500) << "only silhouette pixels may see another primitive";
    EXPECT_LT(ambiguous, compared / 500);
    EXPECT_GT(shadowed, 5000u);
}

INSTANTIATE_TEST_SUITE_P(Oracle, Invariance,
                         ::testing::Values(InvarianceCase{"translated_1e7", 1, 0, 1e7},
                                           InvarianceCase{"scaled_1em4", 1e-4, 0, 0},
                                           InvarianceCase{"scaled_1e4", 1e4, 0, 0}, InvarianceCase{"rotated", 1, 37, 0},
                                           InvarianceCase{"all_at_once", 1e3, 71, 1e7}),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

// Two arrays with the same elements, bit for bit.
template <typename T>
bool same(const std::vector<T>& x, const std::vector<T>& y) {
    return x.size() == y.size() && std::memcmp(x.data(), y.data(), x.size() * sizeof(T)) == 0;
}

TEST(Oracle, IsBitIdenticalWhateverTheThreadCount) {
    Scenario sc = invariance_scene();
    OracleSettings one;
    one.threads = 1;
    OracleResult a = run_oracle(sc, one);
    // 3 threads on a 2-core machine: the boundary search's rows and the tiles must not depend on
    // which thread runs ahead.
    for (int threads : {2, 3}) {
        SCOPED_TRACE(threads);
        OracleSettings many;
        many.threads = threads;
        OracleResult b = run_oracle(sc, many);
        EXPECT_TRUE(same(a.frame.A, b.frame.A));
        EXPECT_TRUE(same(a.frame.prim, b.frame.prim));
        EXPECT_TRUE(same(a.frame.depth, b.frame.depth));
        EXPECT_TRUE(same(a.frame.P, b.frame.P));
        EXPECT_TRUE(same(a.frame.N, b.frame.N));
        for (std::size_t li = 0; li < a.frame.lights.size(); ++li) {
            // The pixel counts of oracle.json (a parallel reduction).
            EXPECT_EQ(a.stats.lights[li].surface, b.stats.lights[li].surface);
            EXPECT_EQ(a.stats.lights[li].lightable, b.stats.lights[li].lightable);
            EXPECT_EQ(a.stats.lights[li].shadowed, b.stats.lights[li].shadowed);
            EXPECT_EQ(a.stats.lights[li].uncertain, b.stats.lights[li].uncertain);
            EXPECT_TRUE(same(a.frame.lights[li].lightable, b.frame.lights[li].lightable));
            EXPECT_TRUE(same(a.frame.lights[li].V, b.frame.lights[li].V));
            EXPECT_TRUE(same(a.frame.lights[li].U, b.frame.lights[li].U));
            EXPECT_TRUE(same(a.frame.lights[li].occluder_m, b.frame.lights[li].occluder_m));
            EXPECT_TRUE(same(a.frame.lights[li].boundary_m, b.frame.lights[li].boundary_m));
        }
    }
}

// run_oracle hands its BVH back on a thread of its own (so that the caller's write hides it,
// #39): the result carries that release, which finishes, and copies of the result share it.
TEST(Oracle, ReleasesItsBvhOnAThreadOfItsOwn) {
    Scenario sc = invariance_scene();
    OracleResult a = run_oracle(sc);
    ASSERT_TRUE(a.tracer_released.valid());
    const OracleResult copy = a;
    EXPECT_EQ(copy.tracer_released.wait_for(std::chrono::seconds(60)), std::future_status::ready);
    EXPECT_EQ(a.tracer_released.wait_for(std::chrono::seconds(0)), std::future_status::ready);
}

// The distance transform's sweeps run in bands of rows side by side, one per thread allowed, each
// band then swept again from the true row above it until a row agrees (shadow_boundary.cpp,
// nearest_sweeps): with 16 bands (more than this machine's cores) the result must be the serial
// sweep's, in the directional light's chart and, for the point light's cube of charts, over the
// image.
TEST(Oracle, BoundarySweepsInBandsGiveTheSerialAnswer) {
    Scenario sc = invariance_scene(1280, 720);
    OracleSettings one, many;
    one.threads = 1;
    many.threads = 16;
    const OracleResult a = run_oracle(sc, one), b = run_oracle(sc, many);
    for (std::size_t li = 0; li < a.frame.lights.size(); ++li) {
        SCOPED_TRACE(li);
        EXPECT_TRUE(same(a.frame.lights[li].boundary_m, b.frame.lights[li].boundary_m));
        EXPECT_TRUE(same(a.frame.lights[li].U, b.frame.lights[li].U));
    }
}

// Embree picks its kernels by the CPU: 16-wide packets natively with AVX-512, through its
// stream fallback below it (docs/oracle.md section 7). The verdicts must not depend on which.
TEST(Oracle, GivesTheSameAnswersWhateverEmbreesKernels) {
    Scenario sc = invariance_scene();
    const OracleResult native = run_oracle(sc);
    for (const char* isa : {"avx2", "sse4.2"}) {
        SCOPED_TRACE(isa);
        OracleSettings s;
        s.embree_isa = isa;
        const OracleResult other = run_oracle(sc, s);
        EXPECT_TRUE(same(native.frame.prim, other.frame.prim));
        EXPECT_TRUE(same(native.frame.P, other.frame.P));
        EXPECT_TRUE(same(native.frame.N, other.frame.N));
        for (std::size_t li = 0; li < native.frame.lights.size(); ++li) {
            SCOPED_TRACE(li);
            const OracleLightImage &a = native.frame.lights[li], &b = other.frame.lights[li];
            EXPECT_TRUE(same(a.lightable, b.lightable));
            EXPECT_TRUE(same(a.V, b.V));
            EXPECT_TRUE(same(a.U, b.U));
            EXPECT_TRUE(same(a.boundary_m, b.boundary_m));
            // occluder_m is Embree's float hit distance (docs/oracle.md, "Known limits"): kernels
            // of another width round it differently, by ~eps x the scene's 20 m (measured: up to
            // 1.9e-6 m, SSE4.2 against AVX2).
            float worst = 0;
            for (std::size_t i = 0; i < a.occluder_m.size(); ++i)
                worst = std::max(worst, std::abs(a.occluder_m[i] - b.occluder_m[i]));
            EXPECT_LE(worst, 1e-5f);
        }
    }
    OracleSettings unknown;
    unknown.embree_isa = "avx3";
    EXPECT_THROW(run_oracle(sc, unknown), InputError);
}

TEST(Oracle, TracesNothingForAbsentLightsOrBackground) {
    SceneBuilder b;
    b.quad({-1, 0, 1}, {1, 0, 1}, {1, 0, -1}, {-1, 0, -1}, false);
    Scenario sc = test::make_scenario(b.build(), test::look_at({0, 3, 3}, {0, 0, 0}, 30), {}, 64, 48);
    OracleResult res = run_oracle(sc);
    EXPECT_EQ(res.stats.shadow_rays, 0u);
    EXPECT_EQ(res.stats.boundary_rays, 0u);
    // With a light below the plane every pixel faces away from it: no shadow rays either.
    sc.lights = {test::directional({0, 1, 0})};
    res = run_oracle(sc);
    EXPECT_EQ(res.stats.shadow_rays, 0u);
    EXPECT_GT(res.stats.lights[0].surface, 100u);
    EXPECT_EQ(res.stats.lights[0].lightable, 0u);
}

}  // namespace
}  // namespace penumbra
