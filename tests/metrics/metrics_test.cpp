// metrics on synthetic frames: every rule of docs/metrics.md's error classes, the exclusions, the
// summary numbers, the perceptual error and the gates. No Embree, no Vulkan.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <set>

#include "common/errors.h"
#include "metrics/classification.h"
#include "metrics/gate.h"
#include "metrics/metric_table.h"
#include "metrics/perceptual.h"
#include "tests/metrics/synthetic_frames.h"

namespace penumbra::metrics {
namespace {

using test::Frames;

PixelClass class_of(const FrameScore& s, std::size_t i) {
    return static_cast<PixelClass>(s.images[0].cls[i]);
}

TEST(Classification, AgreementScoresEveryPixelAndFindsNothingWrong) {
    Frames f(8, 4);
    FrameScore s = f.score();
    EXPECT_EQ(s.lights[0].pixels.surface, 32u);
    EXPECT_EQ(s.lights[0].pixels.scored, 32u);
    EXPECT_EQ(s.lights[0].wrong, 0u);
    EXPECT_EQ(s.lights[0].mae, 0.0);
    EXPECT_EQ(class_of(s, 5), PixelClass::correct);
}

TEST(Classification, ExcludedPixelsAreCountedButNotScored) {
    Frames f(4, 2);
    f.o.A[0] = 0;  // background in both
    f.r.A[0] = 0;
    f.o.prim[0] = f.r.prim[0] = kNoPrimitive;
    f.r.prim[1] = 8;          // the raster path saw another triangle
    f.ol().lightable[2] = 0;  // faces away
    f.ol().V[2] = 0;
    f.ol().U[3] = 1;  // ambiguous truth
    // Every excluded pixel also disagrees, which must not count.
    for (std::size_t i = 1; i < 4; ++i) f.rl().V[i] = 1.0f - f.ol().V[i];
    FrameScore s = f.score();
    const LightScore& l = s.lights[0];
    EXPECT_EQ(l.pixels.surface, 7u);
    EXPECT_EQ(l.pixels.coverage_mismatch, 1u);
    EXPECT_EQ(l.pixels.back_facing, 1u);
    EXPECT_EQ(l.pixels.uncertain, 1u);
    EXPECT_EQ(l.pixels.scored, 4u);
    EXPECT_EQ(l.wrong, 0u);
    EXPECT_EQ(class_of(s, 0), PixelClass::background);
    EXPECT_EQ(class_of(s, 1), PixelClass::coverage_mismatch);
    EXPECT_EQ(class_of(s, 2), PixelClass::back_facing);
    EXPECT_EQ(class_of(s, 3), PixelClass::uncertain);
}

TEST(Classification, SurfaceOnlyTheRasterSawIsACoverageMismatch) {
    Frames f(2, 1);
    f.o.A[0] = 0;
    f.o.prim[0] = kNoPrimitive;
    FrameScore s = f.score();
    EXPECT_EQ(class_of(s, 0), PixelClass::coverage_mismatch);
    EXPECT_EQ(s.lights[0].pixels.surface, 1u);  // the oracle's surfaces only
}

TEST(Classification, ToleranceAddsTheOraclesConfidenceBound) {
    Frames f(3, 1);
    f.ol().V = {0.5f, 0.5f, 0.5f};
    f.ol().E = {0.0f, 0.1f, 0.1f};
    f.rl().V = {0.5f + 3.0f / 255.0f, 0.58f, 0.62f};
    FrameScore s = f.score();
    EXPECT_NE(class_of(s, 0), PixelClass::correct);  // 3/255 > 1/255, exact truth
    EXPECT_EQ(class_of(s, 1), PixelClass::correct);  // 0.08 within 1/255 + 0.1
    EXPECT_NE(class_of(s, 2), PixelClass::correct);  // 0.12 beyond it
}

TEST(Classification, NearATrueBoundaryWithinTheFiltersReachIsAliasing) {
    Frames f(3, 1);
    for (std::size_t i = 0; i < 3; ++i) f.rl().V[i] = 0.0f;  // false shadow everywhere
    f.lk().stored_prim.assign(3, 99u);                       // cast by another triangle, far in front
    f.lk().stored_depth.assign(3, 0.1f);
    f.ol().boundary_m = {0.009f, 0.024f, 0.026f};  // footprint 0.01 m
    ScoringOptions pcf5;
    pcf5.filter_reach_texels = 2.5f;
    FrameScore s = f.score(pcf5);
    EXPECT_EQ(class_of(s, 0), PixelClass::aliasing);
    EXPECT_EQ(class_of(s, 1), PixelClass::aliasing);
    EXPECT_EQ(class_of(s, 2), PixelClass::false_shadow);
    FrameScore narrow = f.score();  // one texel
    EXPECT_EQ(class_of(narrow, 1), PixelClass::false_shadow);
}

TEST(Classification, FalseShadowFromTheReceiversOwnSurfaceIsAcne) {
    Frames f(4, 1);
    f.rl().V.assign(4, 0.0f);
    // 0: the centre texel holds the receiver's own triangle, 0.002 depth units in front.
    f.lk().ref_depth[0] = 0.502f;
    f.lk().stored_depth[0] = 0.5f;
    // 1: another triangle (a coplanar neighbour) within the receiver plane's slope.
    f.lk().stored_prim[1] = 8;
    f.lk().ref_depth[1] = 0.50005f;
    f.lk().stored_depth[1] = 0.5f;
    // 2: another triangle well in front: a real (but false) occluder.
    f.lk().stored_prim[2] = 8;
    f.lk().stored_depth[2] = 0.3f;
    // 3: own triangle, but the lookup fell outside the map.
    f.lk().flags[3] |= kRasterOutsideMap;
    f.lk().stored_depth[3] = kNoDistance;
    FrameScore s = f.score();
    EXPECT_EQ(class_of(s, 0), PixelClass::acne);
    EXPECT_EQ(class_of(s, 1), PixelClass::acne);
    EXPECT_EQ(class_of(s, 2), PixelClass::false_shadow);
    EXPECT_EQ(class_of(s, 3), PixelClass::false_shadow);
    // Acne depth: how far (metres) the receiver sits behind its stored surface.
    EXPECT_NEAR(s.lights[0].acne_depth.max, 0.002 * 10.0, 1e-6);
    EXPECT_NEAR(s.lights[0].acne_depth.mean, (0.002 * 10.0 + 0.00005 * 10.0) / 2, 1e-6);
}

// With a filter, a pixel's centre texel can hold the receiver in front (lit) while other taps
// darken it: no depth is measured there, and it must not read as "0 m more bias would cure it".
TEST(Classification, AcneDepthLeavesOutPixelsOnlyFilterTapsDarkened) {
    Frames f(3, 1);
    f.rl().V.assign(3, 0.0f);
    f.lk().ref_depth = {0.502f, 0.499f, 0.499f};  // 0: behind its own surface; 1, 2: in front of it
    f.lk().stored_depth.assign(3, 0.5f);
    const LightScore l = f.score().lights[0];
    EXPECT_EQ(l.count(PixelClass::acne), 3u);
    EXPECT_EQ(l.acne_depth_pixels, 1u);
    EXPECT_NEAR(l.acne_depth.mean, 0.002 * 10.0, 1e-6) << "the two unmeasured pixels are not averaged in as 0";
    EXPECT_NEAR(l.acne_depth.max, 0.002 * 10.0, 1e-6);
    EXPECT_EQ(to_json(l)["acne_depth"]["pixels"], 1);
    // Only filter-darkened acne: nothing measured, and the report says so with pixels = 0.
    f.lk().ref_depth.assign(3, 0.499f);
    const LightScore none = f.score().lights[0];
    EXPECT_EQ(none.count(PixelClass::acne), 3u);
    EXPECT_EQ(none.acne_depth_pixels, 0u);
}

TEST(Classification, LightLostToBiasIsPeterPanningAndReportsTheGap) {
    Frames f(3, 1);
    f.lk().bias_m.assign(3, 0.05f);  // + one 0.01 m texel = 0.06 m reach
    f.shadow(0, 0.03f);
    f.shadow(1, 0.059f);
    f.shadow(2, 0.2f);
    FrameScore s = f.score();  // the raster says lit everywhere
    EXPECT_EQ(class_of(s, 0), PixelClass::peter_panning);
    EXPECT_EQ(class_of(s, 1), PixelClass::peter_panning);
    EXPECT_EQ(class_of(s, 2), PixelClass::false_lit);
    EXPECT_NEAR(s.lights[0].peter_panning_gap.max, 0.059, 1e-6);
    EXPECT_NEAR(s.lights[0].peter_panning_gap.mean, 0.0445, 1e-6);
    EXPECT_NEAR(s.lights[0].rate(PixelClass::peter_panning), 2.0 / 3.0, 1e-12);
}

// docs/metrics.md, class 5: light in a true umbra, beyond the filter's and the bias's reach, is
// light_bleeding for a moment family and false_lit for any other; a penumbra, a pixel near a
// boundary or one within the bias reach keep their classes.
TEST(Classification, LightInATrueUmbraIsLightBleedingOnlyForMomentFamilies) {
    for (bool lookups : {true, false}) {
        Frames f(6, 1);
        f.rl().V.assign(6, 0.2f);  // the raster leaks 0.2 everywhere
        for (std::size_t i = 0; i < 6; ++i) f.shadow(i, 0.5f);
        f.ol().V[1] = 0.5f;  // a true penumbra, not an umbra (the raster brighter still)
        f.rl().V[1] = 0.8f;
        f.ol().boundary_m[2] = 0.005f;  // within one 0.01 m texel of a true boundary
        f.ol().occluder_m[3] = 0.005f;  // occluder within the bias reach (one texel)
        f.rl().V[4] = 0.0f;             // right
        // Just outside the umbra: V above tau + E (here 1.5 tau, E = 0) is a penumbra's edge.
        f.ol().V[5] = 1.5f * ScoringOptions{}.tolerance;
        f.rl().V[5] = 0.9f;
        ScoringOptions opt;
        opt.texel_footprint_m = 0.01f;  // V only: the scales the lookups give
        opt.bias_reach_m = 0.0f;
        if (!lookups) f.drop_lookups();
        const FrameScore depth_map = f.score(opt);
        EXPECT_EQ(class_of(depth_map, 0), PixelClass::false_lit) << lookups;
        EXPECT_EQ(depth_map.lights[0].count(PixelClass::light_bleeding), 0u);
        opt.light_bleeding = true;
        const FrameScore moments = f.score(opt);
        EXPECT_EQ(class_of(moments, 0), PixelClass::light_bleeding) << lookups;
        EXPECT_EQ(class_of(moments, 1), PixelClass::false_lit) << lookups;
        EXPECT_EQ(class_of(moments, 2), PixelClass::aliasing) << lookups;
        EXPECT_EQ(class_of(moments, 3), PixelClass::peter_panning) << lookups;
        EXPECT_EQ(class_of(moments, 4), PixelClass::correct) << lookups;
        EXPECT_EQ(class_of(moments, 5), PixelClass::false_lit) << lookups;
        EXPECT_EQ(moments.lights[0].count(PixelClass::light_bleeding), 1u);
        EXPECT_EQ(moments.lights[0].count_visible(PixelClass::light_bleeding), 1u);  // 0.2 >= 0.1
        EXPECT_EQ(to_json(moments.lights[0])["counts"]["light_bleeding"], 1);
        EXPECT_EQ(to_json(depth_map.lights[0])["counts"]["light_bleeding"], 0);
    }
}

TEST(Classification, AliasingTakesPrecedenceOverAcneAndPeterPanning) {
    Frames f(2, 1);
    f.rl().V[0] = 0.0f;                    // own-surface false shadow ...
    f.shadow(1, 0.001f);                   // ... and a lost contact shadow
    f.ol().boundary_m = {0.005f, 0.005f};  // both half a texel from a true boundary
    FrameScore s = f.score();
    EXPECT_EQ(class_of(s, 0), PixelClass::aliasing);
    EXPECT_EQ(class_of(s, 1), PixelClass::aliasing);
}

TEST(Classification, SummaryNumbersUseScoredPixelsAsTheDenominator) {
    Frames f(4, 1);
    f.ol().U[3] = 1;                      // not scored
    f.rl().V = {1.0f, 0.5f, 0.0f, 0.0f};  // errors 0, -0.5, -1 (pixel 3 unscored)
    f.lk().stored_prim.assign(4, 99u);
    f.lk().stored_depth.assign(4, 0.1f);
    FrameScore s = f.score();
    const LightScore& l = s.lights[0];
    EXPECT_EQ(l.pixels.scored, 3u);
    EXPECT_NEAR(l.mae, 1.5 / 3, 1e-9);
    EXPECT_NEAR(l.rmse, std::sqrt(1.25 / 3), 1e-7);
    EXPECT_NEAR(l.bias, -1.5 / 3, 1e-9);
    EXPECT_NEAR(l.wrong_fraction, 2.0 / 3, 1e-12);
    EXPECT_EQ(l.counts[3], 2u);  // false_shadow
    EXPECT_FLOAT_EQ(s.images[0].error[2], -1.0f);
    EXPECT_FLOAT_EQ(s.images[0].error[3], 0.0f);
}

TEST(Classification, ASceneWithoutLightsHasNothingToScore) {
    Frames f(4, 2);
    f.o.lights.clear();
    f.r.lights.clear();
    FrameScore s = score_frames(f.o, f.r, {});
    EXPECT_TRUE(s.lights.empty());
}

TEST(Classification, RefusesFramesOfDifferentShape) {
    Frames a(4, 2), b(2, 4);
    ScoringOptions opt;
    EXPECT_THROW(score_frames(a.o, b.r, std::span(&opt, 1)), std::invalid_argument);
    b = Frames(4, 2);
    b.r.lights[0].lookups->depth_to_m.clear();
    EXPECT_THROW(score_frames(a.o, b.r, std::span(&opt, 1)), std::invalid_argument);
}

TEST(Classification, ReportObjectHasDesignKeys) {
    Frames f(2, 2);
    nlohmann::json j = to_json(f.score().lights[0]);
    for (const char* k : {"surface", "scored", "back_facing", "uncertain", "coverage_mismatch"})
        EXPECT_TRUE(j["pixels"].contains(k)) << k;
    for (const char* k : {"acne", "peter_panning", "aliasing", "false_shadow", "false_lit"}) {
        EXPECT_TRUE(j["counts"].contains(k)) << k;
        EXPECT_TRUE(j["rates"].contains(k)) << k;
    }
    for (const char* k : {"mae", "rmse", "wrong_fraction"}) EXPECT_TRUE(j[k].is_number()) << k;
    EXPECT_TRUE(j["peter_panning_gap"]["max"].is_number());
}

// ---- V only: the classes from the oracle's geometry

TEST(VOnly, ClassesRestOnTheOraclesGeometryWithGivenScales) {
    Frames f(6, 1);
    f.drop_lookups();
    // 0: darker, 0.015 m from a true boundary: aliasing (reach 2 x 0.01 m).
    f.rl().V[0] = 0.0f;
    f.ol().boundary_m[0] = 0.015f;
    // 1: darker, nothing between the receiver and the light: acne.
    f.rl().V[1] = 0.0f;
    // 2: darker inside a true penumbra (an occluder on some rays): false shadow.
    f.ol().V[2] = 0.5f;
    f.ol().occluder_m[2] = 0.3f;
    f.rl().V[2] = 0.1f;
    // 3, 4: a lost shadow with the occluder within bias + one texel (0.04 + 0.01), and beyond.
    f.shadow(3, 0.049f);
    f.shadow(4, 0.2f);
    // 5: correct.
    ScoringOptions opt;
    opt.filter_reach_texels = 2;
    opt.texel_footprint_m = 0.01f;
    opt.bias_reach_m = 0.04f;
    FrameScore s = f.score(opt);
    EXPECT_EQ(class_of(s, 0), PixelClass::aliasing);
    EXPECT_EQ(class_of(s, 1), PixelClass::acne);
    EXPECT_EQ(class_of(s, 2), PixelClass::false_shadow);
    EXPECT_EQ(class_of(s, 3), PixelClass::peter_panning);
    EXPECT_EQ(class_of(s, 4), PixelClass::false_lit);
    EXPECT_EQ(class_of(s, 5), PixelClass::correct);
    const ClassificationEvidence& ev = s.lights[0].evidence;
    EXPECT_EQ(ev.source, Evidence::oracle_geometry);
    EXPECT_EQ(ev.texel_footprint_source, ScaleSource::given);
    EXPECT_FLOAT_EQ(ev.texel_footprint_m, 0.01f);
    EXPECT_EQ(ev.bias_reach_source, ScaleSource::given);
    EXPECT_FLOAT_EQ(ev.bias_reach_m, 0.04f);
    EXPECT_NEAR(s.lights[0].peter_panning_gap.max, 0.049, 1e-6);
    EXPECT_EQ(s.lights[0].acne_depth.max, 0.0) << "unknown without the lookups";
}

TEST(VOnly, WithLookupsTheLookupsDecide) {
    Frames f(2, 1);
    f.rl().V[0] = 0.0f;
    f.lk().stored_prim[0] = 99;  // another triangle far in front: a false shadow, not acne
    f.lk().stored_depth[0] = 0.1f;
    FrameScore with = f.score();
    EXPECT_EQ(with.lights[0].evidence.source, Evidence::depth_map_lookups);
    EXPECT_EQ(class_of(with, 0), PixelClass::false_shadow);
    f.drop_lookups();
    FrameScore without = f.score();
    EXPECT_EQ(without.lights[0].evidence.source, Evidence::oracle_geometry);
    EXPECT_EQ(class_of(without, 0), PixelClass::acne) << "nothing lies between the receiver and the light";
}

// A 200 x 40 frame whose column x lies x millimetres from a true boundary. The technique is
// wrong (darker) in the first `band_mm` columns on every other row, and on `far_every`-th
// pixel elsewhere (0: nowhere).
Frames boundary_profile(int band_mm, int far_every) {
    Frames f(200, 40);
    f.drop_lookups();
    for (int y = 0; y < 40; ++y)
        for (int x = 0; x < 200; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * 200 + x;
            f.ol().boundary_m[i] = 0.001f * static_cast<float>(x) + 0.0005f;
            const bool near = x < band_mm && y % 2 == 0;
            const bool far = far_every > 0 && x >= band_mm && i % static_cast<std::size_t>(far_every) == 0;
            if (near || far) f.rl().V[i] = 0.0f;
        }
    return f;
}

TEST(VOnly, EstimatesTheFootprintFromTheErrorProfileAcrossBoundaries) {
    Frames f = boundary_profile(24, 97);  // aliasing within 24 mm, sparse acne beyond
    ScoringOptions opt;
    opt.filter_reach_texels = 2;
    FrameScore s = f.score(opt);
    const ClassificationEvidence& ev = s.lights[0].evidence;
    EXPECT_EQ(ev.texel_footprint_source, ScaleSource::estimated);
    EXPECT_NEAR(ev.texel_footprint_m, 0.012, 0.0005);  // the 24 mm band / reach 2
    EXPECT_EQ(class_of(s, 3), PixelClass::aliasing);
    EXPECT_EQ(s.lights[0].count(PixelClass::aliasing), 20u * 24u);
    EXPECT_GT(s.lights[0].count(PixelClass::acne), 50u);
    // The given footprint overrides the estimate.
    opt.texel_footprint_m = 0.001f;
    const FrameScore given = f.score(opt);
    EXPECT_EQ(given.lights[0].evidence.texel_footprint_source, ScaleSource::given);
    EXPECT_LT(given.lights[0].count(PixelClass::aliasing), 20u * 3u);
}

TEST(VOnly, NoFootprintIsEstimatedWhenErrorsAreNotNearBoundaries) {
    Frames f = boundary_profile(0, 3);  // acne everywhere, at one rate
    FrameScore s = f.score();
    EXPECT_EQ(s.lights[0].evidence.texel_footprint_source, ScaleSource::not_found);
    EXPECT_EQ(s.lights[0].evidence.texel_footprint_m, 0.0f);
    EXPECT_EQ(s.lights[0].count(PixelClass::aliasing), 0u);
    EXPECT_EQ(s.lights[0].count(PixelClass::acne), s.lights[0].wrong);
}

TEST(VOnly, EstimatesTheBiasReachFromLostShadows) {
    // Every pixel truly shadowed; column x's occluder is x centimetres away. The technique
    // loses 3 of 4 shadows within 12 cm of their occluder, 1 in 50 beyond.
    Frames f(100, 20);
    f.drop_lookups();
    for (std::size_t i = 0; i < f.rl().V.size(); ++i) {
        const int x = static_cast<int>(i % 100);
        f.shadow(i, 0.01f * static_cast<float>(x) + 0.005f);
        const bool lost = x < 12 ? i % 4 != 0 : i % 50 == 0;
        f.rl().V[i] = lost ? 1.0f : 0.0f;
    }
    ScoringOptions opt;
    opt.texel_footprint_m = 0.0f;  // no aliasing band
    FrameScore s = f.score(opt);
    const ClassificationEvidence& ev = s.lights[0].evidence;
    EXPECT_EQ(ev.bias_reach_source, ScaleSource::estimated);
    EXPECT_NEAR(ev.bias_reach_m, 0.115, 0.011);
    EXPECT_EQ(class_of(s, 1), PixelClass::peter_panning);
    EXPECT_EQ(class_of(s, 50), PixelClass::false_lit);
    EXPECT_NEAR(s.lights[0].peter_panning_gap.max, 0.115, 0.011);
}

TEST(VOnly, EstimatorsAreDeterministicAndRefuseThinEvidence) {
    std::vector<DistanceSample> samples;
    for (int k = 0; k < 1000; ++k) samples.push_back({0.001f * static_cast<float>(k % 100), k % 100 < 10});
    const auto band = estimate_aliasing_band_m(samples);
    ASSERT_TRUE(band);
    EXPECT_FLOAT_EQ(*band, 0.009f);
    std::reverse(samples.begin(), samples.end());
    EXPECT_EQ(estimate_aliasing_band_m(samples), band);
    EXPECT_EQ(estimate_bias_reach_m(samples), band);
    EXPECT_FALSE(estimate_aliasing_band_m({}));
    EXPECT_FALSE(estimate_bias_reach_m({}));
    // Fewer than kMinBandFlagged flagged samples: no band.
    std::vector<DistanceSample> thin;
    for (int k = 0; k < 1000; ++k) thin.push_back({0.001f * static_cast<float>(k), k < 10});
    EXPECT_FALSE(estimate_aliasing_band_m(thin));
    EXPECT_FALSE(estimate_bias_reach_m(thin));
}

TEST(VOnly, RefusesGivenScalesThatAreNotLengths) {
    Frames f(2, 1);
    f.drop_lookups();
    ScoringOptions opt;
    opt.texel_footprint_m = -1.0f;
    EXPECT_THROW(f.score(opt), std::invalid_argument);
    opt.texel_footprint_m.reset();
    opt.bias_reach_m = std::nanf("");
    EXPECT_THROW(f.score(opt), std::invalid_argument);
}

// ---- perceptual error

std::vector<float> disc(int w, int h, float radius, float inside, float outside) {
    std::vector<float> v(static_cast<std::size_t>(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            v[static_cast<std::size_t>(y) * w + x] = std::hypot(x - w / 2.0f, y - h / 2.0f) < radius ? inside : outside;
    return v;
}

TEST(Perceptual, IdenticalImagesHaveNoError) {
    auto a = disc(64, 48, 10, 0.0f, 1.0f);
    auto e = perceptual_error(a, a, 64, 48, 67);
    for (float v : e) EXPECT_EQ(v, 0.0f);
}

TEST(Perceptual, BoundedAndGrowsWithTheDifference) {
    auto truth = disc(64, 48, 10, 0.0f, 1.0f);
    auto faint = disc(64, 48, 10, 0.9f, 1.0f);  // the shadow almost missing
    auto half = disc(64, 48, 10, 0.5f, 1.0f);
    auto ef = perceptual_error(truth, faint, 64, 48, 67), eh = perceptual_error(truth, half, 64, 48, 67);
    double sf = 0, sh = 0;
    for (std::size_t i = 0; i < ef.size(); ++i) {
        EXPECT_GE(ef[i], 0.0f);
        EXPECT_LE(ef[i], 1.0f);
        sf += ef[i];
        sh += eh[i];
    }
    EXPECT_GT(sf, sh);
    EXPECT_GT(sh, 0.0);
    // A difference far from the image's centre row range leaves distant rows at zero.
    EXPECT_EQ(ef[0], 0.0f);
}

TEST(Perceptual, SmallShiftOfAnEdgeCostsLessThanAMissingShadow) {
    auto truth = disc(96, 64, 16, 0.0f, 1.0f);
    auto shifted = disc(96, 64, 17, 0.0f, 1.0f);
    auto missing = disc(96, 64, 16, 1.0f, 1.0f);
    auto es = perceptual_error(truth, shifted, 96, 64, 67), em = perceptual_error(truth, missing, 96, 64, 67);
    double ss = 0, sm = 0;
    for (std::size_t i = 0; i < es.size(); ++i) {
        ss += es[i];
        sm += em[i];
    }
    EXPECT_LT(ss, 0.5 * sm);  // measured 0.26: the CSF blur spreads the one-pixel ring over about three
}

// A reference filtered once over the whole image scores like the banded one-off: bit for bit,
// whether the difference lies in a band in the middle, at either edge, or everywhere, and for
// every test picture after the first.
TEST(Perceptual, AReferenceFilteredOnceGivesTheSameBitsAsEachOneOff) {
    const int W = 80, H = 200;
    std::vector<float> truth(static_cast<std::size_t>(W) * H);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x)
            truth[static_cast<std::size_t>(y) * W + x] = ((x / 7 + y / 5) % 3 == 0) ? 0.0f : 0.25f * float(x % 4);
    auto changed = [&](int y0, int y1, float v) {
        std::vector<float> t = truth;
        for (int y = y0; y < y1; ++y)
            for (int x = 10 + y % 13; x < W - 5; x += 3) t[static_cast<std::size_t>(y) * W + x] = v;
        return t;
    };
    PerceptualReference reference(truth, W, H, 67);
    for (const auto& test : {changed(100, 104, 1.0f), changed(0, 2, 0.5f), changed(H - 3, H, 0.0f),
                             changed(0, H, 0.75f), truth, changed(150, 151, 0.1f)}) {
        const std::vector<float> once = perceptual_error(truth, test, W, H, 67);
        const std::vector<float> kept = reference.error(test);
        ASSERT_EQ(kept.size(), once.size());
        EXPECT_EQ(0, std::memcmp(kept.data(), once.data(), once.size() * sizeof(float)));
    }
    // And the middle band's rows far from the difference stay zero, as the one-off's do.
    EXPECT_EQ(reference.error(changed(100, 104, 1.0f))[static_cast<std::size_t>(20) * W + 40], 0.0f);
}

// ---- gates

LightScore light_with(std::uint64_t acne_per_10000, double gap_max) {
    LightScore s;
    s.pixels.scored = 10000;
    s.counts[error_class_index(PixelClass::acne)] = acne_per_10000;
    s.peter_panning_gap.max = gap_max;
    return s;
}

std::vector<Light> lights_of(std::initializer_list<LightType> types) {
    std::vector<Light> lights;
    for (LightType t : types) lights.emplace_back().type = t;
    return lights;
}

const std::vector<Light> kTwoSuns = lights_of({LightType::directional, LightType::directional});

Gate gate_file(const char* text, const std::vector<Light>& lights = kTwoSuns) {
    return parse_gate(nlohmann::json::parse(text), "gate.json", lights, GateOrigin::file);
}

// A class counts a pixel 1% too dark as it counts a missing shadow; the visible counts keep only
// errors of at least the threshold (a tie counts as visible).
TEST(Classification, VisibleCountsKeepErrorsFromTheThresholdUp) {
    Frames f(5, 1);
    f.lk().stored_prim.assign(5, 99u);  // false shadows: a foreign occluder well in front
    f.lk().stored_depth.assign(5, 0.1f);
    f.rl().V = {0.99f, 0.7500001f, 0.75f, 0.0f, 1.0f};  // errors -0.01, just under -0.25, -0.25, -1, 0
    ScoringOptions opt;
    opt.visible_threshold = 0.25f;
    const FrameScore s = f.score(opt);
    const LightScore& l = s.lights[0];
    EXPECT_EQ(l.count(PixelClass::false_shadow), 4u);
    EXPECT_EQ(l.count_visible(PixelClass::false_shadow), 2u);
    EXPECT_EQ(l.wrong_visible, 2u);
    EXPECT_NEAR(l.rate_visible(PixelClass::false_shadow), 2.0 / 5.0, 1e-12);
    EXPECT_EQ(l.count_visible(PixelClass::acne), 0u);
    const nlohmann::json j = to_json(l);
    EXPECT_EQ(j["counts_visible"]["false_shadow"], 2);
    EXPECT_EQ(j["counts"]["false_shadow"], 4);
    EXPECT_DOUBLE_EQ(j["rates_visible"]["false_shadow"].get<double>(), 0.4);
    EXPECT_FLOAT_EQ(s.images[0].visible_threshold, 0.25f);
    // Gates read them like any metric, a tie at the bound passing.
    const Gate g = gate_file(R"({"checks": [{"metric": "counts_visible.false_shadow", "max": 2},
        {"metric": "rates_visible.false_shadow", "max": 0.39}]})",
                             lights_of({LightType::directional}));
    const GateResult r = evaluate_gate(g, s.lights);
    ASSERT_EQ(r.outcomes.size(), 2u);
    EXPECT_TRUE(r.outcomes[0].passed) << "2 <= 2";
    EXPECT_FALSE(r.outcomes[1].passed) << "0.4 > 0.39";
}

// The reading names the class with the most visible pixels and its cure; faint errors alone,
// however many, name nothing.
TEST(Classification, TheReadingNamesTheDominantVisibleClass) {
    Frames f(4, 1);
    f.rl().V = {0.0f, 0.0f, 0.0f, 1.0f};  // own surface shadows three of four: acne
    f.lk().ref_depth.assign(4, 0.502f);
    f.lk().stored_depth.assign(4, 0.5f);
    const auto acne = reading_line(f.score().lights[0]);
    ASSERT_TRUE(acne);
    EXPECT_NE(acne->find("acne 75.0% of scored pixels (visible)"), std::string::npos) << *acne;
    EXPECT_NE(acne->find("penumbra tune"), std::string::npos) << *acne;
    f.rl().V = {0.95f, 0.95f, 0.95f, 1.0f};  // the same pixels, only 5% too dark
    EXPECT_FALSE(reading_line(f.score().lights[0]));
}

// Missing shadows: the map's causes by default; a family's own causes where it gives them (a
// family without a map never reads "check the fit"); geometry seen from behind first where the
// run measured enough of it, with the shadow pass's culling.
TEST(Classification, TheReadingOfMissingShadowsNamesTheCausesTheRunMeasured) {
    Frames f(4, 1);
    for (int i = 0; i < 4; ++i) f.shadow(i, 0.5f);  // the raster says lit everywhere: false_lit
    const LightScore l = f.score().lights[0];
    const auto plain = reading_line(l);
    ASSERT_TRUE(plain);
    EXPECT_NE(plain->find("check the fit and culling"), std::string::npos) << *plain;
    EXPECT_EQ(reading_line(l, RunFacts{0.04, "back", ""}), plain) << "below 5% of the frame: the usual reading";

    const auto volumes = reading_line(l, RunFacts{0, "", "casters the volumes leave out"});
    ASSERT_TRUE(volumes);
    EXPECT_NE(volumes->find("shadows missing: casters the volumes leave out"), std::string::npos) << *volumes;
    EXPECT_EQ(volumes->find("map"), std::string::npos) << *volumes;

    const auto behind = reading_line(l, RunFacts{0.2, "back", ""});
    ASSERT_TRUE(behind);
    EXPECT_NE(behind->find("in order: 20% of the frame meets the back of single-sided triangles"), std::string::npos)
        << *behind;
    EXPECT_NE(behind->find("which a shadow pass culling back faces drops as casters; culling; casters clipped"),
              std::string::npos)
        << *behind;
    const auto behind_volumes = reading_line(l, RunFacts{0.2, "", "casters the volumes leave out"});
    ASSERT_TRUE(behind_volumes);
    EXPECT_NE(behind_volumes->find("named in the warnings); casters the volumes leave out"), std::string::npos)
        << *behind_volumes;
}

// A camera path is gated on every frame: a frame in the middle that fails fails the path, and
// the outcome names it, though the last frame passes. temporal.* checks are judged once, over
// the path, and are refused for a scenario without one.
TEST(Gate, ACameraPathIsGatedOnItsWorstFrameAndItsFlicker) {
    const auto one_sun = lights_of({LightType::directional});
    const char* text = R"({"checks": [{"metric": "rates.acne", "max": 0.001},
        {"metric": "temporal.flicker_rate", "max": 0.01}, {"metric": "peter_panning_gap.max", "min": 0.5}]})";
    try {
        gate_file(text, one_sun);
        ADD_FAILURE() << "a temporal check without a camera path was accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("checks[1].metric: temporal.flicker_rate is measured over a camera "
                                             "path only"),
                  std::string::npos)
            << e.what();
    }
    const Gate g = parse_gate(nlohmann::json::parse(text), "gate.json", one_sun, GateOrigin::file, true);
    // Frames 0..2: acne 0.0005, 0.0123, 0.0005; the gap 1.0, 1.0, 0.7. No temporal numbers per frame.
    GateResult worst;
    const std::uint64_t acne[] = {5, 123, 5};
    const double gap[] = {1.0, 1.0, 0.7};
    std::vector<LightScore> last;
    for (int f = 0; f < 3; ++f) {
        last = {light_with(acne[f], gap[f])};
        const GateResult r = evaluate_gate(g, last);
        ASSERT_EQ(r.outcomes.size(), 2u) << "a frame skips the temporal check";
        fold_worst_frame(worst, r, f);
    }
    last[0].temporal = TemporalScore{1000, 20, 0.02};
    const GateResult path = camera_path_gate(evaluate_gate(g, last), worst);
    ASSERT_EQ(path.outcomes.size(), 3u);
    EXPECT_FALSE(path.passed);
    EXPECT_EQ(path.outcomes[0].failure(), "light 0: rates.acne = 0.0123 > 0.001 in frame 1");
    EXPECT_EQ(path.outcomes[1].metric, "temporal.flicker_rate");
    EXPECT_FALSE(path.outcomes[1].passed);
    EXPECT_FALSE(path.outcomes[1].frame) << "over the whole path, not one frame";
    EXPECT_TRUE(path.outcomes[2].passed);
    EXPECT_EQ(path.outcomes[2].frame, 2) << "the frame nearest to failing: 0.7 >= 0.5";
    EXPECT_DOUBLE_EQ(path.outcomes[2].value, 0.7);
    // The last frame alone would have passed the acne check: that was the silent pass.
    EXPECT_TRUE(evaluate_gate(g, last).outcomes[0].passed);
    last[0].temporal->flicker_rate = 0.001;
    EXPECT_TRUE(camera_path_gate(evaluate_gate(g, last), worst).outcomes[1].passed);
}

TEST(Gate, PassesAndFailsPerLightWithOneLinePerFailure) {
    Gate g = gate_file(R"({"checks": [{"metric": "rates.acne", "max": 0.001},
        {"metric": "peter_panning_gap.max", "max": 0.05, "light": 1}]})");
    const std::vector<LightScore> good = {light_with(5, 1.0), light_with(0, 0.01)};
    GateResult ok = evaluate_gate(g, good);
    EXPECT_TRUE(ok.passed);
    EXPECT_EQ(ok.outcomes.size(), 3u);  // acne on both lights, gap on light 1
    const std::vector<LightScore> worse = {light_with(123, 1.0), light_with(0, 0.07)};
    GateResult bad = evaluate_gate(g, worse);
    EXPECT_FALSE(bad.passed);
    ASSERT_EQ(bad.outcomes.size(), 3u);
    EXPECT_EQ(bad.outcomes[0].failure(), "light 0: rates.acne = 0.0123 > 0.001");
    EXPECT_TRUE(bad.outcomes[1].passed);
    EXPECT_EQ(bad.outcomes[2].failure(), "light 1: peter_panning_gap.max = 0.07 > 0.05");
    EXPECT_EQ(bad.outcomes[0].name(), "rates.acne <= 0.001");
}

// The verdict is every check's, not the last one's: the first of two checks failing fails the
// gate though the second passes, on one light and on a camera path's folded frames (#50).
TEST(Gate, AFailingFirstCheckFailsTheGateThoughTheLaterOnesPass) {
    const auto one_sun = lights_of({LightType::directional});
    const Gate g = gate_file(R"({"checks": [{"metric": "rates.acne", "max": 0.001},
        {"metric": "peter_panning_gap.max", "max": 0.05}]})",
                             one_sun);
    const std::vector<LightScore> first_fails = {light_with(123, 0.01)};
    const GateResult r = evaluate_gate(g, first_fails);
    ASSERT_EQ(r.outcomes.size(), 2u);
    EXPECT_FALSE(r.outcomes[0].passed);
    EXPECT_TRUE(r.outcomes[1].passed);
    EXPECT_FALSE(r.passed) << "the gate took the last check's verdict";
    // Over a path: a failing first frame, then a passing one.
    GateResult worst;
    fold_worst_frame(worst, r, 0);
    const std::vector<LightScore> passes = {light_with(5, 0.01)};
    const GateResult later = evaluate_gate(g, passes);
    ASSERT_TRUE(later.passed);
    fold_worst_frame(worst, later, 1);
    EXPECT_FALSE(worst.passed) << "a later passing frame cleared an earlier failure";
    EXPECT_FALSE(camera_path_gate(later, worst).passed);
}

TEST(Gate, MinimumBounds) {
    Gate g = gate_file(R"({"checks": [{"metric": "pixels.scored", "min": 100}]})", lights_of({LightType::spot}));
    LightScore l;
    l.pixels.scored = 50;
    GateResult r = evaluate_gate(g, std::span(&l, 1));
    EXPECT_FALSE(r.passed);
    EXPECT_EQ(r.outcomes[0].failure(), "light 0: pixels.scored = 50 < 100");
}

TEST(Gate, EveryMetricOfTheTableCanBeChecked) {
    Frames f = test::Frames(4, 2);
    ScoringOptions opt;
    opt.soft = true;
    LightScore area = f.score(opt).lights[0];
    area.temporal = TemporalScore{10, 1, 0.1};  // as over a camera path
    for (const Metric& m : metric_table()) {
        const std::string text = fmt::format(R"({{"checks": [{{"metric": "{}", "max": 1e9}}]}})", m.path);
        const Gate g =
            parse_gate(nlohmann::json::parse(text), "gate.json", lights_of({LightType::rect}), GateOrigin::file, true);
        const GateResult r = evaluate_gate(g, std::span(&area, 1));
        ASSERT_EQ(r.outcomes.size(), 1u) << m.path;
        EXPECT_TRUE(r.passed) << m.path;
        EXPECT_EQ(r.outcomes[0].value, *value_of(m, area)) << m.path;
    }
}

void expect_gate_error(const char* text, const std::string& fragment, const std::vector<Light>& lights = kTwoSuns,
                       GateOrigin origin = GateOrigin::file) {
    try {
        parse_gate(nlohmann::json::parse(text), "gate.json", lights, origin);
        ADD_FAILURE() << "accepted: " << text;
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
}

TEST(Gate, BadGatesNameThePathAndWhatWasExpected) {
    expect_gate_error(R"({"checks": [{"metric": "rates.acn", "max": 1}]})",
                      "gate.json: checks[0].metric: unknown metric \"rates.acn\"");
    expect_gate_error(R"({"checks": [{"metric": "rates", "max": 1}]})", "checks[0].metric");
    expect_gate_error(R"({"checks": [{"metric": "mae"}]})", "checks[0]: a check needs \"max\" or \"min\"");
    expect_gate_error(R"({"checks": [{"metric": "mae", "max": 1, "light": 2}]})", "checks[0].light");
    expect_gate_error(R"({"checks": [{"metric": "mae", "max": "x"}]})", "checks[0].max");
    expect_gate_error(R"({"checks": [{"metric": "mae", "max": 1, "limit": 2}]})", "checks[0].limit");
    expect_gate_error(R"({"checks": {"metric": "mae"}})", "checks");
    expect_gate_error(R"({"check": []})", "check");
    expect_gate_error(R"({"checks": [{"metric": "soft.penumbra_mae", "max": 1, "light": 1}]})",
                      "checks[0].light: soft.penumbra_mae applies to area lights only, and light 1 is a directional "
                      "light");
}

TEST(Gate, AnUnknownMetricListsTheTable) {
    try {
        gate_file(R"({"checks": [{"metric": "acne", "max": 1}]})");
        FAIL() << "accepted an unknown metric";
    } catch (const InputError& e) {
        const std::string what = e.what();
        for (const Metric& m : metric_table()) {
            EXPECT_NE(what.find(std::string(m.path) + " ("), std::string::npos) << m.path;
            EXPECT_NE(what.find(std::string(m.meaning)), std::string::npos) << m.meaning;
        }
    }
}

TEST(Gate, AGateGivenExplicitlyMustCheckSomething) {
    // No "gate" in the scenario reads as {}: no gate, nothing to check, fine.
    EXPECT_TRUE(parse_gate(nlohmann::json::object(), "s.json: gate", kTwoSuns, GateOrigin::scenario).checks.empty());
    // The same {} from a --gate file was given on purpose, and checks nothing.
    expect_gate_error("{}", "gate.json: the gate checks nothing: it has no \"checks\"");
    expect_gate_error(R"({"checks": []})", "gate.json: the gate checks nothing: its \"checks\" are empty", kTwoSuns,
                      GateOrigin::scenario);
    expect_gate_error(R"({"checks": [{"metric": "mae", "max": 1}]})",
                      "gate.json: the gate checks nothing: the scenario has no lights", {});
    expect_gate_error(R"({"checks": [{"metric": "soft.penumbra_mae", "max": 1}]})",
                      "gate.json: the gate checks nothing: its checks apply to area lights only, and the scenario "
                      "has none");
    // One area light among punctual ones: the soft check has a light to check.
    EXPECT_EQ(gate_file(R"({"checks": [{"metric": "soft.penumbra_mae", "max": 1}]})",
                        lights_of({LightType::spot, LightType::disk}))
                  .checks.size(),
              1u);
    // A sun with a size has a soft truth: its soft checks apply as an area light's do.
    std::vector<Light> soft_sun = lights_of({LightType::directional});
    soft_sun[0].angular_diameter_rad = 0.00925;
    EXPECT_EQ(gate_file(R"({"checks": [{"metric": "soft.penumbra_mae", "max": 1}]})", soft_sun).checks.size(), 1u);
}

TEST(Gate, AMetricTheLightDoesNotMeasureFailsTheCheck) {
    Frames f(2, 1);
    f.drop_lookups();
    const LightScore v_only = f.score().lights[0];
    const Gate g =
        gate_file(R"({"checks": [{"metric": "acne_depth.max", "max": 0.01}]})", lights_of({LightType::spot}));
    const GateResult r = evaluate_gate(g, std::span(&v_only, 1));
    ASSERT_EQ(r.outcomes.size(), 1u);
    EXPECT_FALSE(r.passed);
    EXPECT_EQ(r.outcomes[0].failure(), "light 0: acne_depth.max is not measured for this light (needs <= 0.01)");
}

// ---- the metrics table

TEST(MetricTable, EveryPathIsUniqueAndResolvesInTheReportObject) {
    Frames f(4, 2);
    ScoringOptions opt;
    opt.soft = true;
    LightScore area = f.score(opt).lights[0];
    area.temporal = TemporalScore{10, 1, 0.1};  // as over a camera path
    const nlohmann::json j = to_json(area);
    std::set<std::string_view> paths;
    for (const Metric& m : metric_table()) {
        EXPECT_TRUE(paths.insert(m.path).second) << "twice: " << m.path;
        EXPECT_EQ(find_metric(m.path), &m);
        EXPECT_NE(to_string(m.unit), "?") << m.path;
        EXPECT_FALSE(m.meaning.empty()) << m.path;
        std::string pointer(1, '/');
        for (char c : m.path) pointer.push_back(c == '.' ? '/' : c);
        const nlohmann::json& v = j.at(nlohmann::json::json_pointer(pointer));
        ASSERT_TRUE(v.is_number()) << m.path;
        EXPECT_EQ(v.is_number_integer(), m.unit == Unit::pixels) << m.path;
        EXPECT_EQ(v.get<double>(), *value_of(m, area)) << m.path;
    }
    EXPECT_EQ(find_metric("rates"), nullptr);
    EXPECT_EQ(find_metric("nope"), nullptr);
}

TEST(MetricTable, ScopesDecideWhatALightReports) {
    Frames f(2, 1);
    const LightScore punctual = f.score().lights[0];
    const nlohmann::json j = to_json(punctual);
    EXPECT_FALSE(j.contains("soft"));
    EXPECT_TRUE(j.contains("acne_depth"));
    EXPECT_EQ(j["evidence"], nlohmann::json({{"source", "depth_map_lookups"}}));
    EXPECT_FALSE(value_of(*find_metric("soft.penumbra_mae"), punctual));
    f.drop_lookups();
    ScoringOptions opt;
    opt.texel_footprint_m = 0.02f;
    const nlohmann::json v_only = to_json(f.score(opt).lights[0]);
    EXPECT_FALSE(v_only.contains("acne_depth")) << "not measured without the lookups";
    EXPECT_EQ(v_only["evidence"]["source"], "oracle_geometry");
    EXPECT_EQ(v_only["evidence"]["texel_footprint"], "given");
    EXPECT_FLOAT_EQ(v_only["evidence"]["texel_footprint_m"].get<float>(), 0.02f);
    EXPECT_EQ(v_only["evidence"]["bias_reach"], "not_found");
}

TEST(MetricTable, DocsListEveryMetric) {
    std::ifstream file(std::string(PENUMBRA_SOURCE_DIR) + "/docs/metrics.md");
    ASSERT_TRUE(file) << "docs/metrics.md";
    const std::string docs((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
    for (const Metric& m : metric_table())
        EXPECT_NE(docs.find(metric_doc_row(m)), std::string::npos) << "docs/metrics.md lacks the row\n"
                                                                   << metric_doc_row(m);
}

TEST(MetricTable, SummaryLineReadsTheTable) {
    Frames f(4, 1);
    f.rl().V[0] = 0.0f;   // one acne pixel of 4, visible
    f.rl().V[1] = 0.95f;  // and one of error 0.05, below the visible threshold 0.1
    EXPECT_EQ(summary_line(f.score().lights[0]),
              "wrong 25.000% visible (50.000% in all) of 4 scored px: acne 25.000% (50.000%)  peter_panning 0.000% "
              "(0.000%)  aliasing 0.000% (0.000%)  false_shadow 0.000% (0.000%)  false_lit 0.000% (0.000%)  ");
    f.drop_lookups();
    ScoringOptions opt;
    opt.texel_footprint_m = 0.01f;
    EXPECT_NE(summary_line(f.score(opt).lights[0]).find("(V only: footprint 0.01 m given, bias reach 0 m not_found)"),
              std::string::npos);
}

// Soft lights: a horizontal ramp from umbra through penumbra to full light, 100 px wide.
Frames soft_ramp() {
    Frames f(100, 4);
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 100; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * 100 + x;
            f.ol().V[i] = std::clamp((x - 20) / 60.0f, 0.0f, 1.0f);  // penumbra: x in (20, 80)
            f.ol().E[i] = f.ol().V[i] > 0 && f.ol().V[i] < 1 ? 0.003f : 0.0f;
            f.rl().V[i] = f.ol().V[i];
        }
    return f;
}

TEST(SoftScore, ARightPenumbraScoresNothingBeyondTheOraclesBound) {
    Frames f = soft_ramp();
    for (std::size_t i = 0; i < f.rl().V.size(); ++i) f.rl().V[i] += (i % 2 ? 0.002f : -0.002f);  // noise < E
    ScoringOptions opt;
    opt.soft = true;
    const LightScore s = f.score(opt).lights[0];
    ASSERT_TRUE(s.soft);
    EXPECT_EQ(s.soft->umbra_pixels + s.soft->penumbra_pixels + s.soft->lit_pixels, s.pixels.scored);
    EXPECT_GT(s.soft->penumbra_pixels, 200u);
    EXPECT_NEAR(s.soft->penumbra_mae, 0.002, 1e-4);
    EXPECT_EQ(s.soft->penumbra_mae_beyond_e, 0.0);
    EXPECT_NEAR(s.soft->penumbra_width_error, 0.0, 0.05);
    EXPECT_FALSE(f.score().lights[0].soft) << "punctual lights carry no soft score";
}

TEST(SoftScore, WidthErrorTellsHardFromWideShadows) {
    ScoringOptions opt;
    opt.soft = true;
    Frames hard = soft_ramp(), wide = soft_ramp();
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 100; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * 100 + x;
            hard.rl().V[i] = x < 50 ? 0.0f : 1.0f;
            wide.rl().V[i] = std::clamp((x - 5) / 90.0f, 0.0f, 1.0f);  // 1.5x as wide
        }
    const SoftScore h = *hard.score(opt).lights[0].soft, w = *wide.score(opt).lights[0].soft;
    EXPECT_NEAR(h.penumbra_width_error, -1.0, 1e-9);
    EXPECT_NEAR(w.penumbra_width_error, 0.5, 0.06);
    EXPECT_GT(h.penumbra_mae, 0.1);
    EXPECT_LT(h.umbra_mae + h.lit_mae, 1e-9);
    EXPECT_GT(h.penumbra_mae_beyond_e, h.penumbra_mae - 0.0031);
}

TEST(SoftScore, GatesNameSoftNumbersAndSkipPunctualLights) {
    Gate g = gate_file(R"({"checks": [{"metric": "soft.penumbra_mae_beyond_E", "max": 0.05}]})",
                       lights_of({LightType::rect, LightType::point}));
    Frames f = soft_ramp();
    ScoringOptions opt;
    opt.soft = true;
    std::vector<LightScore> lights = {f.score(opt).lights[0], f.score().lights[0]};
    GateResult r = evaluate_gate(g, lights);
    ASSERT_EQ(r.outcomes.size(), 1u) << "the punctual light has no soft numbers to check";
    EXPECT_TRUE(r.passed);
    lights[0].soft->penumbra_mae_beyond_e = 0.2;
    EXPECT_FALSE(evaluate_gate(g, lights).passed);
}

}  // namespace
}  // namespace penumbra::metrics
