// report.html's legend shows each class in the colour its pixels have in the class image
// (issue 40): the page's CSS colour and the PNG's sRGB bytes come from two encoders (report's
// css_colour and image_io's table), so a wrong transfer curve in either shows as a mismatch.
#include <OpenImageIO/imageio.h>
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <array>
#include <fstream>

#include "common/output_files.h"
#include "report/bitmap_font.h"
#include "report/report.h"
#include "report/report_files.h"
#include "tests/metrics/synthetic_frames.h"
#include "tests/test_support.h"

namespace penumbra::report {
namespace {

TEST(ReportLegend, TheSwatchOfAClassIsThePngColourOfItsPixels) {
    Scenario scenario;
    scenario.width = 64;
    scenario.height = 40;
    scenario.lights.push_back(test::directional({0, -1, 0}));
    test::Frames frames(64, 40);
    frames.shadow(5, 0.01f);  // peter-panning (bias 0, footprint 0.01 m)
    frames.rl().V[9] = 0.0f;  // acne: the receiver's own triangle in front
    frames.lk().ref_depth[9] = 0.7f;
    frames.lk().stored_depth[9] = 0.6999f;
    frames.ol().V[20] = 0.0f;  // a correct shadow: dark in both
    frames.rl().V[20] = 0.0f;
    const metrics::FrameScore score = frames.score();
    ReportInputs in;
    in.version = "test";
    in.scenario = &scenario;
    in.scenario_file = "scenes/legend.json";
    in.technique = {{"resolution", 1024}};
    in.scoring = {metrics::ScoringOptions{}};
    in.timing = {{"oracle_s", 0.1}, {"raster_s", 0.2}, {"metrics_s", 0.01}, {"raster_ms", {{"shadow", 1.0}}}};
    const nlohmann::json r = report_json(in, score);
    test::TempDir dir;
    {
        OutputTransaction out(dir.path());
        write_report(out, in, frames.o, frames.r, score, r);
        out.commit();
    }
    std::ifstream html(dir / "report.html");
    const std::string page((std::istreambuf_iterator<char>(html)), std::istreambuf_iterator<char>());
    auto png = OIIO::ImageInput::open((dir / "light0.classes.png").string());
    ASSERT_TRUE(png);
    const int w = png->spec().width, h = png->spec().height;
    ASSERT_EQ(png->spec().nchannels, 3);
    std::vector<unsigned char> pixels(static_cast<std::size_t>(w) * h * 3);
    ASSERT_TRUE(png->read_image(0, 0, 0, 3, OIIO::TypeDesc::UINT8, pixels.data()));
    // Correct pixels are drawn in the truth's shading: the legend's "correct" swatches are colours
    // the map has (issue 33: a grey that occurred nowhere).
    ASSERT_EQ(frames.ol().V[0], 1.0f);
    for (const auto& [pixel, name] : {std::pair{5, "peter_panning"}, std::pair{9, "acne"}, std::pair{0, "correct, lit"},
                                      std::pair{20, "correct, in shadow"}}) {
        const unsigned char* p = &pixels[3 * static_cast<std::size_t>(pixel)];
        const std::string swatch = fmt::format("background:#{:02x}{:02x}{:02x}\"></span>{}<", p[0], p[1], p[2], name);
        EXPECT_NE(page.find(swatch), std::string::npos) << swatch;
    }
    // The PNG's own legend band (under the 40 image rows) has a full swatch of each correct
    // colour too: a reader of the PNG alone sees the same key.
    for (const int pixel : {0, 20}) {
        const unsigned char* want = &pixels[3 * static_cast<std::size_t>(pixel)];
        int in_band = 0;
        for (int y = scenario.height; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const unsigned char* p = &pixels[3 * (static_cast<std::size_t>(y) * w + x)];
                in_band += p[0] == want[0] && p[1] == want[1] && p[2] == want[2];
            }
        EXPECT_GE(in_band, kGlyphHeight * kGlyphHeight) << "pixel " << pixel;
    }
}

}  // namespace
}  // namespace penumbra::report
