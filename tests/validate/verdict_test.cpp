// The verdict end to end through the validate pipeline: scenes built so that one error
// dominates, traced by the oracle, drawn by the raster path on lavapipe, and judged by metrics. Each test asserts the
// class docs/metrics.md says that error is.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "common/errors.h"
#include "metrics/classification.h"
#include "metrics/gpu_classification.h"
#include "pipeline/validate.h"
#include "tests/test_support.h"
#include "tests/validate/vulkan_suite.h"

namespace penumbra {
namespace {

using metrics::PixelClass;

class Verdict : public test::VulkanSuite<Verdict> {
  protected:
    // The verdict as the CLI's validate reaches it: the pipeline, with no cache.
    struct Judged {
        metrics::LightScore score;
        double footprint_m = 0;  // the map's texel size (directional light)
    };
    static ValidateResult run(const Scenario& sc, const nlohmann::json& technique_json,
                              raster::RasterSession* session = nullptr,
                              std::shared_ptr<const OracleRun> oracle = nullptr) {
        const raster::Technique technique = raster::parse_technique(technique_json, "test: technique");
        ValidateOptions options;
        options.use_cache = false;
        std::unique_ptr<raster::RasterSession> own;
        if (!session) {
            own = std::make_unique<raster::RasterSession>(sc, *ctx_);
            session = own.get();
        }
        ValidateResult r = validate(sc, technique, metrics::Gate{}, options, session, oracle);
        expect_gpu_scores_identical(technique, options, *session, r);
        // The counts on this device, for comparing devices (docs/raster.md, "Verdicts on two devices").
        const metrics::LightScore& l = r.score.lights[0];
        std::string counts;
        for (metrics::PixelClass c : metrics::kErrorClasses)
            counts += fmt::format(", {} {}", metrics::to_string(c), l.count(c));
        std::printf("  [%s] scored %llu%s\n", ::testing::UnitTest::GetInstance()->current_test_info()->name(),
                    static_cast<unsigned long long>(l.pixels.scored), counts.c_str());
        return r;
    }
    // Every field of two verdicts, exactly: the GPU scorer does the CPU's float operations in
    // its order (metrics/gpu_classification.h), so nothing may differ, not even a sum's last bit.
    static void expect_identical(const metrics::LightScore& gpu, const metrics::LightScore& cpu, const char* what) {
        SCOPED_TRACE(what);
        EXPECT_EQ(gpu.pixels.surface, cpu.pixels.surface);
        EXPECT_EQ(gpu.pixels.scored, cpu.pixels.scored);
        EXPECT_EQ(gpu.pixels.back_facing, cpu.pixels.back_facing);
        EXPECT_EQ(gpu.pixels.uncertain, cpu.pixels.uncertain);
        EXPECT_EQ(gpu.pixels.coverage_mismatch, cpu.pixels.coverage_mismatch);
        EXPECT_EQ(gpu.counts, cpu.counts);
        EXPECT_EQ(gpu.counts_visible, cpu.counts_visible);
        EXPECT_EQ(gpu.wrong, cpu.wrong);
        EXPECT_EQ(gpu.wrong_visible, cpu.wrong_visible);
        EXPECT_EQ(gpu.mae, cpu.mae);
        EXPECT_EQ(gpu.rmse, cpu.rmse);
        EXPECT_EQ(gpu.bias, cpu.bias);
        EXPECT_EQ(gpu.wrong_fraction, cpu.wrong_fraction);
        EXPECT_EQ(gpu.peter_panning_gap.mean, cpu.peter_panning_gap.mean);
        EXPECT_EQ(gpu.peter_panning_gap.max, cpu.peter_panning_gap.max);
        EXPECT_EQ(gpu.peter_panning_gap_p95, cpu.peter_panning_gap_p95);
        EXPECT_EQ(gpu.acne_depth.mean, cpu.acne_depth.mean);
        EXPECT_EQ(gpu.acne_depth.max, cpu.acne_depth.max);
        EXPECT_EQ(gpu.acne_depth_pixels, cpu.acne_depth_pixels);
        EXPECT_EQ(gpu.perceptual.mean, cpu.perceptual.mean);
        EXPECT_EQ(gpu.perceptual.max, cpu.perceptual.max);
        EXPECT_EQ(gpu.evidence.source, cpu.evidence.source);
        EXPECT_EQ(gpu.evidence.texel_footprint_m, cpu.evidence.texel_footprint_m);
        EXPECT_EQ(gpu.evidence.bias_reach_m, cpu.evidence.bias_reach_m);
        ASSERT_EQ(gpu.soft.has_value(), cpu.soft.has_value());
        if (!cpu.soft) return;
        EXPECT_EQ(gpu.soft->umbra_pixels, cpu.soft->umbra_pixels);
        EXPECT_EQ(gpu.soft->penumbra_pixels, cpu.soft->penumbra_pixels);
        EXPECT_EQ(gpu.soft->lit_pixels, cpu.soft->lit_pixels);
        EXPECT_EQ(gpu.soft->umbra_mae, cpu.soft->umbra_mae);
        EXPECT_EQ(gpu.soft->penumbra_mae, cpu.soft->penumbra_mae);
        EXPECT_EQ(gpu.soft->lit_mae, cpu.soft->lit_mae);
        EXPECT_EQ(gpu.soft->penumbra_mae_beyond_e, cpu.soft->penumbra_mae_beyond_e);
        EXPECT_EQ(gpu.soft->width_pixels_oracle, cpu.soft->width_pixels_oracle);
        EXPECT_EQ(gpu.soft->width_pixels_raster, cpu.soft->width_pixels_raster);
    }

    // The GPU scorer against the CPU reference on this scene and technique: the verdict with
    // lookups (validate's), and a V-only one with both scales given (tune's), each from a render
    // whose output stays on the device. Families that read back anyway have nothing to compare.
    static void expect_gpu_scores_identical(const raster::Technique& technique, const ValidateOptions& options,
                                            raster::RasterSession& session, const ValidateResult& r) {
        ASSERT_TRUE(ctx_->shader_float64()) << "the GPU scorer needs shaderFloat64";
        raster::RenderOptions on_device = options.render;
        on_device.read_back = false;
        const raster::RasterResult rr = session.render(technique, on_device);
        if (rr.stats.on_device.empty()) return;
        metrics::GpuScorer scorer(*ctx_, r.oracle->frame, rr.frame);
        const std::optional<metrics::FrameScore> gpu = scorer.score(rr, r.scoring);
        ASSERT_TRUE(gpu);
        ASSERT_EQ(gpu->lights.size(), r.score.lights.size());
        for (std::size_t li = 0; li < r.score.lights.size(); ++li)
            expect_identical(gpu->lights[li], r.score.lights[li], "with lookups");

        std::vector<metrics::ScoringOptions> v_only = r.scoring;
        for (auto& o : v_only) {
            o.texel_footprint_m = static_cast<float>(r.raster.stats.lights[0].projection.metres_per_texel);
            o.bias_reach_m = 0.05f;
        }
        raster::RenderOptions v = on_device;
        v.lookups = false;
        const raster::RasterResult rv = session.render(technique, v);
        const std::optional<metrics::FrameScore> gpu_v = scorer.score(rv, v_only);
        ASSERT_TRUE(gpu_v);
        v.read_back = true;
        const metrics::FrameScore cpu_v =
            metrics::score_frames(r.oracle->frame, session.render(technique, v).frame, v_only);
        for (std::size_t li = 0; li < cpu_v.lights.size(); ++li)
            expect_identical(gpu_v->lights[li], cpu_v.lights[li], "V only, scales given");

        // sweep's way: a render without the camera images (the scorer has seen its camera pass),
        // the perceptual error computed apart. A scorer that has not seen the pass declines.
        raster::RenderOptions bare = on_device;
        bare.camera_images = false;
        const raster::RasterResult rb = session.render(technique, bare);
        EXPECT_TRUE(rb.frame.prim.empty());
        ASSERT_TRUE(scorer.knows_camera(rb.stats));
        metrics::DeferredPerceptual perceptual;
        std::optional<metrics::FrameScore> gpu_b = scorer.score(rb, r.scoring, false, &perceptual);
        ASSERT_TRUE(gpu_b);
        perceptual.run(*gpu_b);
        for (std::size_t li = 0; li < r.score.lights.size(); ++li)
            expect_identical(gpu_b->lights[li], r.score.lights[li], "without camera images, perceptual apart");
        metrics::GpuScorer fresh(*ctx_, r.oracle->frame, rr.frame);
        EXPECT_FALSE(fresh.knows_camera(rb.stats));
        EXPECT_FALSE(fresh.score(rb, r.scoring).has_value());
    }

    static Judged judge(const Scenario& sc, const nlohmann::json& technique_json) {
        const ValidateResult r = run(sc, technique_json);
        return {r.score.lights[0], r.raster.stats.lights[0].projection.metres_per_texel};
    }
};

// `c` has more pixels than every other error class.
void expect_dominant(const metrics::LightScore& s, PixelClass c) {
    std::string all;
    for (auto k : metrics::kErrorClasses) all += fmt::format("{} {}, ", metrics::to_string(k), s.count(k));
    for (auto k : metrics::kErrorClasses)
        if (k != c) {
            EXPECT_GT(s.count(c), s.count(k)) << metrics::to_string(c) << " should dominate: " << all;
        }
}

Light sun_at_elevation(double elevation_deg) {
    const double e = elevation_deg * 3.14159265358979323846 / 180.0;
    return test::directional({std::cos(e) * 0.8, -std::sin(e), std::cos(e) * 0.6});
}

// A 10 m ground plane with a unit box resting on it (contact shadows), seen from above.
Scenario plane_and_box(double elevation_deg = 35) {
    test::SceneBuilder b;
    b.quad({-5, 0, -5}, {-5, 0, 5}, {5, 0, 5}, {5, 0, -5});
    b.box({-0.5, 0, -0.5}, {0.5, 1, 0.5});
    return test::make_scenario(b.build(), test::look_at({3, 5, 6}, {0, 0.3, 0}, 45), {sun_at_elevation(elevation_deg)},
                               320, 240);
}

TEST_F(Verdict, ZeroBiasIsAcne) {
    Judged j = judge(plane_and_box(35), {{"preset", "no-bias"}, {"resolution", 1024}, {"depth_format", "d32"}});
    expect_dominant(j.score, PixelClass::acne);
    EXPECT_GT(j.score.rate(PixelClass::acne), 0.1);
}

TEST_F(Verdict, PureWorldBiasIsPeterPanningWithTheGapOfTheBias) {
    // A thin wall standing on the plane, across the light: receivers whose occluder is nearer
    // than b along the ray are moved through it and read as lit. (A solid box would still
    // shadow them: the map stores its light-facing side, further than b.)
    test::SceneBuilder builder;
    builder.quad({-5, 0, -5}, {-5, 0, 5}, {5, 0, 5}, {5, 0, -5});
    builder.quad({-1.2, 0, 1.6}, {-1.2, 1.5, 1.6}, {1.2, 1.5, -1.6}, {1.2, 0, -1.6});  // normal along (0.8, 0, 0.6)
    Scenario sc = test::make_scenario(builder.build(), test::look_at({3, 5, 6}, {0, 0.3, 0}, 45),
                                      {sun_at_elevation(35)}, 320, 240);
    const double b = 0.15;
    Judged j = judge(sc, {{"resolution", 1024}, {"bias", {{"world", b}}}});
    expect_dominant(j.score, PixelClass::peter_panning);
    EXPECT_EQ(j.score.count(PixelClass::acne), 0u);
    EXPECT_GT(j.score.peter_panning_gap.max, 0.85 * b);
    EXPECT_LE(j.score.peter_panning_gap.max, b + 2 * j.footprint_m);
}

TEST_F(Verdict, LowResolutionWithAdequateBiasIsAliasing) {
    const nlohmann::json bias = {{"slope", 1.5}, {"receiver_plane", true}};
    Judged j = judge(plane_and_box(35), {{"resolution", 128}, {"bias", bias}});
    expect_dominant(j.score, PixelClass::aliasing);
    EXPECT_GT(j.score.count(PixelClass::aliasing), 100u);  // 175 measured on lavapipe
    // Resolution is the cause: 16 times the texels leave a fraction of it.
    Judged fine = judge(plane_and_box(35), {{"resolution", 2048}, {"bias", bias}});
    EXPECT_LT(fine.score.count(PixelClass::aliasing), j.score.count(PixelClass::aliasing) / 4);
}

TEST_F(Verdict, FrontFaceCullingDropsASingleSidedOccluderAsFalseLit) {
    test::SceneBuilder b;
    b.quad({-5, 0, -5}, {-5, 0, 5}, {5, 0, 5}, {5, 0, -5});
    // A single-sided card 1.2 m up, its front face towards the sky (and the light).
    b.quad({-1, 1.2, -1}, {-1, 1.2, 1}, {1, 1.2, 1}, {1, 1.2, -1}, false);
    Scenario sc =
        test::make_scenario(b.build(), test::look_at({3, 5, 6}, {0, 0.3, 0}, 45), {sun_at_elevation(50)}, 320, 240);
    const nlohmann::json bias = {{"slope", 1.5}, {"receiver_plane", true}};
    Judged culled = judge(sc, {{"resolution", 1024}, {"cull", "front"}, {"bias", bias}});
    expect_dominant(culled.score, PixelClass::false_lit);
    EXPECT_GT(culled.score.rate(PixelClass::false_lit), 0.02);
    // The same technique with back-face culling keeps the card's shadow.
    Judged kept = judge(sc, {{"resolution", 1024}, {"cull", "back"}, {"bias", bias}});
    EXPECT_LT(kept.score.rate(PixelClass::false_lit), 0.1 * culled.score.rate(PixelClass::false_lit));
}

// A card 1.2 m over the ground with its back to the sky (its front face down), as foliage cards
// and exported sheets often are: `doubleSided` decides whether an engine casts it.
Scenario card_with_its_back_to_the_light(bool double_sided) {
    test::SceneBuilder b;
    b.quad({-5, 0, -5}, {-5, 0, 5}, {5, 0, 5}, {5, 0, -5});
    b.quad({1, 1.2, -1}, {1, 1.2, 1}, {-1, 1.2, 1}, {-1, 1.2, -1}, double_sided);
    return test::make_scenario(b.build(), test::look_at({3, 5, 6}, {0, 0.3, 0}, 45), {sun_at_elevation(50)}, 320, 240);
}

TEST_F(Verdict, CullByMaterialCastsADoubleSidedCardWithItsBackToTheLight) {
    const nlohmann::json bias = {{"slope", 1.5}, {"receiver_plane", true}};
    const Scenario sc = card_with_its_back_to_the_light(true);
    // One cull mode for every material drops the card: the light sees its back.
    Judged back = judge(sc, {{"resolution", 1024}, {"cull", "back"}, {"bias", bias}});
    expect_dominant(back.score, PixelClass::false_lit);
    EXPECT_GT(back.score.rate(PixelClass::false_lit), 0.02);
    // Its material is double-sided: culled by material, both faces are drawn and it casts.
    Judged material = judge(sc, {{"resolution", 1024}, {"cull", "material"}, {"bias", bias}});
    EXPECT_LT(material.score.rate(PixelClass::false_lit), 0.05 * back.score.rate(PixelClass::false_lit));
    Judged none = judge(sc, {{"resolution", 1024}, {"cull", "none"}, {"bias", bias}});
    EXPECT_EQ(material.score.counts, none.score.counts);
}

TEST_F(Verdict, CullByMaterialCullsASingleSidedMaterialOnTheEnginesSide) {
    const nlohmann::json bias = {{"slope", 1.5}, {"receiver_plane", true}};
    const Scenario sc = card_with_its_back_to_the_light(false);
    // Single-sided: culled on single_sided_cull's side, exactly as that one mode culls.
    for (const char* side : {"back", "front"}) {
        SCOPED_TRACE(side);
        Judged one = judge(sc, {{"resolution", 1024}, {"cull", side}, {"bias", bias}});
        Judged material =
            judge(sc, {{"resolution", 1024}, {"cull", "material"}, {"single_sided_cull", side}, {"bias", bias}});
        EXPECT_EQ(material.score.counts, one.score.counts);
        EXPECT_EQ(material.score.mae, one.score.mae);
    }
}

TEST_F(Verdict, CullByMaterialDrawnRunByRunKeepsTheSceneTriangleIds) {
    // A ground of 64 quads whose materials alternate double- and single-sided, every one facing
    // the light: culled by material it is drawn in 128 runs, and the map's triangle ids (what
    // acne is judged by) must be the scene's, so the verdict equals cull back's to the pixel.
    test::SceneBuilder b;
    for (int i = 0; i < 8; ++i)
        for (int k = 0; k < 8; ++k) {
            const double x = -4 + i, z = -4 + k;
            b.quad({x, 0, z}, {x, 0, z + 1}, {x + 1, 0, z + 1}, {x + 1, 0, z}, (i + k) % 2 == 0);
        }
    b.box({-0.5, 0, -0.5}, {0.5, 1, 0.5});
    const Scenario sc =
        test::make_scenario(b.build(), test::look_at({3, 5, 6}, {0, 0.3, 0}, 45), {sun_at_elevation(35)}, 320, 240);
    Judged back = judge(sc, {{"preset", "no-bias"}, {"resolution", 1024}});
    Judged material = judge(sc, {{"preset", "no-bias"}, {"resolution", 1024}, {"cull", "material"}});
    EXPECT_GT(back.score.rate(PixelClass::acne), 0.05);
    EXPECT_EQ(material.score.counts, back.score.counts);
    EXPECT_EQ(material.score.acne_depth.max, back.score.acne_depth.max);
}

// A checkerboard cut-out card (6 x 6 texels of 0.4 m, alphaMode MASK) 1.2 m over the ground:
// the shadow pass tests alpha as the oracle does (with filters, cascades, moments, the midpoint's
// peel pass, and caster offsets), so its holes let the light through and the
// camera sees the ground through them. What is wrong lies at the texels' edges, within the
// filter's reach (aliasing), never false_shadow in a hole; drawn opaque, the holes would be
// false_shadow over about a fifth of the card's shadow.
Scenario checkerboard_card(bool nearest) {
    test::SceneBuilder b;
    b.quad({-5, 0, -5}, {-5, 0, 5}, {5, 0, 5}, {5, 0, -5});
    Scene scene = b.build();
    test::add_cutout_card(scene, {-1.2, 1.2, 1.2}, {2.4, 0, 0}, {0, 0, -2.4}, test::checkerboard_alpha(6), nearest);
    return test::make_scenario(scene, test::look_at({3, 5, 6}, {0, 0.3, 0}, 45), {sun_at_elevation(50)}, 320, 240);
}

TEST_F(Verdict, CutoutsCastThroughTheirHolesInEveryDepthMapFamily) {
    const nlohmann::json bias = {{"slope", 1.5}, {"receiver_plane", true}};
    for (const bool nearest : {true, false}) {
        const Scenario sc = checkerboard_card(nearest);
        for (const nlohmann::json& t :
             {nlohmann::json{{"resolution", 2048}, {"bias", bias}},
              nlohmann::json{{"resolution", 2048}, {"bias", bias}, {"filter", {{"type", "pcf"}, {"size", 3}}}},
              nlohmann::json{
                  {"family", "cascaded"}, {"resolution", 2048}, {"bias", bias}, {"cascades", {{"max_distance", 20}}}},
              nlohmann::json{{"family", "vsm"}, {"resolution", 2048}},
              nlohmann::json{{"preset", "rtr-midpoint"}, {"resolution", 2048}},
              nlohmann::json{{"preset", "babylon"}, {"resolution", 2048}}, nlohmann::json{{"preset", "unreal-csm"}}}) {
            SCOPED_TRACE(fmt::format("{} {}", nearest ? "nearest" : "linear", t.dump()));
            const ValidateResult r = run(sc, t);
            const metrics::LightScore& l = r.score.lights[0];
            EXPECT_LT(l.rate(PixelClass::false_shadow), 0.002);
            EXPECT_LT(l.rate(PixelClass::false_lit), 0.002);
            // The camera saw the card where the truth did: only its texels' edges differ.
            EXPECT_LT(l.pixels.coverage_mismatch, l.pixels.surface / 200);
        }
    }
}

TEST_F(Verdict, CutoutsAreRefusedByTheFamiliesThatCannotDrawThem) {
    const Scenario sc = checkerboard_card(true);
    for (const char* preset : {"rtr-shadow-volume"}) {
        SCOPED_TRACE(preset);
        try {
            run(sc, {{"preset", preset}});
            ADD_FAILURE() << "drawn";
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find("cannot draw cut-outs (card is alphaMode MASK"), std::string::npos)
                << e.what();
        }
    }
}

// Planar projection flattens the card onto the ground with its texture coordinates over Blinn's
// w, and tests alpha there: the holes' light reaches the ground (the plane is its only receiver,
// and the card itself receives nothing: its own pixels are the technique's false light).
TEST_F(Verdict, PlanarProjectionCastsACutoutThroughItsHoles) {
    for (const bool point : {false, true}) {
        SCOPED_TRACE(point ? "point light" : "sun");
        Scenario sc = checkerboard_card(true);
        if (point) sc.lights = {test::point({0.6, 4.0, 0.4})};
        const metrics::LightScore l = run(sc, {{"preset", "rtr-planar"}}).score.lights[0];
        // Drawn opaque the holes were 2,755 (sun) and 3,856 (point) wrong pixels (classed acne).
        EXPECT_LT(l.wrong, l.pixels.scored / 500);
    }
}

// The same card blended (alphaMode BLEND): the truth holds it opaque (docs/oracle.md), and the
// technique's `blend` rule decides what the shadow pass draws: opaque as the truth, nothing (all
// its shadow false_lit), or alpha-tested like a cut-out (its holes false_lit, about half).
TEST_F(Verdict, BlendedMaterialsCastAsTheTechniquesBlendRuleSays) {
    Scenario sc = checkerboard_card(true);
    for (CutoutMaterial& m : sc.scene.cutout_materials) m.mode = AlphaMode::blend;
    const nlohmann::json t = {{"resolution", 2048}, {"bias", {{"slope", 1.5}, {"receiver_plane", true}}}};
    auto with = [&](const char* blend) {
        nlohmann::json j = t;
        j["blend"] = blend;
        return run(sc, j).score.lights[0];
    };
    const metrics::LightScore opaque = with("opaque"), none = with("none"), cutout = with("cutout(0.5)");
    EXPECT_LT(opaque.rate(PixelClass::false_lit), 0.002);
    EXPECT_GT(none.rate(PixelClass::false_lit), 0.04);
    EXPECT_GT(cutout.rate(PixelClass::false_lit), 0.3 * none.rate(PixelClass::false_lit));
    EXPECT_LT(cutout.rate(PixelClass::false_lit), 0.7 * none.rate(PixelClass::false_lit));
    // The camera sees a blended surface whatever the rule: no coverage mismatch in its holes.
    EXPECT_LT(cutout.pixels.coverage_mismatch, cutout.pixels.surface / 200);
    // A family that draws every triangle opaque takes blend opaque only.
    EXPECT_NO_THROW(run(sc, {{"preset", "rtr-shadow-volume"}}));
    try {
        run(sc, {{"preset", "rtr-shadow-volume"}, {"blend", "none"}});
        ADD_FAILURE() << "drawn";
    } catch (const InputError& e) {
        EXPECT_NE(
            std::string(e.what()).find("technique.blend \"none\": shadow_volume draws blended materials opaque only"),
            std::string::npos)
            << e.what();
    }
}

// A wire mesh (a 128-texel texture, wires 1 texel wide every 8, repeated 8 times over a 6 m
// card 1.2 m up) under a 512-texel map: a texture texel is 6 mm, a map texel about 2.3 cm, so the
// shadow pass's footprint minifies the texture 2^2 times. alpha.mipmaps samples that level, where
// a wire's coverage is averaged below the cutoff and it vanishes, as in an engine's mipmapped
// alpha test: the raster is lit where the wires shadow (the truth keeps level 0). Without it the
// alpha test samples level 0 at each texel centre.
TEST_F(Verdict, MipmappedAlphaLosesTheCoverageOfMinifiedCutouts) {
    test::SceneBuilder b;
    b.quad({-5, 0, -5}, {-5, 0, 5}, {5, 0, 5}, {5, 0, -5});
    Scene scene = b.build();
    AlphaTexture wires;
    wires.width = wires.height = 128;
    for (int j = 0; j < 128; ++j)
        for (int i = 0; i < 128; ++i) wires.alpha.push_back(i % 8 == 0 || j % 8 == 0 ? 65535 : 0);
    const std::uint32_t card = test::add_cutout_card(scene, {-3, 1.2, 3}, {6, 0, 0}, {0, 0, -6}, wires, true);
    for (std::uint32_t t : {card, card + 1})
        for (int k = 0; k < 3; ++k) scene.texcoords[scene.triangles[t][k]] *= 8.0f;
    scene.cutout_materials.back().wrap_s = scene.cutout_materials.back().wrap_t = TextureWrap::repeat;
    const Scenario sc =
        test::make_scenario(scene, test::look_at({3, 5, 6}, {0, 0.3, 0}, 45), {sun_at_elevation(60)}, 320, 240);
    const nlohmann::json t = {{"resolution", 512}, {"bias", {{"slope", 1.5}, {"receiver_plane", true}}}};
    nlohmann::json mip = t;
    mip["alpha"] = {{"mipmaps", true}};
    const metrics::LightScore level0 = run(sc, t).score.lights[0], mipmapped = run(sc, mip).score.lights[0];
    // Brighter than the truth: the wires' shadows are gone (signed error, raster minus oracle);
    // level 0's errors balance. The lost wires lie within a map texel of their true edges, so the
    // boundary rule classes them aliasing (measured: 6,645 aliasing pixels, bias +0.122 against
    // level 0's +0.0002 with 1,797 false_shadow where a texel-wide wire shadow overhangs).
    EXPECT_LT(std::abs(level0.bias), 0.01);
    EXPECT_GT(mipmapped.bias, 0.08);
    EXPECT_EQ(mipmapped.count(PixelClass::false_shadow), 0u);
    std::printf("  level 0: bias %.4f, wrong %llu; mipmapped: bias %.4f, wrong %llu\n", level0.bias,
                static_cast<unsigned long long>(level0.wrong), mipmapped.bias,
                static_cast<unsigned long long>(mipmapped.wrong));
}

TEST_F(Verdict, ASheetWithInvertedWindingIsNamedAndLeadsTheHintOfMissingShadows) {
    // A terrain-like sheet with its winding inverted (front faces down), single-sided, 0.6 m over
    // the ground and seen from above: the camera culls it and sees the ground through it, while
    // the truth's occluders cast on both sides; a shadow pass culling back faces drops it too.
    test::SceneBuilder b;
    b.quad({-5, 0, -5}, {-5, 0, 5}, {5, 0, 5}, {5, 0, -5});
    const std::uint32_t sheet = b.quad({2, 0.6, -2}, {2, 0.6, 2}, {-2, 0.6, 2}, {-2, 0.6, -2}, false);
    Scene scene = b.build();
    scene.triangle_node[sheet] = scene.triangle_node[sheet + 1] = 1;
    scene.node_labels = {"nodes[0] \"Ground\"", "nodes[1] \"Terrain\""};
    const Scenario sc =
        test::make_scenario(scene, test::look_at({3, 5, 6}, {0, 0.3, 0}, 45), {sun_at_elevation(50)}, 320, 240);
    const ValidateResult r = run(sc, {{"resolution", 1024}, {"bias", {{"slope", 1.5}, {"receiver_plane", true}}}});
    ASSERT_EQ(r.facing.meshes.size(), 1u);
    EXPECT_EQ(r.facing.meshes[0].mesh, "nodes[1] \"Terrain\"");
    EXPECT_GT(r.facing.meshes[0].share(), 0.95);  // the ground shows through every one of its pixels
    EXPECT_GT(r.facing.share(), metrics::kFacingHintShare);
    EXPECT_EQ(r.report["facing"]["meshes"][0]["mesh"], "nodes[1] \"Terrain\"");
    ASSERT_FALSE(r.warnings.empty());
    EXPECT_NE(r.warnings.back().find("nodes[1] \"Terrain\": "), std::string::npos) << r.warnings.back();
    const std::optional<std::string> hint = metrics::reading_line(r.score.lights[0], r.facts);
    ASSERT_TRUE(hint);
    EXPECT_TRUE(hint->starts_with("false_lit")) << *hint;
    EXPECT_NE(hint->find("back of single-sided triangles"), std::string::npos) << *hint;
    EXPECT_NE(hint->find("culling back faces"), std::string::npos) << *hint;
    // The same sheet wound right is not named, and the hint is the usual one.
    const ValidateResult ok = run(card_with_its_back_to_the_light(true), {{"resolution", 1024}});
    EXPECT_TRUE(ok.facing.meshes.empty());
    EXPECT_EQ(ok.facing.from_behind, 0u);
}

TEST_F(Verdict, ALightFrustumThatMissesReceiversIsFalseLitNotAcne) {
    test::SceneBuilder b;
    b.quad({-4, 0, -40}, {-4, 0, 4}, {4, 0, 4}, {4, 0, -40});
    for (int k = 0; k < 6; ++k) b.box({-1, 0, -6.0 * k - 1}, {1, 1.5, -6.0 * k + 1});
    Scenario sc =
        test::make_scenario(b.build(), test::look_at({0, 3, 6}, {0, 0, -20}, 50), {sun_at_elevation(40)}, 320, 240);
    // The map covers the first 12 m of view depth only, as an engine's shadow distance would.
    const nlohmann::json technique = {{"resolution", 2048},
                                      {"fit", "camera_frustum"},
                                      {"shadow_distance", 12.0},
                                      {"bias", {{"slope", 1.5}, {"receiver_plane", true}}}};
    Judged j = judge(sc, technique);
    expect_dominant(j.score, PixelClass::false_lit);
    EXPECT_EQ(j.score.count(PixelClass::acne), 0u);
    EXPECT_GT(j.score.count(PixelClass::false_lit), 50u);
    // The missing coverage is the cause: the whole view in the map loses (nearly) nothing.
    nlohmann::json whole = technique;
    whole["shadow_distance"] = 0.0;
    Judged covered = judge(sc, whole);
    EXPECT_LT(covered.score.count(PixelClass::false_lit), j.score.count(PixelClass::false_lit) / 10);
}

// Light bleeding (issue #35): a plate 2 m over the ground casts its shadow beside itself (the
// sun at 45 degrees), and a roof 4 m up covers half of that shadow in the light's view. Along
// the roof's edge inside the plate's shadow a blurred variance map mixes the roof's and the
// plate's depths: Chebyshev's bound lets light through onto ground that the plate shadows,
// away from any true shadow boundary (the roof's edge there is no boundary: the ground is in
// shadow on both sides of it).
Scenario plate_under_roof() {
    test::SceneBuilder b;
    b.quad({-8, 0, -6}, {-8, 0, 6}, {6, 0, 6}, {6, 0, -6});
    b.quad({-1, 2, -1}, {-1, 2, 1}, {1, 2, 1}, {1, 2, -1});    // the plate: its shadow spans x 1..3
    b.quad({-7, 4, -4}, {-7, 4, 4}, {-2, 4, 4}, {-2, 4, -4});  // the roof: its edge's shadow at x = 2
    // Seen from below the plate: its top, where the roof's shadow edge lies on the same light
    // rays as the bleeding ground, is hidden (docs/metrics.md: only seen boundaries count).
    return test::make_scenario(b.build(), test::look_at({9, 1.2, 0}, {2, 0, 0}, 40), {test::directional({1, -1, 0})},
                               320, 240);
}

TEST_F(Verdict, VarianceMapsBleedLightUnderAStackedOccluderAndTheClassSaysSo) {
    const Scenario sc = plate_under_roof();
    const nlohmann::json vsm = {{"family", "vsm"}, {"resolution", 256}, {"blur", 4}, {"vsm", {{"light_bleed", 0.0}}}};
    const ValidateResult r = run(sc, vsm);
    const Judged bleeding{r.score.lights[0], 0};
    EXPECT_GT(bleeding.score.count(PixelClass::light_bleeding), 100u);  // 302 on lavapipe
    EXPECT_EQ(bleeding.score.count(PixelClass::false_lit), 0u);
    // The plate lies halfway between the roof and the ground: a fraction a of roof depths in the
    // footprint gives Chebyshev's bound a(1-a) / (a(1-a) + (1+a)^2), at most 0.111 (a = 0.35).
    // The plates are ramps in the light's view, which spreads the depths a little more.
    float brightest = 0;
    const auto& cls = r.score.images[0].cls;
    for (std::size_t i = 0; i < cls.size(); ++i)
        if (cls[i] == static_cast<std::uint8_t>(PixelClass::light_bleeding))
            brightest = std::max(brightest, r.raster.frame.lights[0].V[i]);
    EXPECT_GT(brightest, 0.09f);
    EXPECT_LT(brightest, 0.14f);
    // The reduction linstep(a, 1, p) cuts the leak.
    nlohmann::json reduced = vsm;
    reduced["vsm"]["light_bleed"] = 0.6;
    Judged less = judge(sc, reduced);
    EXPECT_LT(less.score.count(PixelClass::light_bleeding), bleeding.score.count(PixelClass::light_bleeding) / 2);
    // ESM's exp(c (d - z)), with the plate a quarter of the depth range above the ground,
    // does not leak there.
    Judged esm = judge(sc, {{"family", "esm"}, {"resolution", 256}, {"blur", 4}});
    EXPECT_LT(esm.score.count(PixelClass::light_bleeding), bleeding.score.count(PixelClass::light_bleeding) / 10);
    // EVSM's exponential warp separates the two depths: at the same blur and no reduction it
    // bleeds less than VSM (Lauritzen & McCool 2008).
    Judged evsm = judge(sc, {{"family", "evsm4"}, {"resolution", 256}, {"blur", 4}, {"evsm", {{"light_bleed", 0.0}}}});
    EXPECT_LT(evsm.score.count(PixelClass::light_bleeding), bleeding.score.count(PixelClass::light_bleeding) / 2);
    // A depth-map family never gets the class.
    Judged depth_map = judge(sc, {{"resolution", 256}, {"filter", {{"type", "pcf"}, {"size", 9}}}});
    EXPECT_EQ(depth_map.score.count(PixelClass::light_bleeding), 0u);
}

// Moment shadow maps (Peters & Klein 2015) on the same plate: four moments bound the shadow far
// more sharply than Chebyshev's two, so at the same blur and with no light-bleed reduction MSM
// (Hamburger, 32-bit) bleeds less than VSM (the paper's figures 1 and 7), and a reconstruction
// that lost the shadow would show as false light, one that darkened lit ground as false shadow.
TEST_F(Verdict, MomentShadowMapsBleedLessThanVarianceMapsAtTheSameBlur) {
    const Scenario sc = plate_under_roof();
    Judged vsm = judge(sc, {{"family", "vsm"}, {"resolution", 256}, {"blur", 4}, {"vsm", {{"light_bleed", 0.0}}}});
    EXPECT_GT(vsm.score.count(PixelClass::light_bleeding), 100u);  // 302 on lavapipe
    for (const char* variant : {"hamburger", "hausdorff"}) {
        Judged msm = judge(sc, {{"family", "msm"}, {"resolution", 256}, {"blur", 4}, {"msm", {{"variant", variant}}}});
        EXPECT_LT(msm.score.count(PixelClass::light_bleeding), vsm.score.count(PixelClass::light_bleeding) / 10)
            << variant;  // 10 of 302 on lavapipe, either variant
        EXPECT_EQ(msm.score.count(PixelClass::false_lit), 0u) << variant;
        EXPECT_EQ(msm.score.count(PixelClass::false_shadow), 0u) << variant;
        // Hamburger darkens the plates' ramps no more than VSM (1920 pixels of acne each); the
        // Hausdorff bound is sharper and darkens more of them (9600).
        if (std::string(variant) == "hamburger") {
            EXPECT_LE(msm.score.count(PixelClass::acne), vsm.score.count(PixelClass::acne));
        }
    }
    Judged depth_map = judge(sc, {{"resolution", 256}, {"filter", {{"type", "pcf"}, {"size", 9}}}});
    EXPECT_EQ(depth_map.score.count(PixelClass::light_bleeding), 0u);
}

// Soft shadows: a box under a rect light. The truth's penumbra is wide; a single hard map
// (no filter) has almost none, PCSS widens it from the blockers' depth, and averaging 16 hard
// maps over the light comes closest, as reference 001 says.
TEST_F(Verdict, SoftShadowMetricsRankHardPcssAndAveragedMaps) {
    test::SceneBuilder b;
    b.grid({-3, 0, 3}, {6, 0, 0}, {0, 0, -6}, 6, 6);
    b.box({-0.5, 0, -0.5}, {0.5, 1.0, 0.5});
    Scenario sc = test::make_scenario(b.build(), test::look_at({0, 5, 5}, {0, 0, 0}, 45),
                                      {test::rect({0.5, 3.5, 0.3}, {1.2, 0, 0}, {0, 0, 1.2})}, 160, 120);
    // One oracle and one warm session for the three techniques, as tune and sweep run them.
    ValidateOptions options;
    options.use_cache = false;
    const auto truth = std::make_shared<const OracleRun>(oracle_for(sc, options));
    raster::RasterSession session(sc, *ctx_);
    auto soft_score = [&](const nlohmann::json& technique_json) {
        const ValidateResult r = run(sc, technique_json, &session, truth);
        EXPECT_TRUE(r.score.lights[0].soft.has_value()) << "an area light is scored as soft (scoring_options)";
        return *r.score.lights[0].soft;
    };
    const auto hard = soft_score({{"resolution", 1024}, {"bias", {{"slope", 1.5}, {"constant", 2}}}});
    // 8 r of constant bias rather than the presets' 2: an H100 interpolates depth less exactly than
    // lavapipe, and at 2 r its lit region has acne (docs/raster.md, "Receiver-plane bias per
    // device"); from 8 r both devices give these numbers to the last digit.
    const nlohmann::json bias = {{"constant", 8}};
    const auto pcss = soft_score({{"preset", "pcss"}, {"resolution", 1024}, {"bias", bias}});
    const auto averaged = soft_score({{"preset", "averaged-hard-shadows"}, {"resolution", 1024}, {"bias", bias}});
    EXPECT_GT(hard.penumbra_pixels, 500u);
    EXPECT_LT(hard.penumbra_width_error, -0.7) << "a hard shadow has next to no penumbra";
    EXPECT_GT(pcss.penumbra_width_error, hard.penumbra_width_error + 0.3);
    EXPECT_LT(averaged.penumbra_mae, pcss.penumbra_mae);
    EXPECT_LT(pcss.penumbra_mae, hard.penumbra_mae);
    EXPECT_LT(std::abs(averaged.penumbra_width_error), 0.35);
    EXPECT_LT(averaged.penumbra_mae, 0.08);
}

// A sun with a size (the real sun's 0.53 degrees) 45 degrees from the zenith over a roof 20 m
// up: the truth has a penumbra h (tan(45 + alpha) - tan(45 - alpha)) = 37 cm wide on the
// ground, about 12 pixels here. PCSS sizes its filter from the blockers' depth and the sun's
// angle (docs/raster.md, "A sun with a size"); a hard 3x3 PCF keeps a texel-wide edge. Against
// the same soft oracle, PCSS is wrong on fewer pixels and closer inside the penumbra.
TEST_F(Verdict, PcssOnASunWithASizeIsJudgedAgainstItsSoftTruthAndBeatsHardPcf) {
    test::SceneBuilder b;
    b.grid({10, 0, 10}, {20, 0, 0}, {0, 0, -20}, 8, 8);                // the ground where the roof's edge casts
    b.quad({-10, 20, 15}, {0, 20, 15}, {0, 20, -15}, {-10, 20, -15});  // the roof, x < 0
    const double s45 = std::sqrt(0.5);
    Light sun = test::directional({s45, -s45, 0});
    sun.angular_diameter_rad = 0.53 * 3.14159265358979323846 / 180.0;
    Scenario sc = test::make_scenario(b.build(), test::look_at({23, 6, 6}, {20, 0, 0}, 30), {sun}, 160, 120);
    ValidateOptions options;
    options.use_cache = false;
    const auto truth = std::make_shared<const OracleRun>(oracle_for(sc, options));
    raster::RasterSession session(sc, *ctx_);
    auto score = [&](const nlohmann::json& technique_json) {
        const ValidateResult r = run(sc, technique_json, &session, truth);
        EXPECT_TRUE(r.score.lights[0].soft.has_value()) << "a sun with a size is scored as soft";
        return r.score.lights[0];
    };
    const nlohmann::json bias = {{"slope", 1.5}, {"constant", 8}};
    const metrics::LightScore pcf =
        score({{"resolution", 2048}, {"bias", bias}, {"filter", {{"type", "pcf"}, {"size", 3}}}});
    const metrics::LightScore pcss = score({{"preset", "pcss"}, {"resolution", 2048}, {"bias", bias}});
    ASSERT_TRUE(pcf.soft && pcss.soft);
    for (const auto* s : {&pcf, &pcss})
        std::printf("  wrong %.4f, visible %.4f, penumbra MAE %.4f, width error %+.3f\n", s->wrong_fraction,
                    static_cast<double>(s->wrong_visible) / static_cast<double>(s->pixels.scored),
                    s->soft->penumbra_mae, s->soft->penumbra_width_error);
    EXPECT_GT(pcf.soft->penumbra_pixels, 800u) << "the truth has a penumbra";
    EXPECT_LT(pcss.wrong_fraction, pcf.wrong_fraction);
    EXPECT_LT(pcss.soft->penumbra_mae, pcf.soft->penumbra_mae);
    EXPECT_GT(pcss.soft->penumbra_width_error, pcf.soft->penumbra_width_error);
}

// A point light beside the scene's box, off its edge: off the faces' axes the depth along the
// axis is less than the distance to the box, and a near plane at that distance put the block
// at the box's edge and the cube over it in front of the map (both compared as lit). The
// cube's shadow on the block must be there, with the d3d12-textbook preset as with any.
TEST_F(Verdict, APointLightOffTheSceneBoxsEdgeShadowsReceiversNearThatEdge) {
    test::SceneBuilder b;
    b.quad({-5, 0, -5}, {-5, 0, 5}, {5, 0, 5}, {5, 0, -5});
    b.box({3, 0, -1}, {5, 2, 1});            // a block at the box's edge
    b.box({4, 2.3, -0.3}, {4.6, 2.6, 0.3});  // a cube over it, casting onto its top
    Scenario sc =
        test::make_scenario(b.build(), test::look_at({1, 7, 7}, {4, 2, 0}, 40), {test::point({7, 5, 0})}, 320, 240);
    const metrics::LightScore s = judge(sc, {{"preset", "d3d12-textbook"}}).score;
    EXPECT_GT(s.pixels.scored, 20000u);
    EXPECT_LT(s.count(PixelClass::false_lit), 5u);
}

// Issue #34's first "done when": on a long view (a 300 m ground with props, the camera near it
// looking along it) four cascades of 1024^2 alias less than one 2048^2 map of the same fit (one
// cascade's bounding sphere of the whole range): the same texel budget, spent near the camera.
// report.json's cascades then split the pixels by the cascade that judged them.
TEST_F(Verdict, FourCascadesOf1024AliasLessThanOne2048MapOnALongView) {
    test::SceneBuilder b;
    b.grid({-40, 0, 0}, {80, 0, 0}, {0, 0, -300}, 4, 30);
    for (int k = 0; k < 40; ++k) {
        const double z = -3.0 - 7.0 * k, x = (k % 2 ? -1.0 : 1.0) * (1.5 + (k * 7) % 9);
        b.box({x - 0.8, 0, z - 0.8}, {x + 0.8, 1.2 + 0.05 * (k % 7), z + 0.8});
        b.box({x - 0.1, 0, z + 1.5}, {x + 0.1, 2.5, z + 1.7});  // a post: thin shadows alias first
    }
    Camera cam = test::look_at({0, 1.7, 2}, {0, 1.0, -60}, 50);
    cam.znear = 0.1;
    cam.zfar = 300;
    const Scenario sc = test::make_scenario(b.build(), cam, {test::directional({0.5, -0.6, -0.3})}, 480, 300);
    const auto technique = [](int count, int resolution) {
        return nlohmann::json{{"family", "cascaded"},
                              {"resolution", resolution},
                              {"cascades", {{"count", count}, {"split", "practical"}, {"max_distance", 300}}}};
    };
    const ValidateResult one = run(sc, technique(1, 2048));
    const ValidateResult four = run(sc, technique(4, 1024));
    const metrics::LightScore &a = one.score.lights[0], &c = four.score.lights[0];
    EXPECT_GT(c.pixels.scored, 50000u);
    EXPECT_GT(a.count(PixelClass::aliasing), 200u);  // the single map does alias here
    EXPECT_LT(c.count(PixelClass::aliasing), a.count(PixelClass::aliasing) / 2);
    EXPECT_LT(c.wrong, a.wrong);

    const nlohmann::json& cascades = four.report.at("lights")[0].at("cascades");
    ASSERT_EQ(cascades.size(), 4u);
    std::uint64_t scored = 0, aliasing = 0;
    double previous_texel = 0;
    for (std::size_t k = 0; k < 4; ++k) {
        const nlohmann::json& e = cascades[k];
        EXPECT_EQ(e.at("index"), k);
        EXPECT_GT(e.at("texel_m").get<double>(), previous_texel);
        previous_texel = e.at("texel_m").get<double>();
        EXPECT_LT(e.at("near_m").get<double>(), e.at("far_m").get<double>());
        scored += e.at("pixels").at("scored").get<std::uint64_t>();
        aliasing += e.at("counts").at("aliasing").get<std::uint64_t>();
    }
    // Scored pixels lie within max_distance = zfar, so in a cascade (the receiver bias may push a
    // few at the far end beyond it).
    EXPECT_LE(scored, c.pixels.scored);
    EXPECT_GE(scored, c.pixels.scored * 99 / 100);
    EXPECT_LE(aliasing, c.count(PixelClass::aliasing));
    EXPECT_FALSE(one.report.at("lights")[0].contains("cascades") &&
                 one.report.at("lights")[0].at("cascades").size() != 1u);
}

// SDSM (Lauritzen et al. 2011) on a view that sees only 21-29 m of a camera range of 0.1-300 m
// (a wall tilted away, boxes standing out of it): the splits placed between the visible depths
// spend the texels where the samples are, so it aliases no more than the same cascades placed
// over the camera's range; report.json gives the range.
TEST_F(Verdict, SdsmCascadesAliasNoMoreThanTheCamerasRangeOnAWallView) {
    test::SceneBuilder b;
    const auto wall_z = [](double y) { return -20 - (y + 15) * 10.0 / 33; };
    b.quad({-30, -15, wall_z(-15)}, {30, -15, wall_z(-15)}, {30, 18, wall_z(18)}, {-30, 18, wall_z(18)});
    for (double y : {-8.0, -3.0, 2.0, 7.0})
        for (double x : {-6.0, 0.0, 6.0}) b.box({x - 0.5, y - 0.5, wall_z(y)}, {x + 0.5, y + 0.5, wall_z(y) + 1.5});
    Camera cam = test::look_at({0, 0, 0}, {0, 0, -25}, 50);
    cam.znear = 0.1;
    cam.zfar = 300;
    const Scenario sc = test::make_scenario(b.build(), cam, {test::directional({0.4, -0.3, -0.87})}, 480, 300);
    const auto technique = [](bool sdsm) {
        return nlohmann::json{
            {"family", "cascaded"}, {"resolution", 512}, {"cascades", {{"split", "practical"}, {"sdsm", sdsm}}}};
    };
    const ValidateResult plain = run(sc, technique(false));
    const ValidateResult sdsm = run(sc, technique(true));
    const metrics::LightScore &a = plain.score.lights[0], &c = sdsm.score.lights[0];
    EXPECT_GT(c.pixels.scored, 50000u);
    EXPECT_GT(a.count(PixelClass::aliasing), 0u);
    EXPECT_LE(c.count(PixelClass::aliasing), a.count(PixelClass::aliasing));
    EXPECT_LE(c.wrong, a.wrong);
    const nlohmann::json& light = sdsm.report.at("lights")[0];
    ASSERT_TRUE(light.contains("sdsm"));
    const double near = light.at("sdsm").at("near_m"), far = light.at("sdsm").at("far_m");
    EXPECT_GT(near, 20.0);
    EXPECT_LT(far, 30.0);
    for (const nlohmann::json& e : light.at("cascades")) {
        EXPECT_GE(e.at("near_m").get<double>(), near);
        EXPECT_LE(e.at("far_m").get<double>(), far);
    }
    EXPECT_FALSE(plain.report.at("lights")[0].contains("sdsm"));
    EXPECT_GT(sdsm.raster.stats.gpu_ms["sdsm_reduce"], 0.0);
    std::printf("  sdsm range %.3f..%.3f m, sdsm_reduce %.4f ms\n", near, far, sdsm.raster.stats.gpu_ms["sdsm_reduce"]);
}

}  // namespace
}  // namespace penumbra
