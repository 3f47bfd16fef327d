// compare end to end on data/default (small image): an engine frame made from the oracle's own
// truth scores nothing wrong, penumbra's raster frame passed as an engine's scores what validate
// scores, a frame off by one pixel or flipped is refused with a message that says so, and bad
// image files are refused naming the file and what was expected.
#include "pipeline/compare.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>

#include "common/camera.h"
#include "common/errors.h"
#include "common/projection.h"
#include "image_io/image_io.h"
#include "pipeline/compare_files.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

constexpr int kW = 192, kH = 108;

Scenario small_default() {
    Scenario sc = load_scenario(std::filesystem::path(PENUMBRA_SOURCE_DIR) / "data/default/scenario.json");
    sc.width = kW;
    sc.height = kH;
    return sc;
}

CompareOptions no_cache() {
    CompareOptions o;
    o.validate.use_cache = false;
    return o;
}

// Moves an image's content by (dx, dy) pixels (x right, y down), or flips it vertically; pixels
// that come from outside keep `fill`.
std::vector<float> moved(const std::vector<float>& img, int dx, int dy, bool flip, float fill) {
    std::vector<float> out(img.size(), fill);
    for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x) {
            const int sx = x - dx, sy = flip ? kH - 1 - y : y - dy;
            if (sx >= 0 && sy >= 0 && sx < kW && sy < kH) out[y * kW + x] = img[sy * kW + sx];
        }
    return out;
}

class Compare : public ::testing::Test {
  protected:
    // A device that cannot be opened fails every test: a throw out of SetUpTestSuite would make
    // gtest skip them, and ctest count the skips as a pass.
    static void SetUpTestSuite() {
        try {
            prepare();
        } catch (const std::exception& e) {
            setup_error_ = e.what();
        }
    }
    void SetUp() override { ASSERT_TRUE(setup_error_.empty()) << "the suite could not be prepared: " << setup_error_; }
    static void prepare() {
        sc_ = new Scenario(small_default());
        ValidateOptions vo;
        vo.use_cache = false;
        truth_ = new OracleRun(oracle_for(*sc_, vo));
        // penumbra's own raster frame, as an engine would hand its shadow image over.
        raster::VulkanContext ctx;
        raster::RasterSession session(*sc_, ctx);
        const raster::Technique t = raster::parse_technique(sc_->technique, "test: technique", sc_->lights);
        const metrics::Gate none;
        validated_ = new ValidateResult(
            validate(*sc_, t, none, vo, &session, std::shared_ptr<const OracleRun>(truth_, [](const OracleRun*) {})));
    }
    static void TearDownTestSuite() {
        delete validated_;
        delete truth_;
        delete sc_;
    }

    // The oracle's V where it sees a surface, lit (1) on the background, as an engine's
    // ShadowMaterial over a white clear gives it.
    static EngineFrame perfect_engine() {
        EngineFrame f;
        f.width = kW;
        f.height = kH;
        for (const auto& l : truth_->frame.lights) {
            std::vector<float> v(l.V.size(), 1.0f);
            for (std::size_t i = 0; i < v.size(); ++i)
                if (truth_->frame.A[i] != 0) v[i] = l.V[i];
            f.V.push_back(std::move(v));
        }
        return f;
    }
    static EngineFrame raster_engine() {
        EngineFrame f;
        f.width = kW;
        f.height = kH;
        for (const auto& l : validated_->raster.frame.lights) f.V.push_back(l.V);
        return f;
    }
    static std::vector<float> linear_depth() {
        const std::vector<double> d = oracle_view_depth(*sc_, truth_->frame);
        std::vector<float> f(d.size());
        for (std::size_t i = 0; i < d.size(); ++i) f[i] = std::isfinite(d[i]) ? static_cast<float>(d[i]) : 0.0f;
        return f;
    }

    static Scenario* sc_;
    static OracleRun* truth_;
    static ValidateResult* validated_;
    static std::string setup_error_;
};
Scenario* Compare::sc_ = nullptr;
OracleRun* Compare::truth_ = nullptr;
ValidateResult* Compare::validated_ = nullptr;
std::string Compare::setup_error_;

TEST_F(Compare, ThePerfectEngineScoresNothingWrong) {
    std::uint64_t surface = 0;
    for (float a : truth_->frame.A) surface += a != 0;
    std::vector<std::uint64_t> scored_in_band;
    for (bool with_depth : {false, true}) {
        EngineFrame f = perfect_engine();
        if (with_depth) f.depth = linear_depth();
        const ValidateResult r = compare(*sc_, f, no_cache());
        EXPECT_EQ(r.report["coverage"]["source"], with_depth ? "depth" : "silhouette_band");
        // Coverage is counted over the oracle's whole surface either way. The depth is the
        // oracle's own: nothing but its background differs. The band leaves out the silhouettes,
        // some but a few per cent at this size.
        EXPECT_EQ(r.report["coverage"]["surface"].get<std::uint64_t>(), surface);
        const double mismatch = r.report["coverage"]["mismatch_fraction"];
        if (with_depth) {
            EXPECT_EQ(mismatch, 0.0);
        } else {
            EXPECT_GT(mismatch, 0.0);
            EXPECT_LT(mismatch, 0.1);
        }
        for (std::size_t li = 0; li < r.score.lights.size(); ++li) {
            const auto& l = r.score.lights[li];
            EXPECT_GT(l.pixels.scored, 5000u) << "light " << li;
            EXPECT_EQ(l.wrong, 0u) << "light " << li << (with_depth ? " with depth" : "");
            EXPECT_EQ(l.evidence.source, metrics::Evidence::oracle_geometry);
            // The depth leaves out nothing the band keeps: it scores more of every light.
            if (!with_depth)
                scored_in_band.push_back(l.pixels.scored);
            else
                EXPECT_GT(l.pixels.scored, scored_in_band.at(li)) << "light " << li;
        }
    }
}

// An engine whose depth buffer shows no surface (all zeros read as linear depth, or a buffer
// read in the wrong space) scores nothing: refused, not a pass on no pixels.
TEST_F(Compare, ADepthThatShowsTooLittleOfTheSurfaceIsRefused) {
    auto refused = [&](EngineFrame f, const std::string& says) {
        f.label = "engine.exr";
        f.depth_label = "depth.exr";
        try {
            compare(*sc_, f, no_cache());
            ADD_FAILURE() << says << ": scored";
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
        }
    };
    EngineFrame zeros = perfect_engine();
    zeros.depth = std::vector<float>(static_cast<std::size_t>(kW) * kH, 0.0f);
    refused(zeros, "depth.exr: only 0.00% of the");
    // Linear depth read as ndc: every value above 1 is "no surface".
    EngineFrame wrong_space = perfect_engine();
    wrong_space.depth = linear_depth();
    wrong_space.depth_space = DepthSpace::ndc;
    refused(wrong_space, "is --depth-space right");
    // The band alone may not leave out most of the surface either.
    CompareOptions wide = no_cache();
    wide.silhouette_band_px = 16;
    try {
        compare(*sc_, perfect_engine(), wide);
        ADD_FAILURE() << "a 16-pixel band at 192x108: scored";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("--silhouette-band 16"), std::string::npos) << e.what();
    }
}

// glTF's perspective camera may have no zfar: the projection `penumbra camera` prints is then the
// infinite-far limit, whose depth buffer holds w = 1 - n / z. compare reads it back.
TEST_F(Compare, NdcDepthFromAnInfiniteFarProjectionIsScored) {
    Scenario sc = *sc_;
    sc.camera.zfar = std::numeric_limits<double>::infinity();
    const std::vector<float> z = linear_depth();
    const double n = sc.camera.znear;
    for (DepthSpace space : {DepthSpace::ndc, DepthSpace::ndc_gl}) {
        EngineFrame f = perfect_engine();
        std::vector<float> d(z.size(), 1.0f);  // the cleared buffer: the far plane
        for (std::size_t i = 0; i < z.size(); ++i) {
            if (z[i] <= 0.0f) continue;
            const double w = 1.0 - n / z[i];
            d[i] = static_cast<float>(space == DepthSpace::ndc ? w : 2.0 * w - 1.0);
        }
        f.depth = d;
        f.depth_space = space;
        const ValidateResult r = compare(sc, f, no_cache());
        // Float depth buffers near 1 keep ~24 bits: within compare's 1% depth tolerance at the
        // few metres of this scene.
        EXPECT_LT(r.report["coverage"]["mismatch_fraction"].get<double>(), 0.001) << to_string(space);
        for (std::size_t li = 0; li < r.score.lights.size(); ++li) {
            EXPECT_GT(r.score.lights[li].pixels.scored, 5000u) << to_string(space) << " light " << li;
            EXPECT_EQ(r.score.lights[li].wrong, 0u) << to_string(space) << " light " << li;
        }
    }
}

TEST_F(Compare, PenumbrasOwnRasterFrameScoresWhatValidateScores) {
    // The depth-aware comparison sees the surface validate sees (raster prim = oracle prim) at
    // all but the silhouette pixels, so every light's wrong pixels agree to within those.
    EngineFrame f = raster_engine();
    f.depth = linear_depth();
    const ValidateResult r = compare(*sc_, f, no_cache());
    for (std::size_t li = 0; li < r.score.lights.size(); ++li) {
        const auto& c = r.score.lights[li];
        const auto& v = validated_->score.lights[li];
        const double silhouettes = static_cast<double>(v.pixels.coverage_mismatch);
        EXPECT_GT(v.wrong, 0u) << "light " << li << ": the default technique leaves wrong pixels";
        EXPECT_NEAR(static_cast<double>(c.wrong), static_cast<double>(v.wrong), silhouettes + 2) << "light " << li;
    }
    // Without depth: the same frame, scored outside the silhouette band.
    const ValidateResult nd = compare(*sc_, raster_engine(), no_cache());
    for (std::size_t li = 0; li < nd.score.lights.size(); ++li)
        EXPECT_LE(nd.score.lights[li].wrong, validated_->score.lights[li].wrong + 2) << "light " << li;
}

TEST_F(Compare, AFrameOffByOnePixelOrFlippedIsRefusedNotScored) {
    struct Case {
        int dx, dy;
        bool flip;
        const char* says;
    };
    for (const Case& k : {Case{1, 0, false, "shifted by (+1, +0) px"}, Case{0, -1, false, "shifted by (+0, -1) px"},
                          Case{0, 0, true, "flipped vertically"}})
        for (bool with_depth : {false, true}) {
            EngineFrame f = raster_engine();
            f.label = "engine.exr";
            for (auto& v : f.V) v = moved(v, k.dx, k.dy, k.flip, 1.0f);
            if (with_depth) f.depth = moved(linear_depth(), k.dx, k.dy, k.flip, 0.0f);
            try {
                compare(*sc_, f, no_cache());
                ADD_FAILURE() << k.says << (with_depth ? " (depth)" : "") << ": scored, not refused";
            } catch (const InputError& e) {
                const std::string m = e.what();
                std::printf("  %s\n", m.c_str());
                EXPECT_NE(m.find("engine.exr: the frame does not line up with the scenario's camera"),
                          std::string::npos)
                    << m;
                EXPECT_NE(m.find(k.says), std::string::npos) << m;
                EXPECT_NE(m.find(with_depth ? "the engine's depth" : "the shadow image"), std::string::npos) << m;
            }
        }
}

TEST_F(Compare, BadFramesNameTheFileAndWhatWasExpected) {
    auto refused = [&](EngineFrame f, const std::string& says) {
        f.label = "engine.exr";
        try {
            compare(*sc_, f, no_cache());
            ADD_FAILURE() << says << ": accepted";
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
        }
    };
    EngineFrame nan = perfect_engine();
    nan.V[1][kW * 3 + 5] = std::numeric_limits<float>::quiet_NaN();
    refused(nan, "engine.exr: light 1: NaN at pixel (5, 3); expected a shadow factor in [0, 1]");
    EngineFrame bytes = perfect_engine();
    bytes.V[0][7] = 255.0f;
    refused(bytes,
            "engine.exr: light 0: 255 at pixel (7, 0); expected a shadow factor in [0, 1] (1 = lit) (was it "
            "written as 0..255?)");
    EngineFrame two = perfect_engine();
    two.V.pop_back();
    refused(two, "engine.exr: 2 shadow channels; expected one per light of scenario.json (3)");
}

// The matrices `penumbra camera` prints and the depth compare reads back are one projection: a
// point at view depth z lands at window_depth(z) through each convention's P * V, and
// view_depth inverts it, for finite and infinite far planes.
TEST(CameraProjection, MatricesAndDepthAgreeInEveryConvention) {
    Camera persp;
    look_at_basis({1, 2, 3}, {0, 0, -4}, {0, 1, 0}, persp);
    persp.znear = 0.5;
    persp.zfar = 80;
    Camera infinite = persp;
    infinite.zfar = std::numeric_limits<double>::infinity();
    Camera ortho = persp;
    ortho.type = ProjectionType::orthographic;
    ortho.znear = 0.0;
    Bounds box;
    box.grow({-5, -5, -5});
    box.grow({5, 5, 5});
    for (const Camera* cam : {&persp, &infinite, &ortho}) {
        const CameraProjection p(*cam, 160, 90, box);
        const Mat4 v = p.view();
        for (ClipConvention conv : {ClipConvention::gl, ClipConvention::vulkan, ClipConvention::d3d}) {
            const Mat4 m = p.matrix(conv);
            for (double z : {0.7, 3.0, 40.0}) {
                const glm::dvec3 x = cam->eye + z * cam->forward + 0.1 * cam->right;
                double view[4], clip[4];
                for (int r = 0; r < 4; ++r) view[r] = v[r][0] * x.x + v[r][1] * x.y + v[r][2] * x.z + v[r][3];
                for (int r = 0; r < 4; ++r)
                    clip[r] = m[r][0] * view[0] + m[r][1] * view[1] + m[r][2] * view[2] + m[r][3] * view[3];
                const double ndc = clip[2] / clip[3];
                const double w = conv == ClipConvention::gl ? 0.5 * (ndc + 1.0) : ndc;
                EXPECT_NEAR(w, p.window_depth(z), 1e-12) << "z " << z;
                EXPECT_NEAR(p.view_depth(p.window_depth(z)), z, 1e-9 * z) << "z " << z;
                EXPECT_TRUE(std::isfinite(w)) << "z " << z;
            }
        }
        EXPECT_TRUE(std::isnan(p.view_depth(1.0)));
    }
    // The infinite far plane is the limit of far ones.
    Camera far = persp;
    far.zfar = 1e12;
    const Mat4 a = CameraProjection(infinite, 160, 90, box).matrix(ClipConvention::gl);
    const Mat4 b = CameraProjection(far, 160, 90, box).matrix(ClipConvention::gl);
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) EXPECT_NEAR(a[r][c], b[r][c], 1e-9) << r << "," << c;
    // An orthographic camera without zfar has no such limit: its far plane is the scene's far side.
    Camera open_ortho = ortho;
    open_ortho.zfar = std::numeric_limits<double>::infinity();
    const CameraProjection po(open_ortho, 160, 90, box);
    EXPECT_TRUE(po.zfar_from_scene());
    double farthest = 0;
    for (int k = 0; k < 8; ++k) {  // every corner of the box lies inside the depth range
        const glm::dvec3 c(k & 1 ? 5 : -5, k & 2 ? 5 : -5, k & 4 ? 5 : -5);
        const double w = po.window_depth(glm::dot(c - open_ortho.eye, open_ortho.forward));
        EXPECT_LT(w, 1.0) << "corner " << k;
        farthest = std::max(farthest, w);
    }
    EXPECT_GT(farthest, 0.98) << "the far plane hugs the scene, keeping depth precision";
}

TEST(CompareFiles, BadImageFilesNameTheFileAndWhatWasExpected) {
    const Scenario sc = small_default();
    test::TempDir dir;
    const std::size_t n = static_cast<std::size_t>(kW) * kH;
    {
        OutputTransaction out(dir.path());
        write_exr(out, "small.exr", kW / 2, kH, {{"light0.V", std::vector<float>(n / 2, 1.0f), {}}});
        write_exr(out, "named.exr", kW, kH,
                  {{"light0.V", std::vector<float>(n, 1.0f), {}}, {"light1.V", std::vector<float>(n, 1.0f), {}}});
        write_exr(out, "rgb.exr", kW, kH,
                  {{"R", std::vector<float>(n, 1.0f), {}}, {"G", std::vector<float>(n, 1.0f), {}}});
        // An 8-bit mask written as 0 and 1 rather than 0 and 255 (write_png takes linear RGB;
        // 0.0003 encodes to sRGB byte 1).
        std::vector<float> rgb(3 * n, 0.0f);
        for (std::size_t i = 0; i < n; i += 2) rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = 0.0003f;
        write_png(out, "ones.png", kW, kH, rgb);
        out.commit();
    }
    auto refused = [&](const std::filesystem::path& file, std::vector<std::size_t> lights, const std::string& says) {
        try {
            load_engine_frame(sc, file, lights, std::nullopt, DepthSpace::linear);
            ADD_FAILURE() << file << ": accepted";
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
        }
    };
    const std::string d = dir.path().string();
    refused(dir / "small.exr", {0},
            d + "/small.exr: 96x108 pixels; expected the scenario's image size, 192x108 (scenario.json)");
    refused(dir / "named.exr", {0, 1, 2}, d + "/named.exr: no channel light2.V (it has light0.V, light1.V)");
    refused(dir / "rgb.exr", {0, 1, 2},
            d + "/rgb.exr: channels R, G; expected light<i>.V channels or one channel per light (3)");
    refused(dir / "ones.png", {0}, d + "/ones.png: channel R: an 8-bit image whose values are only 0 and 1 (of 255)");
    refused(dir / "missing.exr", {0}, d + "/missing.exr: no such image file");
    // A good one: named channels, in the scenario's order.
    const EngineFrame f = load_engine_frame(sc, dir / "named.exr", {1}, std::nullopt, DepthSpace::linear);
    ASSERT_EQ(f.V.size(), 1u);
    EXPECT_EQ(f.info["channels"][0]["channel"], "light1.V");
}

}  // namespace
}  // namespace penumbra
