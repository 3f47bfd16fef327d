// compare end to end on data/default (small image): an engine frame made from the oracle's own
// truth scores nothing wrong, penumbra's raster frame passed as an engine's scores what validate
// scores, a frame off by one pixel or flipped is refused with a message that says so, and bad
// image files are refused naming the file and what was expected.
#include "pipeline/compare.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>

#include "common/errors.h"
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
    for (bool with_depth : {false, true}) {
        EngineFrame f = perfect_engine();
        if (with_depth) f.depth = linear_depth();
        const ValidateResult r = compare(*sc_, f, no_cache());
        EXPECT_EQ(r.report["coverage"]["source"], with_depth ? "depth" : "silhouette_band");
        const double mismatch = r.report["coverage"]["mismatch_fraction"];
        // The depth is the oracle's own: nothing but its background differs. The band leaves out
        // the silhouettes, a few per cent at this size.
        if (with_depth)
            EXPECT_EQ(mismatch, 0.0);
        else
            EXPECT_LT(mismatch, 0.1);
        EXPECT_GT(mismatch, with_depth ? -1.0 : 0.0);
        for (std::size_t li = 0; li < r.score.lights.size(); ++li) {
            const auto& l = r.score.lights[li];
            EXPECT_GT(l.pixels.scored, 5000u) << "light " << li;
            EXPECT_EQ(l.wrong, 0u) << "light " << li << (with_depth ? " with depth" : "");
            EXPECT_EQ(l.evidence.source, metrics::Evidence::oracle_geometry);
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
