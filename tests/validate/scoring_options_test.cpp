// How each light is judged under a technique (pipeline/validate.cpp, scoring_options): the acne
// rule's depth quantum is the format's step, never finer than 2^-22 (docs/metrics.md, "acne"),
// the aliasing reach is the filter's, and area lights are scored as soft. Asserted against the
// documented values, so a quantum or reach off by a factor 2 fails here, not only in a verdict
// scene that happens to sit near the edge.
#include <gtest/gtest.h>

#include <cmath>

#include "pipeline/validate.h"
#include "raster/technique.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

Scenario sun_and_rect() {
    test::SceneBuilder b;
    b.quad({-1, 0, -1}, {-1, 0, 1}, {1, 0, 1}, {1, 0, -1});
    return test::make_scenario(b.build(), test::look_at({0, 3, 3}, {0, 0, 0}, 50),
                               {test::directional({0, -1, 0}), test::rect({0, 2, 0}, {1, 0, 0}, {0, 0, 1})}, 16, 16);
}

metrics::ScoringOptions options_for(const nlohmann::json& technique, std::size_t light = 0) {
    const std::vector<metrics::ScoringOptions> o =
        scoring_options(sun_and_rect(), raster::parse_technique(technique, "test: technique"), 0.03);
    EXPECT_EQ(o.size(), 2u);
    return o.at(light);
}

TEST(ScoringOptions, TheDepthQuantumIsTheFormatsStepNeverFinerThanTwoToTheMinus22) {
    EXPECT_EQ(options_for({{"depth_format", "d16"}}).depth_quantum, std::ldexp(1.0f, -16));
    EXPECT_EQ(options_for({{"depth_format", "d24"}}).depth_quantum, std::ldexp(1.0f, -22));
    EXPECT_EQ(options_for({{"depth_format", "d32"}}).depth_quantum, std::ldexp(1.0f, -22));
}

TEST(ScoringOptions, TheAliasingReachIsTheFiltersAndAreaLightsAreSoft) {
    EXPECT_EQ(options_for({{"filter", {{"type", "none"}}}}).filter_reach_texels, 1.0f);
    // PCF of n taps reaches n/2 texels from the centre; bilinear taps half a texel more.
    EXPECT_EQ(options_for({{"filter", {{"type", "pcf"}, {"size", 5}}}}).filter_reach_texels, 2.5f);
    EXPECT_EQ(options_for({{"filter", {{"type", "pcf"}, {"size", 3}, {"bilinear_taps", true}}}}).filter_reach_texels,
              2.0f);
    const metrics::ScoringOptions sun = options_for(nlohmann::json::object(), 0),
                                  rect = options_for(nlohmann::json::object(), 1);
    EXPECT_FALSE(sun.soft);
    EXPECT_TRUE(rect.soft);
    EXPECT_EQ(sun.tolerance, 0.03f);
}

}  // namespace
}  // namespace penumbra
