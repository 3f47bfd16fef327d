#include "stress/cases.h"

#include <fmt/format.h>

#include <cmath>
#include <functional>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <numbers>
#include <random>

#include "common/camera.h"
#include "common/errors.h"

namespace penumbra::stress {

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// A triangle soup assembled from shapes, world space, counter-clockwise = outward.
class Shapes {
  public:
    std::uint32_t triangle(glm::dvec3 a, glm::dvec3 b, glm::dvec3 c, bool double_sided = false) {
        return scene_.add_triangle(a, b, c, double_sided);
    }
    void quad(glm::dvec3 a, glm::dvec3 b, glm::dvec3 c, glm::dvec3 d, bool double_sided = false) {
        triangle(a, b, c, double_sided);
        triangle(a, c, d, double_sided);
    }
    // An upward-facing square ground of half-size h at height y.
    void ground(double h, double y = 0) { quad({-h, y, h}, {h, y, h}, {h, y, -h}, {-h, y, -h}); }
    void box(glm::dvec3 lo, glm::dvec3 hi) {
        glm::dvec3 p[8];
        for (int i = 0; i < 8; ++i) p[i] = {i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z};
        quad(p[0], p[2], p[3], p[1]);  // -z
        quad(p[4], p[5], p[7], p[6]);  // +z
        quad(p[0], p[4], p[6], p[2]);  // -x
        quad(p[1], p[3], p[7], p[5]);  // +x
        quad(p[0], p[1], p[5], p[4]);  // -y
        quad(p[2], p[6], p[7], p[3]);  // +y
    }
    // A UV sphere with its vertices on the sphere, faces outward.
    void sphere(glm::dvec3 c, double r, int slices, int stacks) {
        auto at = [&](int i, int j) {
            double phi = 2 * std::numbers::pi * i / slices, theta = std::numbers::pi * j / stacks;
            return c +
                   r * glm::dvec3(std::sin(theta) * std::cos(phi), std::cos(theta), -std::sin(theta) * std::sin(phi));
        };
        for (int j = 0; j < stacks; ++j)
            for (int i = 0; i < slices; ++i) {
                glm::dvec3 a = at(i, j), b = at(i, j + 1), cc = at(i + 1, j + 1), d = at(i + 1, j);
                if (j > 0) triangle(a, b, d);
                if (j < stacks - 1) triangle(b, cc, d);
            }
    }
    Scene build() const { return scene_; }

  private:
    Scene scene_;
};

Camera look_at(glm::dvec3 eye, glm::dvec3 target, double yfov_deg, double znear, double zfar = 1e30) {
    Camera c;
    look_at_basis(eye, target, {0, 1, 0}, c);
    c.type = ProjectionType::perspective;
    c.yfov_rad = yfov_deg * kDeg;
    c.znear = znear;
    c.zfar = zfar;
    return c;
}

Light directional(glm::dvec3 d, const char* name) {
    Light l;
    l.type = LightType::directional;
    l.direction = glm::normalize(d);
    l.origin = name;
    return l;
}

Light point(glm::dvec3 p, const char* name) {
    Light l;
    l.type = LightType::point;
    l.position = p;
    l.origin = name;
    return l;
}

Light spot(glm::dvec3 p, glm::dvec3 d, double outer_half_deg, const char* name) {
    Light l;
    l.type = LightType::spot;
    l.position = p;
    l.direction = glm::normalize(d);
    l.outer_cone_rad = outer_half_deg * kDeg;
    l.inner_cone_rad = 0;
    l.origin = name;
    return l;
}

// A sun `angle_deg` from the vertical (the ground's normal), from azimuth `azimuth_deg`.
glm::dvec3 sun(double angle_deg, double azimuth_deg) {
    double a = angle_deg * kDeg, z = azimuth_deg * kDeg;
    return {std::sin(a) * std::cos(z), -std::cos(a), std::sin(a) * std::sin(z)};
}

Scenario scenario(const std::string& name, Scene scene, Camera camera, std::vector<Light> lights,
                  const CaseOptions& o) {
    Scenario s;
    s.label = "stress case " + name;
    s.width = o.width;
    s.height = o.height;
    s.camera = camera;
    s.lights = std::move(lights);
    s.scene = std::move(scene);
    return s;
}

// The base scene of the far and scale cases: a box resting on the ground, a 2 cm pole, a
// floating slab and a zero-thickness sign, under a sun and a point light.
Scenario base_scene(const std::string& name, const CaseOptions& o) {
    Shapes b;
    b.ground(10);
    b.box({-2.5, 0, -0.5}, {-1.5, 1, 0.5});
    b.box({0.2, 0, -1.51}, {0.22, 2.5, -1.49});
    b.quad({-0.4, 1.6, -1.5}, {0.8, 1.6, -1.5}, {0.8, 2.2, -1.5}, {-0.4, 2.2, -1.5}, true);
    b.box({-3.3, 2.1, -0.3}, {-1.3, 2.3, 0.7});
    return scenario(name, b.build(), look_at({4.5, 4.0, 9.0}, {0, 0.6, 0}, 45, 0.01),
                    {directional({0.35, -0.7, -0.45}, "sun"), point({1.0, 3.2, 2.5}, "lamp")}, o);
}

// The frame the canonical version of a geometric case is drawn in: a generic rotation and a
// kilometre away, so no axis, sign or exponent is shared with the case.
Scenario moved_copy(const Scenario& s) {
    glm::dmat3 r(glm::rotate(glm::dmat4(1.0), 37 * kDeg, glm::normalize(glm::dvec3(1, 2, 3))));
    return transformed(s, 1.0, r, {1000.0, -500.0, 700.0});
}

constexpr const char* kMovedCopy = "the same scene rotated 37 degrees about (1,2,3) and moved 1.3 km";

StressCase geometric(std::string name, std::string group, std::string stresses, Scenario s) {
    StressCase c{std::move(name), std::move(group), std::move(stresses), kMovedCopy, std::move(s), {}, false};
    c.reference = moved_copy(c.scenario);
    c.scenario.label = "stress case " + c.name;
    c.reference.label = "stress case " + c.name + " (canonical)";
    return c;
}

StressCase grazing(double angle_deg, const std::string& name, const CaseOptions& o) {
    Shapes b;
    b.ground(20);
    b.box({-0.5, 0, -0.5}, {0.5, 1, 0.5});
    b.box({1.5, 0, 1.0}, {1.52, 1.5, 1.02});  // a 2 cm pole
    Scenario s = scenario(name, b.build(), look_at({5, 4, 6}, {0.5, 0, 0}, 50, 0.01),
                          {directional(sun(angle_deg, 200), "grazing sun")}, o);
    return geometric(name, "grazing",
                     fmt::format("a sun {} degrees from the ground's normal: the terminator and shadows {:.0f} times "
                                 "longer than their casters",
                                 angle_deg, std::tan(angle_deg * kDeg)),
                     std::move(s));
}

StressCase far_from_origin(double distance, const std::string& name, const CaseOptions& o) {
    Scenario base = base_scene(name, o);
    StressCase c{name,
                 "far_from_origin",
                 fmt::format("the base scene {:g} m from the origin, where a float's step is {:g} m", distance,
                             std::ldexp(1.0, std::ilogb(distance) - 23)),
                 "the same scene at the origin",
                 transformed(base, 1.0, glm::dmat3(1.0), glm::dvec3(0.8, 0.36, -0.48) * distance),
                 base,
                 true};
    c.scenario.label = "stress case " + name;
    c.reference.label = "stress case " + name + " (canonical)";
    return c;
}

StressCase scaled(double scale, const std::string& name, const CaseOptions& o) {
    Scenario base = base_scene(name, o);
    StressCase c{name,
                 "scale",
                 fmt::format("the whole base scenario scaled by {:g} (lights, camera and depth range with it)", scale),
                 "the same scene at scale 1",
                 transformed(base, scale, glm::dmat3(1.0), glm::dvec3(0.0)),
                 base,
                 true};
    c.scenario.label = "stress case " + name;
    c.reference.label = "stress case " + name + " (canonical)";
    return c;
}

// A ground that widens with distance so it fills the view out to `depth` metres, boxes from a
// centimetre in front of the eye out to the horizon, each as large as its distance is far.
StressCase depth_range(double depth, const std::string& name, const CaseOptions& o) {
    Shapes b;
    const double w = 0.8 * depth;
    b.quad({-0.5, 0, 0.5}, {0.5, 0, 0.5}, {w, 0, -depth}, {-w, 0, -depth});
    b.box({-0.004, 1.69, -0.012}, {0.004, 1.695, -0.008});  // 1 cm from the eye
    for (double d = 2; d < depth; d *= 10) b.box({0.1 * d, 0, -1.05 * d}, {0.25 * d, 0.15 * d, -0.95 * d});
    Camera cam = look_at({0, 1.7, 0}, {0, 1.2, -10}, 60, 1e-3, depth);
    Scenario s =
        scenario(name, b.build(), cam,
                 {directional(sun(50, 240), "sun"), spot({0.2, 1.0, 0.1}, {0.0, -0.05, -1.0}, 45, "headlight")}, o);
    return geometric(name, "depth_range",
                     fmt::format("znear 1e-3 m, zfar {:g} m: a depth range of {:g} in the camera and in the spot "
                                 "light's frustum",
                                 depth, depth / 1e-3),
                     std::move(s));
}

StressCase thin_occluders(const std::string& name, const CaseOptions& o) {
    Shapes b;
    b.ground(10);
    b.box({-1, 0.5, -1}, {0, 0.5001, 0});            // a slab 1e-4 m thick
    b.box({0.5, 0.3, -1.5}, {0.5001, 0.3001, 1.5});  // a wire 1e-4 m across
    b.box({1.0, 0, -0.6}, {1.0001, 1.2, 0.6});       // a wall 1e-4 m thick
    Scenario s = scenario(name, b.build(), look_at({2.5, 2.2, 3.5}, {0, 0.3, -0.3}, 50, 0.01),
                          {directional(sun(35, 30), "sun")}, o);
    return geometric(name, "thin_occluders",
                     "occluders 1e-4 m thick: a slab, a wire and a wall, far thinner than a pixel or a texel",
                     std::move(s));
}

StressCase coplanar(const std::string& name, const CaseOptions& o) {
    Shapes b;
    b.ground(8);
    // Decals exactly on the ground: two triangles in the same plane at every point (z-fighting).
    b.quad({-1.5, 0, 1.0}, {1.0, 0, 1.0}, {1.0, 0, -1.5}, {-1.5, 0, -1.5});
    b.quad({-0.5, 0, 2.0}, {2.0, 0, 2.0}, {2.0, 0, -0.5}, {-0.5, 0, -0.5});
    b.box({-0.3, 0, -0.3}, {0.3, 1.2, 0.3});
    b.box({0.8, 0.0, 0.8}, {1.4, 0.6, 1.4});
    b.quad({0.8, 0.6, 0.8}, {0.8, 0.6, 1.4}, {1.4, 0.6, 1.4}, {1.4, 0.6, 0.8}, true);  // a decal on the box's top
    Scenario s =
        scenario(name, b.build(), look_at({3, 3.5, 4}, {0.2, 0, 0}, 50, 0.01), {directional(sun(40, 210), "sun")}, o);
    return geometric(name, "coplanar",
                     "coplanar receivers: decals exactly on the ground and on a box's top (z-fighting)", std::move(s));
}

StressCase contact_box(const std::string& name, const CaseOptions& o) {
    Shapes b;
    b.ground(30);
    b.box({-0.5, 0, -0.5}, {0.5, 1, 0.5});
    Scenario s = scenario(name, b.build(), look_at({2.5, 2.5, 2.0}, {0.6, 0, 0.4}, 50, 0.01),
                          {directional(sun(80, 30), "low sun")}, o);
    return geometric(name, "contact", "a box resting on the ground under a sun 10 degrees above the horizon",
                     std::move(s));
}

StressCase contact_sphere(const std::string& name, const CaseOptions& o) {
    Shapes b;
    b.ground(10);
    b.sphere({0, 0.5, 0}, 0.5, 48, 24);  // its lowest vertex touches the ground at the origin
    Scenario s = scenario(name, b.build(), look_at({1.6, 1.2, 1.8}, {0.2, 0.1, 0.2}, 50, 0.01),
                          {directional(sun(60, 225), "sun")}, o);
    return geometric(name, "contact", "a sphere touching the ground at a single vertex", std::move(s));
}

StressCase contact_wedge(const std::string& name, const CaseOptions& o) {
    Shapes b;
    b.ground(10);
    // A wedge whose underside meets the ground along x = 0 and rises at 1 degree.
    const double len = 3, h = len * std::tan(1 * kDeg), z0 = -1, z1 = 1;
    glm::dvec3 a0(0, 0, z1), a1(0, 0, z0), t0(len, h, z1), t1(len, h, z0), s0(len, 0, z1), s1(len, 0, z0);
    b.quad(a0, t0, t1, a1);  // top, at 1 degree
    b.triangle(a0, s0, t0);  // +z side
    b.triangle(a1, t1, s1);  // -z side
    b.quad(s0, s1, t1, t0);  // the end wall
    b.quad(a0, a1, s1, s0);  // underside, on the ground
    Scenario s = scenario(name, b.build(), look_at({-0.8, 0.6, 2.2}, {0.8, 0, 0}, 50, 0.01),
                          {directional(sun(30, 0), "sun")}, o);
    return geometric(name, "contact",
                     "a wedge meeting the ground at 1 degree: contact along a line, a gap that grows "
                     "by 1.7 cm per metre",
                     std::move(s));
}

StressCase needles(const std::string& name, const CaseOptions& o) {
    Shapes b;
    // The ground as a fan of 400 slivers from one corner: near-degenerate receivers.
    const int n = 400;
    for (int i = 0; i < n; ++i) {
        double x0 = -4 + 8.0 * i / n, x1 = -4 + 8.0 * (i + 1) / n;
        b.triangle({0, 0, 6}, {x1, 0, -4}, {x0, 0, -4});
    }
    // Needles: 1 m long, 1e-4 m wide, seeded.
    std::mt19937_64 rng(o.seed);
    std::uniform_real_distribution<double> pos(-2, 2), height(0.3, 1.5), angle(0, std::numbers::pi);
    for (int i = 0; i < 40; ++i) {
        glm::dvec3 c(pos(rng), height(rng), pos(rng));
        double a = angle(rng);
        glm::dvec3 along(std::cos(a), 0.1, std::sin(a)), across(-std::sin(a), 0, std::cos(a));
        b.triangle(c - 0.5 * along, c + 0.5 * along, c + 1e-4 * across, true);
    }
    Scenario s = scenario(name, b.build(), look_at({3, 3, 4}, {0, 0, 0}, 50, 0.01),
                          {directional(sun(30, 250), "sun"), point({0.5, 2.5, 0.5}, "lamp")}, o);
    return geometric(name, "degenerate",
                     "needle occluders 1 m by 1e-4 m over a ground made of 400 slivers from one corner", std::move(s));
}

StressCase t_junctions(const std::string& name, const CaseOptions& o) {
    Shapes b;
    // One large quad on the left, a 8x8 grid on the right: the grid's vertices sit on the large
    // quad's edge (T-junctions), where float rounding opens cracks.
    b.quad({-6, 0, 4}, {0, 0, 4}, {0, 0, -4}, {-6, 0, -4});
    const int n = 8;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            double x0 = 6.0 * i / n, x1 = 6.0 * (i + 1) / n, z0 = 4 - 8.0 * j / n, z1 = 4 - 8.0 * (j + 1) / n;
            b.quad({x0, 0, z0}, {x1, 0, z0}, {x1, 0, z1}, {x0, 0, z1});
        }
    b.box({-0.4, 0, -0.6}, {0.4, 1.5, 0.2});
    Scenario s = scenario(name, b.build(), look_at({1.5, 3, 4.5}, {0, 0, -0.5}, 50, 0.01),
                          {directional(sun(45, 200), "sun")}, o);
    return geometric(name, "degenerate", "a ground with T-junctions along the seam a box's shadow crosses",
                     std::move(s));
}

StressCase point_touching(const std::string& name, const CaseOptions& o) {
    Shapes b;
    b.ground(10);
    b.box({0.6, 0, -0.3}, {1.0, 0.4, 0.1});
    Scenario s = scenario(name, b.build(), look_at({-1.5, 2.0, 2.5}, {0.3, 0, 0}, 50, 0.01),
                          {point({0, 1e-4, 0}, "touching lamp")}, o);
    return geometric(name, "lights",
                     "a point light 1e-4 m above the ground: light at 90 degrees to the ground's normal", std::move(s));
}

StressCase point_inside(const std::string& name, const CaseOptions& o) {
    Shapes b;
    // A closed room (double-sided walls) with pillars; the lamp and the camera are inside.
    const double h = 4;
    b.ground(h);
    b.quad({-h, 3, -h}, {-h, 3, h}, {h, 3, h}, {h, 3, -h}, true);    // ceiling
    b.quad({-h, 0, -h}, {-h, 3, -h}, {h, 3, -h}, {h, 0, -h}, true);  // walls
    b.quad({-h, 0, h}, {h, 0, h}, {h, 3, h}, {-h, 3, h}, true);
    b.quad({-h, 0, -h}, {-h, 0, h}, {-h, 3, h}, {-h, 3, -h}, true);
    b.quad({h, 0, -h}, {h, 3, -h}, {h, 3, h}, {h, 0, h}, true);
    for (double x : {-2.0, 0.0, 2.0}) b.box({x - 0.2, 0, -2.2}, {x + 0.2, 3, -1.8});
    b.box({-0.5, 0, 0.5}, {0.5, 0.8, 1.5});
    Scenario s = scenario(name, b.build(), look_at({0.5, 2.2, 3.5}, {0, 0.6, -2}, 70, 0.01),
                          {point({0.3, 1.8, -0.5}, "room lamp")}, o);
    return geometric(name, "lights",
                     "a point light inside the scene's bounds: every cube face of its map sees geometry", std::move(s));
}

StressCase spot_wide(const std::string& name, const CaseOptions& o) {
    Shapes b;
    b.ground(10);
    b.box({-1.5, 0, -0.5}, {-0.9, 0.8, 0.1});
    b.box({1.2, 0, 0.6}, {1.6, 1.1, 1.0});
    b.box({-0.2, 0.9, -0.2}, {0.2, 1.0, 0.2});
    Scenario s = scenario(name, b.build(), look_at({0, 5, 6}, {0, 0, 0}, 60, 0.01),
                          {spot({0, 1.5, 0}, {0, -1, 0}, 89.5, "179 degree spot")}, o);
    return geometric(name, "lights", "a spot light with a 179 degree cone over a ground", std::move(s));
}

StressCase camera_inside(const std::string& name, const CaseOptions& o) {
    Shapes b;
    b.ground(10);
    b.box({-1, 0, -1}, {1, 2, 1});  // single-sided, outward: culled for the camera inside it
    b.box({2.0, 0, -2.5}, {2.6, 1.2, -1.9});
    Scenario s = scenario(name, b.build(), look_at({0.3, 1.2, 0.5}, {2, 0, -3}, 70, 0.01),
                          {directional(sun(40, 300), "sun")}, o);
    return geometric(name, "camera",
                     "the camera inside a closed box that casts: its walls are culled for the camera and still shadow",
                     std::move(s));
}

StressCase terrain(const std::string& name, const CaseOptions& o) {
    Shapes b;
    // 10 km of seeded rolling hills (sum of three sines), 64 x 64 quads.
    std::mt19937_64 rng(o.seed + 1);
    std::uniform_real_distribution<double> phase(0, 2 * std::numbers::pi);
    double p[3] = {phase(rng), phase(rng), phase(rng)};
    auto height = [&](double x, double z) {
        return 60 * std::sin(x / 900 + p[0]) * std::cos(z / 1100 + p[1]) + 25 * std::sin((x + z) / 310 + p[2]);
    };
    const int n = 64;
    const double half = 5000;
    auto at = [&](int i, int j) {
        double x = -half + 2 * half * i / n, z = -half + 2 * half * j / n;
        return glm::dvec3(x, height(x, z), z);
    };
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) b.quad(at(i, j + 1), at(i + 1, j + 1), at(i + 1, j), at(i, j));
    Scenario s = scenario(name, b.build(), look_at({-4000, 600, 4000}, {500, 0, -500}, 50, 1.0),
                          {directional(sun(70, 20), "sun")}, o);
    return geometric(name, "footprint", "10 km of terrain in one map: a texel covers metres", std::move(s));
}

StressCase tiny_object(const std::string& name, const CaseOptions& o) {
    Shapes b;
    b.quad({-0.01, 0, 0.01}, {0.01, 0, 0.01}, {0.01, 0, -0.01}, {-0.01, 0, -0.01});  // a 2 cm plate
    b.box({-0.004, 0, -0.003}, {0.001, 0.005, 0.002});
    b.sphere({0.005, 0.002, 0.004}, 0.002, 24, 12);
    Scenario s = scenario(name, b.build(), look_at({0.02, 0.025, 0.035}, {0, 0, 0}, 50, 1e-4),
                          {directional(sun(40, 200), "sun")}, o);
    return geometric(name, "footprint", "a 1 cm object: the whole map spans a few centimetres", std::move(s));
}

struct Entry {
    std::string name;
    std::function<StressCase(const std::string&, const CaseOptions&)> make;
};

const std::vector<Entry>& registry() {
    static const std::vector<Entry> r = {
        {"grazing_89", [](auto& n, auto& o) { return grazing(89, n, o); }},
        {"grazing_89.9", [](auto& n, auto& o) { return grazing(89.9, n, o); }},
        {"grazing_89.99", [](auto& n, auto& o) { return grazing(89.99, n, o); }},
        {"far_1e5", [](auto& n, auto& o) { return far_from_origin(1e5, n, o); }},
        {"far_1e6", [](auto& n, auto& o) { return far_from_origin(1e6, n, o); }},
        {"far_1e7", [](auto& n, auto& o) { return far_from_origin(1e7, n, o); }},
        {"far_1e8", [](auto& n, auto& o) { return far_from_origin(1e8, n, o); }},
        {"scale_1e-4", [](auto& n, auto& o) { return scaled(1e-4, n, o); }},
        {"scale_1e4", [](auto& n, auto& o) { return scaled(1e4, n, o); }},
        {"depth_range_1e5", [](auto& n, auto& o) { return depth_range(1e5, n, o); }},
        {"depth_range_1e7", [](auto& n, auto& o) { return depth_range(1e7, n, o); }},
        {"thin_occluders", thin_occluders},
        {"coplanar_decals", coplanar},
        {"contact_box", contact_box},
        {"contact_sphere", contact_sphere},
        {"contact_wedge_1deg", contact_wedge},
        {"needles", needles},
        {"t_junctions", t_junctions},
        {"point_light_touching", point_touching},
        {"point_light_inside", point_inside},
        {"spot_179", spot_wide},
        {"camera_inside_caster", camera_inside},
        {"terrain_10km", terrain},
        {"object_1cm", tiny_object},
    };
    return r;
}

}  // namespace

Scenario transformed(Scenario sc, double s, const glm::dmat3& r, const glm::dvec3& t) {
    auto place = [&](const glm::dvec3& p) { return s * (r * p) + t; };
    Bounds bounds;
    for (auto& p : sc.scene.positions) {
        p = place(p);
        bounds.grow(p);
    }
    sc.scene.bounds = bounds;
    Camera& c = sc.camera;
    c.eye = place(c.eye);
    c.forward = r * c.forward;
    c.right = r * c.right;
    c.up = r * c.up;
    c.xmag *= s;
    c.ymag *= s;
    c.znear *= s;
    c.zfar *= s;
    for (auto& l : sc.lights) {
        l.position = place(l.position);
        l.direction = r * l.direction;
        l.u = s * (r * l.u);
        l.v = s * (r * l.v);
        l.normal = r * l.normal;
        l.radius *= s;
    }
    return sc;
}

std::vector<std::string> case_names() {
    std::vector<std::string> names;
    for (const auto& e : registry()) names.push_back(e.name);
    return names;
}

std::vector<StressCase> make_cases(const std::vector<std::string>& names, const CaseOptions& options,
                                   const std::string& label) {
    for (const auto& n : names) {
        bool known = false;
        for (const auto& e : registry()) known = known || e.name == n;
        if (!known)
            throw InputError(
                fmt::format("{}: unknown case \"{}\"; the cases are {}", label, n, fmt::join(case_names(), ", ")));
    }
    std::vector<StressCase> cases;
    for (const auto& e : registry()) {
        bool wanted = names.empty();
        for (const auto& n : names) wanted = wanted || n == e.name;
        if (wanted) cases.push_back(e.make(e.name, options));
    }
    return cases;
}

}  // namespace penumbra::stress
