// validate over a camera path (issue #34, "Time: shimmer"): every frame traced and drawn with one
// oracle BVH and one raster session, and the flicker that cascade stabilisation exists to cure.
#include "pipeline/camera_path.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>

#include "oracle/oracle.h"
#include "tests/metrics/synthetic_frames.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

// The long view of the cascade tests: a 300 m ground with boxes and posts, the camera near it.
Scene long_view() {
    test::SceneBuilder b;
    b.grid({-40, 0, 0}, {80, 0, 0}, {0, 0, -300}, 4, 30);
    for (int k = 0; k < 40; ++k) {
        const double z = -3.0 - 7.0 * k, x = (k % 2 ? -1.0 : 1.0) * (1.5 + (k * 7) % 9);
        b.box({x - 0.8, 0, z - 0.8}, {x + 0.8, 1.2 + 0.05 * (k % 7), z + 0.8});
        b.box({x - 0.1, 0, z + 1.5}, {x + 0.1, 2.5, z + 1.7});
    }
    return b.build();
}

CameraKey key(glm::dvec3 eye, glm::dvec3 target) {
    CameraKey k;
    k.camera = test::look_at(eye, target, 50);
    k.camera.znear = 0.1;
    k.camera.zfar = 300;
    k.target = target;
    return k;
}

// A slow sideways pan: 1.5 m over `frames` frames, the view direction fixed.
Scenario panning(int frames, int width, int height) {
    CameraPath path;
    path.frames = frames;
    path.keys = {key({0, 1.7, 2}, {0, 1.0, -60}), key({1.5, 1.7, 2}, {1.5, 1.0, -60})};
    Scenario sc =
        test::make_scenario(long_view(), path.keys[0].camera, {test::directional({0.5, -0.6, -0.3})}, width, height);
    sc.camera_path = path;
    return sc;
}

ValidateOptions no_cache() {
    ValidateOptions o;
    o.use_cache = false;
    return o;
}

raster::Technique cascaded(bool stabilize) {
    return raster::parse_technique({{"family", "cascaded"},
                                    {"resolution", 512},
                                    {"cascades", {{"count", 4}, {"max_distance", 300}, {"stabilize", stabilize}}}},
                                   "test: technique");
}

// Issue #34's "done when": over a slow pan of 30 frames, stabilised cascades flicker at most a
// fifth as much as unstabilised ones; the oracle's BVH is built once for all the frames.
TEST(CameraPath, StabilizedCascadesFlickerAFifthAsMuchOverASlowPan) {
    const Scenario sc = panning(30, 320, 180);
    double rate[2] = {0, 0};
    for (bool stabilize : {false, true}) {
        const auto t0 = std::chrono::steady_clock::now();
        const CameraPathResult r = validate_camera_path(sc, cascaded(stabilize), metrics::Gate{}, no_cache());
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        EXPECT_EQ(r.frames, 30);
        EXPECT_EQ(r.bvh_builds, 1);
        const nlohmann::json& t = r.last.report.at("lights")[0].at("temporal");
        EXPECT_EQ(t.at("frames"), 30);
        EXPECT_EQ(t.at("pairs"), 29);
        EXPECT_EQ(t.at("per_frame").size(), 30u);
        // Most of each frame's surface is seen by the one before.
        EXPECT_GT(t.at("points").get<std::uint64_t>(), 29u * 320 * 180 / 3);
        rate[stabilize] = t.at("flicker_rate").get<double>();
        std::fprintf(stderr, "stabilize %s: flicker_rate %.6f (%llu of %llu points), %.1f s\n",
                     stabilize ? "on" : "off", rate[stabilize],
                     static_cast<unsigned long long>(t.at("flicker_pixels").get<std::uint64_t>()),
                     static_cast<unsigned long long>(t.at("points").get<std::uint64_t>()), seconds);
    }
    EXPECT_GT(rate[0], 1e-3);  // unstabilised cascades do shimmer here
    EXPECT_LE(rate[1], rate[0] / 5);
}

// The oracle of a path: one BVH, in the first frame's local frame, traced from later cameras,
// gives what a fresh oracle of a scenario with that camera gives.
TEST(CameraPath, OneBvhTracesEveryFrameAsAFreshOracleWould) {
    const Scenario sc = panning(5, 96, 64);
    OracleSession session(sc);
    for (int f : {0, 4}) {
        const Camera cam = path_camera(*sc.camera_path, f).value();
        const OracleResult shared = session.trace(cam);
        Scenario alone = sc;
        alone.camera = cam;
        const OracleResult fresh = run_oracle(alone);
        ASSERT_EQ(shared.frame.pixel_count(), fresh.frame.pixel_count());
        std::size_t same_prim = 0, same_v = 0, surface = 0;
        for (std::size_t i = 0; i < fresh.frame.pixel_count(); ++i) {
            surface += fresh.frame.A[i] != 0;
            same_prim += shared.frame.prim[i] == fresh.frame.prim[i];
            same_v += shared.frame.lights[0].V[i] == fresh.frame.lights[0].V[i];
            // The same world point, whichever local frame it was found in.
            if (fresh.frame.A[i] != 0 && shared.frame.A[i] != 0 && shared.frame.prim[i] == fresh.frame.prim[i]) {
                ASSERT_LT(glm::length(shared.frame.frame_origin + glm::dvec3(shared.frame.P[i]) -
                                      fresh.frame.frame_origin - glm::dvec3(fresh.frame.P[i])),
                          1e-3)
                    << "frame " << f << " pixel " << i;
            }
        }
        EXPECT_GT(surface, fresh.frame.pixel_count() / 2);
        if (f == 0) {  // the first frame's local frame is the fresh oracle's: the same frame
            EXPECT_EQ(same_prim, fresh.frame.pixel_count());
            EXPECT_EQ(same_v, fresh.frame.pixel_count());
        } else {  // a float local frame a metre and a half away: boundary pixels may differ
            EXPECT_GE(same_prim, fresh.frame.pixel_count() * 999 / 1000);
            EXPECT_GE(same_v, fresh.frame.pixel_count() * 995 / 1000);
        }
        EXPECT_EQ(shared.stats.build_s, 0.0);  // a frame costs its trace only
    }
    EXPECT_EQ(session.bvh_builds(), 1);
}

// `t` drawn by a session moved from the path's first camera to its last, and by a cold run at the
// last camera.
struct WarmAndCold {
    raster::RasterResult warm, cold;
};
WarmAndCold moved_and_cold(const Scenario& sc, const raster::Technique& t) {
    raster::VulkanContext ctx{raster::ContextOptions{}};
    Scenario moving = sc;
    raster::RasterSession session(moving, ctx);
    session.render(t);
    const Camera last = path_camera(*sc.camera_path, 2).value();
    moving.camera = last;
    session.set_camera(last);
    WarmAndCold r{session.render(t), {}};
    Scenario alone = sc;
    alone.camera = last;
    r.cold = raster::run_raster(alone, t, ctx);
    return r;
}

// A session whose camera moved draws what a cold session of that camera draws, bit for bit.
TEST(CameraPath, AMovedRasterSessionDrawsWhatAColdOneDraws) {
    const WarmAndCold r = moved_and_cold(panning(3, 96, 64), cascaded(true));
    EXPECT_EQ(r.warm.frame.prim, r.cold.frame.prim);
    EXPECT_EQ(r.warm.frame.frame_origin, r.cold.frame.frame_origin);
    EXPECT_EQ(r.warm.frame.lights[0].V, r.cold.frame.lights[0].V);
}

// The same with cut-outs: the moved session keeps their buffers and set (raster/cutouts.h), and
// its camera and shadow passes test alpha as a cold session's do.
TEST(CameraPath, AMovedRasterSessionDrawsCutoutsAsAColdOneDraws) {
    Scenario sc = panning(3, 96, 64);
    test::add_cutout_card(sc.scene, {-1.2, 1.2, 1.2}, {2.4, 0, 0}, {0, 0, -2.4}, test::checkerboard_alpha(6), true);
    const WarmAndCold r = moved_and_cold(sc, raster::parse_technique({{"resolution", 1024}}, "test: technique"));
    EXPECT_EQ(r.warm.frame.prim, r.cold.frame.prim);
    EXPECT_EQ(r.warm.frame.lights[0].V, r.cold.frame.lights[0].V);
}

// The flicker rule on two synthetic frames from one orthographic camera (pixel j sees the same
// point in both): a raster change where the truth changes too is a moving true edge, not
// shimmer; one where the truth holds is flicker (docs/metrics.md, "Flicker over a camera path").
TEST(CameraPathFlicker, OnlyARasterChangeTheTruthDoesNotMakeIsFlicker) {
    Camera cam;
    cam.type = ProjectionType::orthographic;
    cam.eye = {0, 0, 10};
    cam.xmag = cam.ymag = 4;  // 8 x 8 pixels of 1 m
    test::Frames a(8, 8), b(8, 8);
    for (test::Frames* f : {&a, &b}) {
        f->o.frame_origin = cam.eye;
        f->o.P.resize(64);
        for (int y = 0; y < 8; ++y)
            for (int x = 0; x < 8; ++x)
                f->o.P[static_cast<std::size_t>(y * 8 + x)] = glm::vec3(x + 0.5f - 4.0f, 4.0f - (y + 0.5f), -10.0f);
    }
    b.ol().V[5] = 0.0f;  // the truth moved here: the raster follows
    b.rl().V[5] = 0.0f;
    b.rl().V[7] = 0.0f;  // the truth holds here: the raster shimmers
    const PairFlicker pf = flicker_between(a.o, a.r, cam, b.o, b.r, 1.0 / 255.0);
    EXPECT_EQ(pf.points, 64u);
    ASSERT_EQ(pf.flicker.size(), 1u);
    EXPECT_EQ(pf.flicker[0], 1u);
    EXPECT_EQ(pf.map[0][7], 1);
    EXPECT_EQ(pf.map[0][5], 0);
}

}  // namespace
}  // namespace penumbra
