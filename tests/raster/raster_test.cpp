// The Vulkan raster path against analytic answers and against the oracle. Every test runs
// with the Khronos validation layer on and fails on any validation message.
#include "raster/raster.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "common/errors.h"
#include "oracle/oracle.h"
#include "tests/data_dir.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

class Raster : public ::testing::Test {
  protected:
    void SetUp() override {
        raster::ContextOptions o;
        o.validation = true;
        ctx_ = std::make_unique<raster::VulkanContext>(o);
    }
    void TearDown() override {
        if (!ctx_) return;  // SetUp failed, and said why
        EXPECT_TRUE(ctx_->validation_messages().empty())
            << ctx_->validation_messages().size() << " validation messages, first: " << ctx_->validation_messages()[0];
    }
    raster::RasterResult render(const Scenario& sc, const nlohmann::json& technique) {
        return raster::run_raster(sc, raster::parse_technique(technique, "test: technique"), *ctx_);
    }
    std::unique_ptr<raster::VulkanContext> ctx_;
};

// Pixel (x, y) lies on an edge of the oracle's image of triangles: a neighbour sees another one.
bool on_triangle_edge(const OracleFrame& f, int x, int y) {
    std::uint32_t p = f.prim[static_cast<std::size_t>(y) * f.width + x];
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
            int nx = x + dx, ny = y + dy;
            if (nx < 0 || ny < 0 || nx >= f.width || ny >= f.height) continue;
            if (f.prim[static_cast<std::size_t>(ny) * f.width + nx] != p) return true;
        }
    return false;
}

void expect_same_primitives(const OracleFrame& o, const RasterFrame& r) {
    std::size_t same = 0, off_edge = 0;
    for (int y = 0; y < o.height; ++y)
        for (int x = 0; x < o.width; ++x) {
            std::size_t i = static_cast<std::size_t>(y) * o.width + x;
            if (o.prim[i] == r.prim[i]) {
                ++same;
            } else if (!on_triangle_edge(o, x, y)) {
                ++off_edge;
            }
        }
    double agreement = static_cast<double>(same) / o.pixel_count();
    EXPECT_GE(agreement, 0.995);
    EXPECT_EQ(off_edge, 0u) << "mismatches away from triangle edges";
}

Scenario default_scenario() {
    return load_scenario(test::data_dir() / "default/scenario.json");
}

Scenario perspective_scene() {
    test::SceneBuilder b;
    b.grid({-6, 0, -6}, {0, 0, 12}, {12, 0, 0}, 8, 8);
    b.box({-1, 0, -1}, {1, 1.5, 1});
    b.box({1.5, 0.3, 0.5}, {2.5, 0.6, 2.5});
    b.triangle({-3, 0.2, 2}, {-2, 2.5, 2.5}, {-1.5, 0.2, 3}, false);
    return test::make_scenario(b.build(), test::look_at({3, 4, 7}, {0, 0.5, 0}, 50),
                               {test::directional({-0.4, -1, -0.3})}, 480, 320);
}

TEST_F(Raster, CameraPassSeesTheOraclesPrimitivesOnTheDefaultScene) {
    Scenario sc = default_scenario();
    OracleResult o = run_oracle(sc);
    raster::RasterResult r = render(sc, nlohmann::json::object());
    expect_same_primitives(o.frame, r.frame);
}

TEST_F(Raster, CameraPassSeesTheOraclesPrimitivesOnAPerspectiveScene) {
    Scenario sc = perspective_scene();
    OracleResult o = run_oracle(sc);
    raster::RasterResult r = render(sc, nlohmann::json::object());
    expect_same_primitives(o.frame, r.frame);
}

// With enough bias the technique must agree with the truth wherever the truth is not within a
// few texels of a shadow boundary: a wrong light matrix, face or cone would break this.
TEST_F(Raster, AgreesWithTheOracleAwayFromShadowBoundaries) {
    Scenario sc = default_scenario();
    OracleResult o = run_oracle(sc);
    raster::RasterResult r = render(sc, {{"bias", {{"normal_offset", 1.5}, {"slope", 1.5}}}});
    for (std::size_t li = 0; li < sc.lights.size(); ++li) {
        const auto& ol = o.frame.lights[li];
        const auto& rl = r.frame.lights[li];
        std::size_t scored = 0, agree = 0;
        for (std::size_t i = 0; i < o.frame.pixel_count(); ++i) {
            if (o.frame.prim[i] == kNoPrimitive || o.frame.prim[i] != r.frame.prim[i] || ol.U[i] != 0) continue;
            if (ol.lightable[i] == 0) {
                EXPECT_EQ(rl.V[i], 0.0f);  // back-facing or outside the cone: V = 0 in both paths
                continue;
            }
            if (ol.boundary_m[i] < 4.0f * rl.lookups->footprint_m[i] + 0.05f) continue;
            ++scored;
            agree += (rl.V[i] >= 0.5f) == (ol.V[i] >= 0.5f);
        }
        ASSERT_GT(scored, 10000u) << "light " << li;
        EXPECT_GE(static_cast<double>(agree) / scored, 0.998) << "light " << li;
    }
}

Scene plane_scene() {
    test::SceneBuilder b;
    b.quad({-10, 0, -10}, {-10, 0, 10}, {10, 0, 10}, {10, 0, -10});
    return b.build();
}

TEST_F(Raster, ZeroBiasSelfShadowsAPlaneAndSlopeBiasCuresIt) {
    double elev = 35.0 * M_PI / 180.0;
    Light sun = test::directional({std::cos(elev), -std::sin(elev), 0.3});
    Scenario sc = test::make_scenario(plane_scene(), test::look_at({0, 8, 8}, {0, 0, 0}, 50), {sun}, 320, 240);
    std::size_t dark = 0, self = 0;
    auto acne = [&](const raster::RasterResult& r) {
        std::size_t surface = 0;
        dark = self = 0;
        for (std::size_t i = 0; i < r.frame.pixel_count(); ++i) {
            if (r.frame.prim[i] == kNoPrimitive) continue;
            ++surface;
            if (r.frame.lights[0].V[i] < 1.0f) {
                ++dark;
                self += r.frame.lights[0].lookups->stored_prim[i] == r.frame.prim[i];
            }
        }
        return static_cast<double>(dark) / surface;
    };
    EXPECT_GT(acne(render(sc, {{"preset", "no-bias"}, {"resolution", 1024}})),
              0.2);  // nothing occludes the plane: all of it is acne
    // The texel that darkened the pixel holds the very triangle the camera sees.
    EXPECT_GT(static_cast<double>(self), 0.9 * static_cast<double>(dark));
    EXPECT_LT(acne(render(sc, {{"resolution", 1024}, {"bias", {{"slope", 2.0}, {"constant", 4}}}})), 1e-3);
    // Receiver-plane depth bias compares against the plane's depth at the texel centre: with
    // it a few ulps of constant bias suffice where the same constant alone changes nothing. How
    // few depends on how exactly the rasteriser interpolates depth (docs/raster.md, "Receiver-
    // plane bias per device"): lavapipe needs 1 r, an H100 16 r for d24 and d32.
    nlohmann::json tiny = {{"constant", 16}};
    EXPECT_GT(acne(render(sc, {{"preset", "no-bias"}, {"resolution", 1024}, {"bias", tiny}})), 0.4);
    tiny["receiver_plane"] = true;
    raster::RasterResult planar = render(sc, {{"preset", "no-bias"}, {"resolution", 1024}, {"bias", tiny}});
    EXPECT_LT(acne(planar), 1e-3);
}

// A thin wall on the ground, light from the side at elevation a: with a world bias b the
// receiver is moved b towards the light, so the shadow starts b cos(a) away from the wall.
TEST_F(Raster, WorldBiasDetachesAThinWallsShadowByThePredictedDistance) {
    double a = 30.0 * M_PI / 180.0, b = 0.5, h = 2.0;
    test::SceneBuilder sb;
    sb.quad({-6, 0, -6}, {-6, 0, 6}, {6, 0, 6}, {6, 0, -6});
    sb.quad({0, 0, -4}, {0, h, -4}, {0, h, 4}, {0, 0, 4});
    Light sun = test::directional({std::cos(a), -std::sin(a), 0});
    const int W = 1024;
    Scenario sc =
        test::make_scenario(sb.build(), test::look_at_ortho({2, 10, 0}, {2, 0, 0}, 4, 1, {0, 0, -1}), {sun}, W, 256);
    raster::RasterResult r = render(sc, {{"resolution", 4096}, {"cull", "none"}, {"bias", {{"world", b}}}});
    int row = 128;
    double px = 8.0 / W, first = 1e9, last = -1e9;
    for (int x = 0; x < W; ++x) {
        std::size_t i = static_cast<std::size_t>(row) * W + x;
        double wx = 2.0 - 4.0 + (x + 0.5) * px;
        if (wx > 0.0 && r.frame.lights[0].V[i] < 0.5f) {
            first = std::min(first, wx);
            last = std::max(last, wx);
        }
    }
    double texel = 0.01;  // about 12 m of scene over 4096 texels, with margin
    EXPECT_NEAR(first, b * std::cos(a), px + 2 * texel);
    EXPECT_NEAR(last, h / std::tan(a), px + 2 * texel);  // the far edge does not move
}

struct FilterCase {
    const char* name;
    nlohmann::json filter;
    double (*profile)(double s);  // V as a function of s = x / texel, edge at s = 0
};

double ramp(double s) {
    return std::clamp(s + 0.5, 0.0, 1.0);
}

const FilterCase kFilterCases[] = {
    {"none", {{"type", "none"}}, [](double s) { return s >= 0 ? 1.0 : 0.0; }},
    {"hw2x2", {{"type", "hw2x2"}}, ramp},
    {"pcf3",
     {{"type", "pcf"}, {"size", 3}},
     [](double s) {
         double v = 0;
         for (int k = -1; k <= 1; ++k) v += std::floor(s + k) >= 0 ? 1.0 : 0.0;
         return v / 3;
     }},
    {"pcf4",
     {{"type", "pcf"}, {"size", 4}},
     [](double s) {
         double v = 0;
         for (int k = 0; k < 4; ++k) v += std::floor(s + k - 1.5) >= 0 ? 1.0 : 0.0;
         return v / 4;
     }},
    {"pcf3bilinear",
     {{"type", "pcf"}, {"size", 3}, {"bilinear_taps", true}},
     [](double s) { return (ramp(s - 1) + ramp(s) + ramp(s + 1)) / 3; }},
};

// A straight shadow edge along x = 0 on a texel boundary, the light straight down: a 16 m
// ground and, over x < 0, an occluder 1 m up, single-sided and facing down (the camera above
// culls it and sees the ground; the light, culling nothing, still sees it). The orthographic
// camera frames x in [-half_width, half_width].
Scenario straight_edge_scenario(double half_width, int W, int H) {
    test::SceneBuilder sb;
    sb.quad({-8, 0, -8}, {-8, 0, 8}, {8, 0, 8}, {8, 0, -8});
    sb.quad({-8, 1, -8}, {0, 1, -8}, {0, 1, 8}, {-8, 1, 8}, false);
    return test::make_scenario(sb.build(),
                               test::look_at_ortho({0, 5, 0}, {0, 0, 0}, half_width, half_width / 4, {0, 0, -1}),
                               {test::directional({0, -1, 0})}, W, H);
}

class FilterProfile : public Raster, public ::testing::WithParamInterface<FilterCase> {};

// A straight shadow edge on a texel boundary, light straight down: each filter's V across the
// edge must follow its analytic profile.
TEST_P(FilterProfile, MatchesTheAnalyticProfileOfAStraightEdge) {
    const int W = 256, res = 64;
    const double texel = 16.0 / res;
    const Scenario sc = straight_edge_scenario(1, W, 64);
    raster::RasterResult r =
        render(sc, {{"resolution", res}, {"cull", "none"}, {"bias", {{"world", 0.05}}}, {"filter", GetParam().filter}});
    double worst = 0;
    for (int x = 0; x < W; ++x) {
        double wx = -1.0 + (x + 0.5) * (2.0 / W);
        double expected = GetParam().profile(wx / texel);
        double got = r.frame.lights[0].V[static_cast<std::size_t>(32) * W + x];
        worst = std::max(worst, std::abs(got - expected));
        if (std::abs(got - expected) > 0.01) ADD_FAILURE() << "x " << wx << " V " << got << " expected " << expected;
    }
    EXPECT_LT(worst, 0.01) << GetParam().name;
}

INSTANTIATE_TEST_SUITE_P(Raster, FilterProfile, ::testing::ValuesIn(kFilterCases),
                         [](const ::testing::TestParamInfo<FilterCase>& param_info) {
                             return std::string(param_info.param.name);
                         });

TEST_F(Raster, PoissonFilterIsBoundedBySymmetricAboutTheEdge) {
    const int W = 256, H = 64, res = 64;
    const double texel = 16.0 / res, radius = 2.0;
    const Scenario sc = straight_edge_scenario(1.5, W, H);
    raster::RasterResult r = render(sc, {{"resolution", res},
                                         {"cull", "none"},
                                         {"bias", {{"world", 0.05}}},
                                         {"filter", {{"type", "poisson"}, {"taps", 24}, {"radius_texels", radius}}}});
    double left = 0, right = 0;
    std::size_t n = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W / 2; ++x) {
            double wx = -1.5 + (x + 0.5) * (3.0 / W);  // mirror pixel: W - 1 - x
            double vl = r.frame.lights[0].V[static_cast<std::size_t>(y) * W + x];
            double vr = r.frame.lights[0].V[static_cast<std::size_t>(y) * W + (W - 1 - x)];
            if (-wx > (radius + 1) * texel) {
                EXPECT_EQ(vl, 0.0);
                EXPECT_EQ(vr, 1.0);
            }
            left += vl;
            right += vr;
            ++n;
        }
    EXPECT_NEAR((left + right) / n, 1.0, 0.05);  // V(-x) + V(x) = 1 on average
}

// three.js's PCF (docs/engines.md, "The vogel filter"): N point taps on a Vogel disk turned per
// pixel by interleaved gradient noise. Every V is a multiple of 1/N, the band is as wide as the
// disk, the noise gives neighbouring pixels different values, and the edge stays in place.
TEST_F(Raster, VogelFilterTurnsItsDiskPerPixelAndStaysCentredOnTheEdge) {
    const int W = 256, H = 64, res = 64, taps = 5;
    const double texel = 16.0 / res, radius = 2.0;
    const Scenario sc = straight_edge_scenario(1.5, W, H);
    raster::RasterResult r = render(sc, {{"resolution", res},
                                         {"cull", "none"},
                                         {"bias", {{"world", 0.05}}},
                                         {"filter", {{"type", "vogel"}, {"taps", taps}, {"radius_texels", radius}}}});
    double left = 0, right = 0;
    std::size_t n = 0, fractional = 0, differs_from_neighbour = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W / 2; ++x) {
            double wx = -1.5 + (x + 0.5) * (3.0 / W);  // mirror pixel: W - 1 - x
            double vl = r.frame.lights[0].V[static_cast<std::size_t>(y) * W + x];
            double vr = r.frame.lights[0].V[static_cast<std::size_t>(y) * W + (W - 1 - x)];
            EXPECT_NEAR(vl * taps, std::round(vl * taps), 1e-4) << "x " << x << " y " << y;
            if (-wx > (radius + 1) * texel) {
                EXPECT_EQ(vl, 0.0);
                EXPECT_EQ(vr, 1.0);
            }
            if (vl > 0 && vl < 1) ++fractional;
            if (y > 0 && vl != r.frame.lights[0].V[static_cast<std::size_t>(y - 1) * W + x]) ++differs_from_neighbour;
            left += vl;
            right += vr;
            ++n;
        }
    EXPECT_GT(fractional, 0u);
    // Along the edge (constant x) the map is the same, so only the per-pixel turn changes V.
    EXPECT_GT(differs_from_neighbour, fractional / 4);
    EXPECT_NEAR((left + right) / n, 1.0, 0.05);  // V(-x) + V(x) = 1 on average
}

// Winding conventions: single-sided surfaces seen from behind are culled for the camera, and
// "back"/"front" culling in the shadow pass drop the faces turned from/towards the light.
TEST_F(Raster, CullingFollowsTheWindingAsSeenFromCameraAndLight) {
    test::SceneBuilder sb;
    sb.quad({-8, 0, -8}, {-8, 0, 8}, {8, 0, 8}, {8, 0, -8});
    std::uint32_t up_facing = sb.quad({-1, 1, -1}, {-1, 1, 1}, {1, 1, 1}, {1, 1, -1}, false);  // normal +y
    // Light slanted along +x so that the occluder's shadow falls beside it, in view.
    Scenario sc = test::make_scenario(sb.build(), test::look_at({0, 6, 0.01}, {0, 0, 0}, 40),
                                      {test::directional({0.5, -1, 0})}, 64, 64);
    std::size_t centre = 32 * 64 + 32;
    auto shadowed_under = [&](const char* cull) {
        raster::RasterResult r = render(sc, {{"cull", cull}, {"bias", {{"world", 0.05}}}});
        return r;
    };
    raster::RasterResult back = shadowed_under("back");
    EXPECT_TRUE(back.frame.prim[centre] == up_facing || back.frame.prim[centre] == up_facing + 1);
    // The light looks at the occluder's front: back culling keeps it, front culling drops it.
    std::size_t ground_px = 0, dark_back = 0, dark_front = 0, dark_none = 0;
    raster::RasterResult front = shadowed_under("front"), none = shadowed_under("none");
    for (std::size_t i = 0; i < back.frame.pixel_count(); ++i) {
        if (back.frame.prim[i] >= 2) continue;  // the ground around the occluder only
        ++ground_px;
        dark_back += back.frame.lights[0].V[i] < 0.5f;
        dark_front += front.frame.lights[0].V[i] < 0.5f;
        dark_none += none.frame.lights[0].V[i] < 0.5f;
    }
    ASSERT_GT(ground_px, 0u);
    EXPECT_EQ(dark_front, 0u);
    EXPECT_GT(dark_back, 0u);
    EXPECT_EQ(dark_back, dark_none);

    // Seen from below, the single-sided quad disappears for the camera.
    Scenario below = test::make_scenario(sc.scene, test::look_at({0, -6, 0.01}, {0, 0, 0}, 40),
                                         {test::directional({0, -1, 0})}, 64, 64);
    raster::RasterResult r = render(below, nlohmann::json::object());
    EXPECT_TRUE(r.frame.prim[centre] < 2u) << "sees the ground (double-sided), not the single-sided quad";
}

TEST_F(Raster, PointLightRendersOnlyTheCubeFacesThatReceiversSample) {
    test::SceneBuilder sb;
    sb.quad({-10, 0, -10}, {-10, 0, 10}, {10, 0, 10}, {10, 0, -10});
    sb.box({-0.5, 0, -0.5}, {0.5, 1, 0.5});
    Light lamp = test::point({0.3, 3, 0.2});
    Scenario sc = test::make_scenario(sb.build(), test::look_at({0, 12, 0.5}, {0, 0, 0}, 30), {lamp}, 256, 256);
    OracleResult o = run_oracle(sc);
    raster::RasterResult r = render(sc, {{"resolution", 1024}, {"bias", {{"normal_offset", 1.5}, {"slope", 1.0}}}});
    const auto& st = r.stats.lights[0];
    EXPECT_FALSE(st.layers_sampled & (1u << 2)) << "+Y sees nothing the camera sees";
    EXPECT_TRUE(st.layers_sampled & (1u << 3)) << "-Y looks at the ground under the lamp";
    EXPECT_LT(st.layers_rendered, 6);
    std::size_t scored = 0, agree = 0;
    for (std::size_t i = 0; i < o.frame.pixel_count(); ++i) {
        const auto& ol = o.frame.lights[0];
        if (o.frame.prim[i] != r.frame.prim[i] || o.frame.prim[i] == kNoPrimitive || ol.U[i] != 0 ||
            ol.lightable[i] == 0 || ol.boundary_m[i] < 4 * r.frame.lights[0].lookups->footprint_m[i] + 0.02f)
            continue;
        ++scored;
        agree += (r.frame.lights[0].V[i] >= 0.5f) == (ol.V[i] >= 0.5f);
    }
    ASSERT_GT(scored, 20000u);
    EXPECT_GE(static_cast<double>(agree) / scored, 0.999);
}

TEST_F(Raster, FarFromTheOriginGivesTheSameVerdicts) {
    Scenario a = perspective_scene(), b = perspective_scene();
    glm::dvec3 shift(3e6, -2e6, 1e6);
    for (auto& p : b.scene.positions) p += shift;
    b.scene.bounds.lo += shift;
    b.scene.bounds.hi += shift;
    b.camera.eye += shift;
    nlohmann::json t = {{"bias", {{"normal_offset", 1.0}, {"slope", 1.0}}}};
    raster::RasterResult ra = render(a, t), rb = render(b, t);
    std::size_t same_prim = 0, same_v = 0;
    for (std::size_t i = 0; i < ra.frame.pixel_count(); ++i) {
        same_prim += ra.frame.prim[i] == rb.frame.prim[i];
        same_v += ra.frame.lights[0].V[i] == rb.frame.lights[0].V[i];
    }
    EXPECT_GE(static_cast<double>(same_prim) / ra.frame.pixel_count(), 0.999);
    EXPECT_GE(static_cast<double>(same_v) / ra.frame.pixel_count(), 0.995);
}

TEST_F(Raster, PresetsRunAndRecordWhichBilinearCompareRan) {
    for (const auto& p : raster::presets()) {
        Scenario sc = perspective_scene();
        // PCSS needs a light with a size: its preset draws a rect light (emitting down).
        if (p.name == "pcss") sc.lights = {test::rect({0, 5, 0}, {1, 0, 0}, {0, 0, 1})};
        // The presets of references 000/002 and the engines whose filters take 2x2 bilinear compares.
        const raster::Technique t = raster::parse_technique(nlohmann::json{{"preset", p.name}}, p.name);
        // Cascades without a max_distance end at the camera's zfar, which must then be finite.
        if (t.family == "cascaded") sc.camera.zfar = 200;
        raster::RasterResult r = render(sc, {{"preset", p.name}});
        const bool bilinear = t.filter.type == raster::FilterType::hw2x2 ||
                              (t.filter.bilinear_taps && t.filter.type != raster::FilterType::none &&
                               t.filter.type != raster::FilterType::pcss);
        if (p.name == "d3d12-textbook" || p.name == "diligent-tutorial13" || p.name == "three") {
            EXPECT_TRUE(bilinear) << p.name;
        }
        EXPECT_EQ(r.stats.hw2x2 == "unused", !bilinear) << p.name;
        // Shadow volumes and planar projection draw no map: planar's one pass is the stencil.
        if (p.name == "rtr-planar") {
            EXPECT_GT(r.stats.lights[0].gpu_ms["stencil"], 0.0);
        } else if (r.stats.family != "shadow_volume") {
            EXPECT_GT(r.stats.lights[0].layers_rendered, 0) << p.name;
        }
    }
}

TEST_F(Raster, LightsWithoutReceiversAndAbsentLightsCostNoPasses) {
    Scenario sc = perspective_scene();
    sc.lights.clear();
    raster::RasterResult r = render(sc, nlohmann::json::object());
    EXPECT_TRUE(r.frame.lights.empty());
    EXPECT_GT(std::count(r.frame.A.begin(), r.frame.A.end(), 1.0f), 0);
    // A point light under the ground faces no receiver the camera sees: no face is rendered.
    sc.lights = {test::point({0, -5, 0})};
    r = render(sc, nlohmann::json::object());
    EXPECT_EQ(r.stats.lights[0].layers_rendered, 0);
}

// The library refuses PCSS on a light without a size too, whoever parsed the technique.
TEST_F(Raster, PcssOnALightWithoutASizeIsBadInput) {
    Scenario sc = perspective_scene();
    sc.lights = {test::directional({-0.3, -1, -0.2})};
    EXPECT_THROW(render(sc, {{"filter", {{"type", "pcss"}}}}), InputError);
}

TEST_F(Raster, AreaLightsAreDrawnFromTheirCentreOrFromPointsSpreadOverThem) {
    Scenario sc = perspective_scene();
    sc.lights = {test::rect({0, 5, 0}, {1, 0, 0}, {0, 0, 1})};  // emits down
    raster::RasterResult centre = render(sc, {{"preset", "pcss"}});
    ASSERT_EQ(centre.frame.lights.size(), 1u);
    EXPECT_GT(centre.stats.lights[0].layers_rendered, 0);
    raster::RasterResult averaged = render(sc, {{"preset", "averaged-hard-shadows"}, {"area_samples", 4}});
    ASSERT_EQ(averaged.frame.lights.size(), 1u) << "the drawn points fold back into one light";
    EXPECT_GE(averaged.stats.lights[0].layers_rendered, 4 * centre.stats.lights[0].layers_rendered / 2);
    // Averaging hard verdicts of 4 points gives multiples of 1/4 only.
    for (float v : averaged.frame.lights[0].V) {
        const float k = v * 4.0f;
        ASSERT_NEAR(k, std::round(k), 1e-5f);
    }
}

// V of an averaged light is the mean of N points; one point's lookups would classify it as if
// that point alone had drawn it. Such a light has no lookup layer (the metrics then classify it
// from V); a light drawn once keeps its lookups.
TEST_F(Raster, AnAveragedAreaLightHasNoOneSamplesLookups) {
    Scenario sc = perspective_scene();
    sc.lights.push_back(test::rect({0, 5, 0}, {1, 0, 0}, {0, 0, 1}));
    const raster::RasterResult averaged = render(sc, {{"preset", "averaged-hard-shadows"}, {"area_samples", 4}});
    ASSERT_EQ(averaged.frame.lights.size(), 2u);
    EXPECT_TRUE(averaged.frame.lights[0].lookups.has_value()) << "the sun is drawn once";
    EXPECT_FALSE(averaged.frame.lights[1].lookups.has_value()) << "the rect light is the mean of 4 points";
    const raster::RasterResult centre = render(sc, {{"bias", {{"slope", 1.5}}}});
    EXPECT_TRUE(centre.frame.lights[1].lookups.has_value()) << "drawn once from its centre";
}

// Per-light bias: a render with `lights: [{bias A}, {bias B}]` gives light 0 what the shared bias A
// gives it and light 1 what the shared bias B gives it, bit for bit; area lights drawn as
// several points carry their light's override to each.
TEST_F(Raster, EachLightIsDrawnWithItsOwnBias) {
    Scenario sc = perspective_scene();
    sc.width = 240;
    sc.height = 160;
    sc.lights = {test::directional({-0.4, -1, -0.3}), test::point({0.5, 3, 1.5})};
    const nlohmann::json a = {{"constant", 2}, {"slope", 0.2}, {"normal_offset", 0.5}};
    const nlohmann::json b = {{"constant", 20000}, {"slope", 3.0}, {"world", 0.05}};
    const nlohmann::json base = {{"resolution", 512}, {"depth_format", "d24"}};
    auto with = [&](nlohmann::json extra) {
        nlohmann::json t = base;
        t.merge_patch(extra);
        return render(sc, t);
    };
    const raster::RasterResult shared_a = with({{"bias", a}}), shared_b = with({{"bias", b}});
    const raster::RasterResult own = with({{"lights", {{{"bias", a}}, {{"bias", b}}}}});
    // The two biases differ where it shows: else the test could not tell them apart.
    ASSERT_NE(shared_a.frame.lights[0].V, shared_b.frame.lights[0].V);
    ASSERT_NE(shared_a.frame.lights[1].V, shared_b.frame.lights[1].V);
    EXPECT_EQ(own.frame.lights[0].V, shared_a.frame.lights[0].V);
    EXPECT_EQ(own.frame.lights[1].V, shared_b.frame.lights[1].V);
    EXPECT_EQ(own.frame.lights[0].lookups->bias_m, shared_a.frame.lights[0].lookups->bias_m);
    EXPECT_EQ(own.frame.lights[1].lookups->bias_m, shared_b.frame.lights[1].lookups->bias_m);
    // A partial override keeps the shared keys it does not name.
    const raster::RasterResult partial = with({{"bias", b}, {"lights", {{{"bias", a}}, nlohmann::json::object()}}});
    EXPECT_EQ(partial.frame.lights[1].V, shared_b.frame.lights[1].V);

    sc.lights = {test::rect({0, 5, 0}, {1, 0, 0}, {0, 0, 1}), test::directional({-0.4, -1, -0.3})};
    const nlohmann::json averaged = {{"resolution", 512}, {"area_samples", 4}};
    auto avg = [&](nlohmann::json extra) {
        nlohmann::json t = averaged;
        t.merge_patch(extra);
        return render(sc, t);
    };
    const raster::RasterResult avg_a = avg({{"bias", a}}), avg_b = avg({{"bias", b}});
    const raster::RasterResult avg_own = avg({{"lights", {{{"bias", b}}, {{"bias", a}}}}});
    EXPECT_EQ(avg_own.frame.lights[0].V, avg_b.frame.lights[0].V);
    EXPECT_EQ(avg_own.frame.lights[1].V, avg_a.frame.lights[1].V);
}

// Two frames are the same bit for bit: V and every lookup channel.
void expect_identical(const RasterFrame& a, const RasterFrame& b, const std::string& what) {
    ASSERT_EQ(a.lights.size(), b.lights.size()) << what;
    EXPECT_EQ(a.prim, b.prim) << what;
    for (std::size_t li = 0; li < a.lights.size(); ++li) {
        const RasterLightImage &x = a.lights[li], &y = b.lights[li];
        EXPECT_EQ(std::memcmp(x.V.data(), y.V.data(), x.V.size() * sizeof(float)), 0) << what << ": light " << li;
        ASSERT_EQ(x.lookups.has_value(), y.lookups.has_value()) << what;
        if (!x.lookups) continue;
        EXPECT_EQ(x.lookups->stored_prim, y.lookups->stored_prim) << what;
        EXPECT_EQ(x.lookups->flags, y.lookups->flags) << what;
        for (auto field : {&DepthMapLookups::ref_depth, &DepthMapLookups::stored_depth, &DepthMapLookups::footprint_m,
                           &DepthMapLookups::texel_slope, &DepthMapLookups::bias_m, &DepthMapLookups::depth_to_m}) {
            const auto &u = *x.lookups.*field, &v = *y.lookups.*field;
            EXPECT_EQ(std::memcmp(u.data(), v.data(), u.size() * sizeof(float)), 0) << what << ": light " << li;
        }
    }
}

// A warm session gives what a cold run gives, whatever came before it: every kind of change in
// turn (a lookup-only bias, a hardware bias, the map's size and format, filters, culling, the
// light kinds of both families), and back again.
TEST_F(Raster, AWarmSessionRendersEveryTechniqueAsAColdRunDoes) {
    Scenario sc = perspective_scene();
    sc.width = 240;  // the same view at half the size: 16 renders under the validation layer
    sc.height = 160;
    sc.lights.push_back(test::point({1.0, 3.0, 1.5}));
    sc.lights.push_back(test::rect({-1, 4, 0}, {1, 0, 0}, {0, 0, 1}));
    const std::vector<nlohmann::json> sequence = {
        {{"bias", {{"slope", 1.5}}}},
        {{"bias", {{"slope", 1.5}, {"world", 0.02}}}},
        {{"bias", {{"slope", 2.5}, {"constant", 4}}}},
        {{"resolution", 512}, {"depth_format", "d16"}, {"bias", {{"slope", 1.5}}}},
        {{"filter", {{"type", "pcf"}, {"size", 5}}}, {"cull", "none"}},
        {{"preset", "averaged-hard-shadows"}, {"area_samples", 3}},
        {{"filter", {{"type", "poisson"}}}, {"bias", {{"receiver_plane", true}, {"normal_offset", 1}}}},
        {{"family", "cascaded"}, {"resolution", 512}, {"cascades", {{"count", 3}, {"max_distance", 20}}}},
        {{"family", "cascaded"},
         {"filter", {{"type", "pcf"}}},
         {"cascades", {{"split", "uniform"}, {"max_distance", 15}, {"overlap", 0.3}, {"fit", "bounds"}}}},
        {{"family", "shadow_volume"}},
        {{"family", "shadow_volume"}, {"shadow_volume", {{"open_meshes", "include"}, {"method", "zpass"}}}},
        {{"preset", "rtr-midpoint"}, {"resolution", 512}},
        {{"depth_layer", "midpoint"}, {"bias", {{"slope", 1.5}}}},
        {{"depth_layer", "second"}},
        {{"preset", "rtr-planar"}},
        {{"bias", {{"slope", 1.5}}}},
    };
    raster::RasterSession session(sc, *ctx_);
    for (const auto& t : sequence) {
        const raster::Technique technique = raster::parse_technique(t, "test: technique");
        expect_identical(session.render(technique).frame, render(sc, t).frame, t.dump());
    }
    // A lookup-only change reuses the map that is still in place; with reuse off it is drawn.
    Scenario one = perspective_scene();
    raster::RasterSession single(one, *ctx_);
    const raster::Technique a = raster::parse_technique({{"bias", {{"slope", 1.5}}}}, "a");
    const raster::Technique b = raster::parse_technique({{"bias", {{"slope", 1.5}, {"world", 0.05}}}}, "b");
    EXPECT_FALSE(single.render(a).stats.lights[0].map_reused);
    const raster::RasterResult reused = single.render(b);
    EXPECT_TRUE(reused.stats.lights[0].map_reused);
    EXPECT_EQ(reused.stats.lights[0].layers_rendered, 0);
    expect_identical(reused.frame, render(one, {{"bias", {{"slope", 1.5}, {"world", 0.05}}}}).frame, "reused map");
    raster::RenderOptions fresh;
    fresh.reuse_maps = false;
    EXPECT_FALSE(single.render(b, fresh).stats.lights[0].map_reused);
    // V only: the same V, no lookup layer.
    raster::RenderOptions v_only;
    v_only.lookups = false;
    const raster::RasterResult v = single.render(b, v_only);
    EXPECT_FALSE(v.frame.lights[0].lookups.has_value());
    EXPECT_EQ(v.frame.lights[0].V, reused.frame.lights[0].V);
    const raster::Technique plane = raster::parse_technique(
        {{"bias", {{"receiver_plane", true}, {"slope", 1}}}, {"filter", {{"type", "pcf"}, {"size", 3}}}}, "plane");
    EXPECT_EQ(single.render(plane, v_only).frame.lights[0].V, single.render(plane).frame.lights[0].V)
        << "V alone is the V of the full lookup (receiver plane, PCF)";
    const raster::Technique blended = raster::parse_technique(
        {{"family", "cascaded"}, {"cascades", {{"max_distance", 15}, {"overlap", 0.4}}}}, "blended");
    EXPECT_EQ(single.render(blended, v_only).frame.lights[0].V, single.render(blended).frame.lights[0].V)
        << "V alone is the V of the full lookup (cascades blended across their overlap)";
}

// A sun whose map covers only the near view, drawn with a point light beside it: every lookup
// outside the sun's map reads as lit, with the 2x2 compare filter too. With one compare sampler
// for every light, clamped to the edge for the point light's sake, a device that filters depth
// read the map's edge texel there instead (never lavapipe, which emulates the filter): the
// light travels away from the camera, so receivers beyond the map lie deeper than its far edge
// and an edge read shadows them.
TEST_F(Raster, ALookupOutsideADirectionalMapIsLitBesideAPointLight) {
    test::SceneBuilder b;
    b.quad({-4, 0, -40}, {-4, 0, 4}, {4, 0, 4}, {4, 0, -40});
    for (int k = 0; k < 6; ++k) b.box({-1, 0, -6.0 * k - 1}, {1, 1.5, -6.0 * k + 1});
    Scenario sc = test::make_scenario(b.build(), test::look_at({0, 3, 6}, {0, 0, -20}, 50),
                                      {test::directional({0.3, -1, -0.4}), test::point({0, 4, 2})}, 240, 160);
    raster::RasterResult r =
        render(sc, {{"fit", "camera_frustum"}, {"shadow_distance", 7.0}, {"filter", {{"type", "hw2x2"}}}});
    const RasterLightImage& sun = r.frame.lights[0];
    const int W = sc.width, H = sc.height;
    auto in_map = [&](int x, int y) {
        const std::uint32_t f = sun.lookups->flags[static_cast<std::size_t>(y) * W + x];
        return (f & kRasterSurface) && !(f & kRasterOutsideMap);
    };
    // Pixels a few pixels away from the map's edge: a 2x2 filter at the edge legitimately
    // reaches one texel into the map.
    std::size_t outside = 0, dark = 0;
    for (int y = 3; y < H - 3; ++y)
        for (int x = 3; x < W - 3; ++x) {
            const std::uint32_t f = sun.lookups->flags[static_cast<std::size_t>(y) * W + x];
            if (!(f & kRasterOutsideMap) || (f & kRasterBackFacing)) continue;
            bool near_edge = false;
            for (int dy = -3; dy <= 3 && !near_edge; ++dy)
                for (int dx = -3; dx <= 3 && !near_edge; ++dx) near_edge = in_map(x + dx, y + dy);
            if (near_edge) continue;
            ++outside;
            dark += sun.V[static_cast<std::size_t>(y) * W + x] < 1.0f;
        }
    EXPECT_GT(outside, 300u) << "the view reaches beyond the sun's map";
    EXPECT_EQ(dark, 0u) << "lookups outside the sun's map must read the lit border (hw2x2 " << r.stats.hw2x2 << ")";
}

// The whole scenario moved by t: the camera sees the same image.
Scenario moved(Scenario sc, const glm::dvec3& t) {
    Bounds b;
    for (auto& p : sc.scene.positions) b.grow(p += t);
    sc.scene.bounds = b;
    sc.camera.eye += t;
    for (auto& l : sc.lights) l.position += t;
    return sc;
}

std::size_t differing_pixels(const raster::RasterResult& a, const raster::RasterResult& b) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < a.frame.lights[0].V.size(); ++i) n += a.frame.lights[0].V[i] != b.frame.lights[0].V[i];
    return n;
}

// technique.precision (docs/raster.md): camera_relative is the default, and a session that
// switches to world_float32 and back draws the same bits as before.
TEST_F(Raster, CameraRelativePrecisionIsTheDefaultAndBitIdenticalAcrossPrecisionSwitches) {
    Scenario sc = moved(perspective_scene(), {3e6, 0, -2e6});
    raster::RasterSession session(sc, *ctx_);
    const auto plain = session.render(raster::parse_technique(nlohmann::json::object(), "test"));
    const auto relative = raster::parse_technique({{"precision", "camera_relative"}}, "test");
    const auto world = raster::parse_technique({{"precision", "world_float32"}}, "test");
    EXPECT_EQ(raster::parse_technique(nlohmann::json::object(), "test").to_json().at("precision"), "camera_relative");
    const auto a = session.render(relative);
    const auto w = session.render(world);
    const auto b = session.render(relative);
    for (const auto* r : {&a, &b}) {
        EXPECT_EQ(r->frame.prim, plain.frame.prim);
        EXPECT_EQ(r->frame.lights[0].V, plain.frame.lights[0].V);
        EXPECT_EQ(r->frame.lights[0].lookups->ref_depth, plain.frame.lights[0].lookups->ref_depth);
        EXPECT_EQ(r->frame.lights[0].lookups->stored_depth, plain.frame.lights[0].lookups->stored_depth);
    }
    EXPECT_GT(differing_pixels(a, w), 0u) << "3.6e6 m from the origin, float32 world positions must show";
}

// world_float32 renders as an engine with float32 world positions and matrices: the same as
// camera_relative at the origin (but for a few pixels on edges), far from it visibly different,
// while camera_relative far from the origin stays as it was at the origin (godot #72015).
TEST_F(Raster, WorldFloat32PrecisionDiffersFarFromTheOriginAndNotAtIt) {
    // Without bias, where every lit texel compares against its own triangle's depth, so that
    // float32's rounding shows in the verdicts.
    const nlohmann::json relative = {{"preset", "no-bias"}, {"precision", "camera_relative"}},
                         world = {{"preset", "no-bias"}, {"precision", "world_float32"}};
    const Scenario near = perspective_scene(), far = moved(perspective_scene(), {1e7, 0, -1e7});
    const auto near_rel = render(near, relative), near_world = render(near, world);
    const auto far_rel = render(far, relative), far_world = render(far, world);
    std::size_t surface = 0;
    for (float a : near_rel.frame.A) surface += a != 0;
    ASSERT_GT(surface, 50000u);
    EXPECT_LT(differing_pixels(near_rel, near_world), surface / 200);
    EXPECT_LT(differing_pixels(near_rel, far_rel), surface / 200);
    EXPECT_GT(differing_pixels(far_rel, far_world), surface / 20);
}

// Contexts one after another each find their device: the driver stays loaded between them.
// NVIDIA's takes static TLS on every load that glibc never returns, and the 30th context of a
// process found no driver (raster/vulkan_context.cpp, keep_driver_loaded).
TEST(VulkanContexts, FortyInARowEachFindTheirDevice) {
    for (int i = 0; i < 40; ++i) {
        raster::ContextOptions o;
        o.validation = true;
        try {
            raster::VulkanContext ctx(o);
        } catch (const std::exception& e) {
            FAIL() << "context " << i << ": " << e.what();
        }
    }
}

// A technique the device refuses, with a new precision, leaves the session as it was: the next
// render finds its scene and maps in place and draws what a cold run draws.
TEST_F(Raster, ARefusedTechniqueLeavesTheSessionAsItWas) {
    Scenario sc = moved(perspective_scene(), {3e6, 0, -2e6});
    raster::RasterSession session(sc, *ctx_);
    const nlohmann::json relative = {{"bias", {{"slope", 1.5}}}};
    const raster::Technique technique = raster::parse_technique(relative, "test");
    session.render(technique);
    raster::Technique refused = raster::parse_technique({{"precision", "world_float32"}}, "test");
    refused.resolution = static_cast<int>(ctx_->limits().maxImageDimension2D) + 1;
    EXPECT_THROW(session.render(refused), InputError);
    const raster::RasterResult again = session.render(technique);
    EXPECT_TRUE(again.stats.lights[0].map_reused) << "the refused precision replaced the scene and its maps";
    expect_identical(again.frame, render(sc, relative).frame, "after a refused technique");
    const nlohmann::json world = {{"precision", "world_float32"}};
    expect_identical(session.render(raster::parse_technique(world, "test")).frame, render(sc, world).frame,
                     "world_float32 after a refused technique");
}

// Every light keeps its own map: a change the maps do not depend on (a world bias) draws no
// shadow pass for any light, sun, spot, point or an averaged area light's samples, and gives
// what a cold run gives.
TEST_F(Raster, EveryLightKeepsItsMapAcrossALookupOnlyChange) {
    Scenario sc = perspective_scene();
    sc.width = 240;
    sc.height = 160;
    sc.lights.push_back(test::spot({-3, 5, 3}, {0.5, -1, -0.5}, 40));
    sc.lights.push_back(test::point({1.0, 3.0, 1.5}));
    sc.lights.push_back(test::rect({-1, 4, 0}, {1, 0, 0}, {0, 0, 1}));
    for (const int samples : {0, 3}) {
        const nlohmann::json a = {{"resolution", 512}, {"area_samples", samples}, {"bias", {{"slope", 1.5}}}};
        nlohmann::json b = a;
        b["bias"]["world"] = 0.02;
        raster::RasterSession session(sc, *ctx_);
        const raster::RasterResult first = session.render(raster::parse_technique(a, "a"));
        const raster::RasterResult second = session.render(raster::parse_technique(b, "b"));
        ASSERT_EQ(second.stats.lights.size(), sc.lights.size());
        for (std::size_t li = 0; li < sc.lights.size(); ++li) {
            EXPECT_FALSE(first.stats.lights[li].map_reused) << "light " << li;
            EXPECT_TRUE(second.stats.lights[li].map_reused) << "area_samples " << samples << ", light " << li;
            EXPECT_EQ(second.stats.lights[li].layers_rendered, 0) << "area_samples " << samples << ", light " << li;
        }
        expect_identical(second.frame, render(sc, b).frame, b.dump());
    }
}

// Buffers and maps are sub-allocated: 3 area lights of 256 samples each (768 drawn lights, 4
// to 6 buffers each) stay far below the 4096 allocations Vulkan guarantees.
TEST_F(Raster, ManyAreaSamplesTakeAFewMemoryAllocations) {
    Scenario sc = perspective_scene();
    sc.width = 64;
    sc.height = 48;
    sc.lights = {test::rect({-1, 4, 0}, {1, 0, 0}, {0, 0, 1}), test::rect({1, 4, 0}, {1, 0, 0}, {0, 0, 1}),
                 test::rect({0, 5, 1}, {1, 0, 0}, {0, 0, 1})};
    raster::RasterSession session(sc, *ctx_);
    const std::uint64_t before = ctx_->memory_allocations();
    const raster::RasterResult r = session.render(raster::parse_technique(
        {{"resolution", 64}, {"area_samples", 256}, {"bias", {{"slope", 1.5}, {"constant", 8}}}}, "many"));
    const std::uint64_t allocations = ctx_->memory_allocations() - before;
    EXPECT_LE(allocations, 32u);
    ASSERT_EQ(r.frame.lights.size(), 3u);
    for (const RasterLightImage& img : r.frame.lights) {
        // The mean of 256 hard verdicts: multiples of 1/256.
        for (float v : img.V) ASSERT_NEAR(v * 256.0f, std::round(v * 256.0f), 1e-3f);
        EXPECT_GT(std::count_if(img.V.begin(), img.V.end(), [](float v) { return v > 0 && v < 1; }), 0);
    }
}

// A production render (V alone) draws depth-only maps, the pass an engine draws, and gets the
// diagnostic render's V bit for bit: the same vertex shader, depth bias and rasterisation store
// the same depths. A depth-only map holds no triangle ids, so a render with lookups after it
// draws the map again; a map with ids serves a V-only render as it is.
TEST_F(Raster, AProductionRenderDrawsDepthOnlyMapsWithTheDiagnosticRendersV) {
    Scenario sc = default_scenario();  // sun, spot and point light
    sc.width = 320;
    sc.height = 180;
    const std::vector<nlohmann::json> techniques = {
        {{"preset", "d3d12-textbook"}},
        {{"resolution", 512}, {"bias", {{"constant", 0}, {"slope", 0}}}},  // no bias: acne in V
        {{"resolution", 1024}, {"depth_format", "d16"}, {"bias", {{"constant", 6}, {"slope", 2.5}}}},
        {{"filter", {{"type", "hw2x2"}}}, {"cull", "front"}},
        {{"filter", {{"type", "pcf"}, {"size", 5}}}, {"bias", {{"receiver_plane", true}, {"normal_offset", 1}}}},
        {{"filter", {{"type", "poisson"}}}, {"cull", "none"}, {"depth_format", "d24"}},
    };
    raster::RenderOptions production, diagnostic;
    production.lookups = false;
    production.reuse_maps = diagnostic.reuse_maps = false;
    raster::RasterSession session(sc, *ctx_);
    for (const auto& j : techniques) {
        const raster::Technique t = raster::parse_technique(j, "test: technique");
        const raster::RasterResult v = session.render(t, production);
        const raster::RasterResult full = session.render(t, diagnostic);
        ASSERT_EQ(v.frame.lights.size(), 3u);
        for (std::size_t li = 0; li < 3; ++li) {
            EXPECT_FALSE(v.stats.lights[li].map_triangle_ids) << j.dump() << ", light " << li;
            EXPECT_TRUE(full.stats.lights[li].map_triangle_ids) << j.dump() << ", light " << li;
            const std::vector<float>&a = v.frame.lights[li].V, &b = full.frame.lights[li].V;
            ASSERT_EQ(a.size(), b.size());
            EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)), 0) << j.dump() << ", light " << li;
        }
        EXPECT_NE(v.stats.gpu_ms.what("shadow"), full.stats.gpu_ms.what("shadow"));
    }
    // Reuse: a depth-only map is drawn again for the lookups (their stored triangle ids as a
    // cold run's); a map with ids is reused by a V-only render.
    const nlohmann::json j = {{"bias", {{"slope", 1.5}}}};
    const raster::Technique t = raster::parse_technique(j, "test: technique");
    raster::RenderOptions v_only;
    v_only.lookups = false;
    raster::RasterSession warm(sc, *ctx_);
    warm.render(t, v_only);
    const raster::RasterResult after_v = warm.render(t);
    for (std::size_t li = 0; li < 3; ++li) EXPECT_FALSE(after_v.stats.lights[li].map_reused) << "light " << li;
    expect_identical(after_v.frame, render(sc, j).frame, "lookups after a V-only render");
    const raster::RasterResult v_again = warm.render(t, v_only);
    for (std::size_t li = 0; li < 3; ++li) {
        EXPECT_TRUE(v_again.stats.lights[li].map_reused) << "light " << li;
        EXPECT_TRUE(v_again.stats.lights[li].map_triangle_ids) << "light " << li;
    }
    EXPECT_EQ(v_again.frame.lights[0].V, after_v.frame.lights[0].V);
}

}  // namespace
}  // namespace penumbra
