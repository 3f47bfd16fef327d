// Shadow volumes (issue #36, docs/raster.md "Shadow volumes") judged end to end through the
// validate pipeline on lavapipe: closed boxes on a plane under a directional, a spot and a point
// light are exact up to rasterisation (wrong pixels only beside a shadow boundary), the camera
// inside a volume is judged as outside it (z-fail; z-pass is not, which shows that the scene
// puts the camera inside one), and an open mesh is reported with its open edges and what the
// open-mesh rule costs.
#include "raster/shadow_volume.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "common/errors.h"
#include "metrics/classification.h"
#include "metrics/metric_table.h"
#include "pipeline/validate.h"
#include "tests/test_support.h"
#include "tests/validate/vulkan_suite.h"

namespace penumbra {
namespace {

using metrics::PixelClass;

class ShadowVolume : public test::VulkanSuite<ShadowVolume> {};

const nlohmann::json kVolumes = {{"preset", "rtr-shadow-volume"}};
const nlohmann::json kSkipOpen = {{"preset", "rtr-shadow-volume"}, {"shadow_volume", {{"open_meshes", "skip"}}}};

// Wrong pixels of light `li` (as the metrics count them) that have no shadow boundary within
// one pixel: no pixel of the 3x3 around them where the oracle's V differs from theirs by half.
struct WrongPixels {
    std::size_t wrong = 0, scored = 0, away_from_boundary = 0;
};
WrongPixels wrong_pixels(const ValidateResult& r, std::size_t li) {
    const OracleFrame& of = r.oracle->frame;
    const RasterFrame& rf = r.raster.frame;
    const OracleLightImage& o = of.lights[li];
    const std::vector<float>& V = rf.lights[li].V;
    const float tolerance = r.scoring[li].tolerance;
    WrongPixels w;
    for (int y = 0; y < of.height; ++y)
        for (int x = 0; x < of.width; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * of.width + x;
            if (of.A[i] == 0 || rf.A[i] == 0 || rf.prim[i] != of.prim[i] || o.lightable[i] == 0 || o.U[i] != 0)
                continue;
            ++w.scored;
            if (std::abs(V[i] - o.V[i]) <= tolerance + o.E[i]) continue;
            ++w.wrong;
            bool boundary = false;
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const int nx = x + dx, ny = y + dy;
                    if (nx < 0 || ny < 0 || nx >= of.width || ny >= of.height) continue;
                    const std::size_t j = static_cast<std::size_t>(ny) * of.width + nx;
                    if (std::abs(o.V[j] - o.V[i]) > 0.5f) boundary = true;
                }
            if (!boundary) ++w.away_from_boundary;
        }
    return w;
}

// Two closed boxes on a 12 m ground plane (the ground is an open mesh: it casts as a sheet under
// the default rule, onto nothing).
test::SceneBuilder boxes_on_a_plane() {
    test::SceneBuilder b;
    b.quad({-6, 0, -6}, {-6, 0, 6}, {6, 0, 6}, {6, 0, -6});
    b.box({-1.5, 0, -0.5}, {-0.5, 1.2, 0.5});
    b.box({0.8, 0, -1.2}, {1.6, 0.6, 0.2});
    return b;
}

void expect_exact(const ValidateResult& r, std::size_t li, const std::string& what) {
    const WrongPixels w = wrong_pixels(r, li);
    const metrics::LightScore& s = r.score.lights[li];
    EXPECT_EQ(w.scored, s.pixels.scored) << what;
    EXPECT_EQ(w.wrong, s.wrong) << what;
    EXPECT_GT(s.pixels.scored, 20000u) << what;
    EXPECT_LE(static_cast<double>(w.wrong), 0.0005 * static_cast<double>(w.scored)) << what << ": " << w.wrong;
    EXPECT_EQ(w.away_from_boundary, 0u) << what;
    // No texels and no bias: nothing is excused as aliasing or peter-panning.
    EXPECT_EQ(s.count(PixelClass::aliasing), 0u) << what;
    EXPECT_EQ(s.count(PixelClass::peter_panning), 0u) << what;
}

TEST_F(ShadowVolume, ClosedBoxesOnAPlaneAreExactUnderDirectionalSpotAndPointLights) {
    const Scenario sc = test::make_scenario(
        boxes_on_a_plane().build(), test::look_at({3, 6, 7}, {0, 0.3, 0}, 45),
        {test::directional({0.55, -0.7, 0.45}), test::spot({-3, 4, 2.5}, glm::normalize(glm::dvec3(0.6, -1, -0.5)), 50),
         test::point({2.2, 2.5, 1.8})},
        320, 240);
    const ValidateResult r = judge(sc, kVolumes);
    ASSERT_EQ(r.raster.stats.family, "shadow_volume");
    const char* names[] = {"directional", "spot", "point"};
    for (std::size_t li = 0; li < 3; ++li) {
        expect_exact(r, li, names[li]);
        // The shadows are there to be got wrong: a good part of the scored ground is in shadow.
        std::size_t shadowed = 0;
        for (std::size_t i = 0; i < r.oracle->frame.pixel_count(); ++i)
            shadowed += r.oracle->frame.lights[li].lightable[i] != 0 && r.oracle->frame.lights[li].V[i] < 0.5f;
        EXPECT_GT(shadowed, 1000u) << names[li];
    }
    // raster.json says what was drawn: the two boxes cast, and so does the ground, open.
    const nlohmann::json& light = r.raster_info["lights"][0]["shadow_volume"];
    EXPECT_EQ(light["meshes"], 3);
    EXPECT_EQ(light["closed_meshes"], 2);
    EXPECT_EQ(light["open_meshes"][0]["open_edges"], 4);
    EXPECT_EQ(light["open_meshes"][0]["casts"], true);
    EXPECT_GT(light["silhouette_edges"].get<int>(), 8);
    EXPECT_GT(r.raster.stats.gpu_ms["stencil"] + r.raster.stats.gpu_ms["resolve"], 0.0);
}

TEST_F(ShadowVolume, TheCameraInsideAVolumeIsJudgedAsOutsideWithZFailAndNotWithZPass) {
    // A wall and the sun high behind it: the camera stands low in the wall's shadow, inside its
    // volume, looking past it at the boxes' shadows on the ground.
    test::SceneBuilder b = boxes_on_a_plane();
    b.box({-0.5, 0, 3.0}, {2.5, 2.2, 3.4});
    const Light sun = test::directional(glm::normalize(glm::dvec3(0.1, -1, -0.6)));
    const Camera inside = test::look_at({1, 0.5, 2.6}, {0, 0, -1}, 60);
    const Camera outside = test::look_at({-4, 5, 6}, {0, 0, -1}, 50);
    const Scenario in_volume = test::make_scenario(b.build(), inside, {sun}, 320, 240);
    const Scenario out_volume = test::make_scenario(b.build(), outside, {sun}, 320, 240);
    const ValidateResult in_zfail = judge(in_volume, kVolumes);
    const ValidateResult out_zfail = judge(out_volume, kVolumes);
    expect_exact(in_zfail, 0, "camera inside, z-fail");
    expect_exact(out_zfail, 0, "camera outside, z-fail");
    // The same verdict: every class empty but beside a boundary, inside as outside.
    for (PixelClass c : {PixelClass::acne, PixelClass::aliasing, PixelClass::peter_panning})
        EXPECT_EQ(in_zfail.score.lights[0].count(c), out_zfail.score.lights[0].count(c));
    // z-pass counts the volumes in front of the surface: right from outside, off by one
    // everywhere from inside.
    nlohmann::json zpass = kVolumes;
    zpass["shadow_volume"] = {{"method", "zpass"}};
    const ValidateResult out_zpass = judge(out_volume, zpass);
    expect_exact(out_zpass, 0, "camera outside, z-pass");
    const ValidateResult in_zpass = judge(in_volume, zpass);
    EXPECT_GT(in_zpass.score.lights[0].wrong_fraction, 0.2);
}

TEST_F(ShadowVolume, AnOpenMeshIsReportedAndTheRuleDecidesWhetherItCasts) {
    // A box without its bottom face, on the ground: four open edges along its foot.
    test::SceneBuilder b;
    b.quad({-6, 0, -6}, {-6, 0, 6}, {6, 0, 6}, {6, 0, -6});
    glm::dvec3 p[8];
    const glm::dvec3 lo(-1, 0, -1), hi(1, 1.5, 1);
    for (int i = 0; i < 8; ++i) p[i] = {i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z};
    b.quad(p[0], p[2], p[3], p[1], false);
    b.quad(p[4], p[5], p[7], p[6], false);
    b.quad(p[0], p[4], p[6], p[2], false);
    b.quad(p[1], p[3], p[7], p[5], false);
    b.quad(p[2], p[6], p[7], p[3], false);
    const Scenario sc = test::make_scenario(b.build(), test::look_at({3, 6, 7}, {0, 0.3, 0}, 45),
                                            {test::directional({0.55, -0.7, 0.45})}, 320, 240);

    const ValidateResult skipped = judge(sc, kSkipOpen);
    const nlohmann::json& report = skipped.raster_info["lights"][0]["shadow_volume"];
    ASSERT_EQ(report["open_meshes"].size(), 2u);  // the ground and the box
    const nlohmann::json& box = report["open_meshes"][1];
    EXPECT_EQ(box["open_edges"], 4);
    EXPECT_EQ(box["non_manifold_edges"], 0);
    EXPECT_EQ(box["triangles"], 10);
    EXPECT_EQ(box["first_triangle"], 2);
    EXPECT_EQ(box["casts"], false);
    EXPECT_EQ(report["rule"], "skip");
    // Skipped, the box casts nothing: its whole shadow on the ground reads as lit.
    const metrics::LightScore& lost = skipped.score.lights[0];
    EXPECT_GT(lost.count(PixelClass::false_lit), 2000u);
    // Said on the run, with the count and the share; the hint names the family's cause, not a map's.
    const auto said = std::find_if(skipped.warnings.begin(), skipped.warnings.end(), [](const std::string& w) {
        return w.starts_with(
            "shadow_volume.open_meshes \"skip\": 2 open meshes cast no shadow, 12 of the scene's 12 "
            "triangles (100.0%): node 0 (10 triangles), node 0 (2 triangles)");
    });
    EXPECT_NE(said, skipped.warnings.end()) << fmt::format("{}", fmt::join(skipped.warnings, "\n"));
    const std::optional<std::string> hint = metrics::reading_line(lost, skipped.facts);
    ASSERT_TRUE(hint);
    EXPECT_NE(hint->find("casters the volumes leave out (open meshes"), std::string::npos) << *hint;
    EXPECT_EQ(hint->find("map"), std::string::npos) << *hint;

    nlohmann::json include = kVolumes;
    include["shadow_volume"] = {{"open_meshes", "include"}};
    const ValidateResult cast = judge(sc, include);
    EXPECT_EQ(cast.raster_info["lights"][0]["shadow_volume"]["open_meshes"][1]["casts"], true);
    EXPECT_TRUE(std::none_of(cast.warnings.begin(), cast.warnings.end(),
                             [](const std::string& w) { return w.starts_with("shadow_volume.open_meshes"); }));
    expect_exact(cast, 0, "open box included");
}

// Open geometry the closed-box test never had (#49): a single-sided ground sheet facing the
// light, a scatter of thin single-sided triangles tilted either way, an open frame (a box
// without top and bottom) and a closed box, under a sun and a point light straight above, a
// spot straight down, an oblique and a grazing sun (shadows several metres long); seen by a
// top-down orthographic camera and an oblique perspective one, at the origin and 10^6 m from
// it. Every light is exact up to rasterisation with the default rule: open meshes cast, and a
// sheet facing the light does not shadow itself.
test::SceneBuilder open_geometry(glm::dvec3 o) {
    test::SceneBuilder b;
    b.quad(o + glm::dvec3(-6, 0, -6), o + glm::dvec3(-6, 0, 6), o + glm::dvec3(6, 0, 6), o + glm::dvec3(6, 0, -6),
           false);
    std::uint32_t seed = 7;
    auto next = [&] {
        seed = seed * 1664525u + 1013904223u;
        return static_cast<double>(seed >> 8) / static_cast<double>(1u << 24);
    };
    for (int k = 0; k < 24; ++k) {
        const glm::dvec3 c = o + glm::dvec3(-4.5 + 9 * next(), 0.4 + 2.2 * next(), -4.5 + 9 * next());
        const glm::dvec3 u(0.3 + 0.5 * next(), 0.6 * (next() - 0.5), 0.2 * next());
        const glm::dvec3 v(0.2 * next(), 0.6 * (next() - 0.5), 0.3 + 0.5 * next());
        if (k % 2)
            b.triangle(c, c + u, c + v, false);  // facing down
        else
            b.triangle(c, c + v, c + u, false);  // facing up
    }
    const glm::dvec3 lo = o + glm::dvec3(1.5, 0.8, 1.5), hi = o + glm::dvec3(3.0, 1.6, 2.6);
    glm::dvec3 p[8];
    for (int i = 0; i < 8; ++i) p[i] = {i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z};
    b.quad(p[0], p[4], p[6], p[2], false);
    b.quad(p[1], p[3], p[7], p[5], false);
    b.quad(p[0], p[2], p[3], p[1], false);
    b.quad(p[4], p[5], p[7], p[6], false);
    b.box(o + glm::dvec3(-3.0, 0, 1.0), o + glm::dvec3(-2.0, 1.0, 2.0));
    return b;
}

TEST_F(ShadowVolume, OpenSoupsSheetsAndFramesAreExactFromEitherCameraAtTheOriginAndFarFromIt) {
    for (const double offset : {0.0, 1e6}) {
        const glm::dvec3 o(offset, 0, offset);
        const std::vector<Light> lights = {test::directional({0, -1, 0}), test::point(o + glm::dvec3(0.3, 6, -0.2)),
                                           test::spot(o + glm::dvec3(-0.5, 7, 0.4), {0, -1, 0}, 70),
                                           test::directional({0.5, -0.8, 0.3}), test::directional({1, -0.2, 0.1})};
        const char* names[] = {"sun straight above", "point straight above", "spot straight down", "oblique sun",
                               "grazing sun"};
        const std::pair<const char*, Camera> cameras[] = {
            {"orthographic from above", test::look_at_ortho(o + glm::dvec3(0, 12, 0), o, 6.5, 5, {0, 0, -1})},
            {"perspective", test::look_at(o + glm::dvec3(5, 7, 9), o + glm::dvec3(0, 0.5, 0), 50)}};
        for (const auto& [camera_name, camera] : cameras) {
            const Scenario sc = test::make_scenario(open_geometry(o).build(), camera, lights, 320, 240);
            const ValidateResult r = judge(sc, kVolumes);
            for (std::size_t li = 0; li < lights.size(); ++li) {
                const std::string what = fmt::format("{}, {}, at {} m", names[li], camera_name, offset);
                expect_exact(r, li, what);
                // Where the truth cannot be lit (facing away, edge-on: the frame's and the box's
                // walls under the sun straight above, outside the spot's cone), the volumes' V is 0
                // too, as a depth map's lookup decides; those pixels are not scored, so this is
                // checked apart.
                const OracleFrame& of = r.oracle->frame;
                std::size_t unlit = 0, lit_anyway = 0;
                for (std::size_t i = 0; i < of.pixel_count(); ++i)
                    if (of.A[i] != 0 && r.raster.frame.prim[i] == of.prim[i] && of.lights[li].lightable[i] == 0) {
                        ++unlit;
                        lit_anyway += r.raster.frame.lights[li].V[i] != 0;
                    }
                EXPECT_LE(lit_anyway, unlit / 10000) << what << ": " << lit_anyway << " of " << unlit;
            }
            EXPECT_TRUE(std::none_of(r.warnings.begin(), r.warnings.end(), [](const std::string& w) {
                return w.starts_with("shadow_volume.open_meshes");
            })) << "the default casts open meshes";
        }
    }
}

TEST_F(ShadowVolume, AWarmSessionKeepsEachLightsVolumesUntilTheRuleChanges) {
    const Scenario sc = test::make_scenario(boxes_on_a_plane().build(), test::look_at({3, 6, 7}, {0, 0.3, 0}, 45),
                                            {test::point({2.2, 2.5, 1.8})}, 160, 120);
    raster::RasterSession session(sc, *ctx_);
    const raster::Technique skip = raster::parse_technique(kSkipOpen, "test: technique");
    nlohmann::json include_json = kVolumes;
    include_json["shadow_volume"] = {{"open_meshes", "include"}};
    const raster::Technique include = raster::parse_technique(include_json, "test: technique");
    const raster::RasterResult first = session.render(skip);
    const raster::RasterResult again = session.render(skip);
    const raster::RasterResult changed = session.render(include);
    EXPECT_FALSE(first.stats.lights[0].family_keys["volumes_reused"].get<bool>());
    EXPECT_TRUE(again.stats.lights[0].family_keys["volumes_reused"].get<bool>());
    EXPECT_EQ(again.stats.lights[0].family_keys["extrude_ms"].get<double>(), 0.0);
    EXPECT_FALSE(changed.stats.lights[0].family_keys["volumes_reused"].get<bool>());
    EXPECT_EQ(first.frame.lights[0].V, again.frame.lights[0].V);
    // The ground, included, casts onto nothing: the same shadows.
    EXPECT_EQ(changed.stats.lights[0].family_keys["open_meshes"][0]["casts"], true);
    EXPECT_EQ(first.frame.lights[0].V, changed.frame.lights[0].V);
    // A scenario without lights draws the depth pass alone.
    Scenario dark = sc;
    dark.lights.clear();
    raster::RasterSession none(dark, *ctx_);
    EXPECT_TRUE(none.render(skip).frame.lights.empty());
}

TEST(ShadowVolumeTopology, ABoxIsClosedAndEveryOpenOrNonManifoldEdgeIsCounted) {
    test::SceneBuilder b;
    b.box({0, 0, 0}, {1, 1, 1});
    b.quad({3, 0, 0}, {3, 0, 1}, {4, 0, 1}, {4, 0, 0});
    // A fin: three triangles on one edge.
    b.triangle({6, 0, 0}, {6, 1, 0}, {7, 0, 0});
    b.triangle({6, 1, 0}, {6, 0, 0}, {5, 0, 0});
    b.triangle({6, 0, 0}, {6, 1, 0}, {6, 0, 1});
    const raster::SceneTopology t = raster::scene_topology(b.build());
    ASSERT_EQ(t.meshes.size(), 3u);
    EXPECT_TRUE(t.meshes[0].closed());
    EXPECT_EQ(t.meshes[0].triangles, 12u);
    EXPECT_EQ(t.meshes[1].open_edges, 4u);
    EXPECT_EQ(t.meshes[1].non_manifold_edges, 0u);
    EXPECT_EQ(t.meshes[2].non_manifold_edges, 1u);
    EXPECT_EQ(t.meshes[2].open_edges, 6u);
}

TEST(ShadowVolumeTechnique, KeysRoundTripAndForeignKeysAreRefused) {
    const raster::Technique t = raster::parse_technique(
        {{"family", "shadow_volume"}, {"shadow_volume", {{"open_meshes", "include"}, {"method", "zpass"}}}},
        "test: technique");
    const raster::ShadowVolumeParameters* p = raster::shadow_volume_parameters(t);
    ASSERT_NE(p, nullptr);
    EXPECT_EQ(p->open_meshes, raster::OpenMeshRule::include);
    EXPECT_EQ(p->method, raster::StencilMethod::zpass);
    const nlohmann::json j = t.to_json();
    EXPECT_EQ(raster::parse_technique(j, "test: technique").to_json(), j);
    EXPECT_EQ(raster::parse_technique(kVolumes, "test: technique").to_json()["shadow_volume"],
              (nlohmann::json{{"open_meshes", "include"}, {"method", "zfail"}}));
    EXPECT_EQ(raster::parse_technique({{"family", "shadow_volume"}}, "test: technique").to_json()["shadow_volume"],
              (nlohmann::json{{"open_meshes", "include"}, {"method", "zfail"}}))
        << "open meshes cast by default";
    try {
        raster::parse_technique({{"family", "shadow_volume"}, {"resolution", 1024}}, "test: technique");
        ADD_FAILURE() << "resolution accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("resolution"), std::string::npos) << e.what();
    }
    try {
        raster::parse_technique({{"family", "shadow_volume"}, {"shadow_volume", {{"open_meshes", "cap"}}}},
                                "test: technique");
        ADD_FAILURE() << "open_meshes cap accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("technique.shadow_volume.open_meshes"), std::string::npos) << e.what();
    }
    // Scored on V alone with no footprint and no bias reach: no wrong pixel excused.
    const std::vector<metrics::ScoringOptions> so =
        scoring_options(test::make_scenario(boxes_on_a_plane().build(), test::look_at({3, 6, 7}, {0, 0, 0}, 45),
                                            {test::directional({0, -1, 0})}, 8, 8),
                        t, 1.0 / 255);
    ASSERT_TRUE(so[0].texel_footprint_m.has_value());
    EXPECT_EQ(*so[0].texel_footprint_m, 0.0f);
    EXPECT_EQ(so[0].bias_reach_m.value_or(-1.0f), 0.0f);
}

}  // namespace
}  // namespace penumbra
