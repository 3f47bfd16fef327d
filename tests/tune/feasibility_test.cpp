// tune's feasibility at its boundary (issue 40): a setting is feasible when its acne is at most
// max_acne on every scenario and light (tune/tune.h, Objective), so acne exactly at the limit,
// 0 at a limit of 0 included, is feasible.
#include <gtest/gtest.h>

#include <cmath>

#include "raster/raster.h"
#include "tests/test_support.h"
#include "tune/tune.h"

namespace penumbra::tune {
namespace {

TEST(TuneFeasibility, AcneExactlyAtTheLimitIsFeasible) {
    test::SceneBuilder b;
    b.quad({-10, 0, -10}, {-10, 0, 10}, {10, 0, 10}, {10, 0, -10}, false);
    const double t = 40.0 * M_PI / 180.0;
    const std::vector<Scenario> sc = {test::make_scenario(b.build(), test::look_at({-1, 5, 3}, {-1, 0, 0}, 40),
                                                          {test::directional({std::sin(t), -std::cos(t), 0})}, 160,
                                                          120)};
    const raster::Technique technique = raster::parse_technique(
        {{"preset", "no-bias"}, {"resolution", 512}, {"depth_format", "d24"}, {"fit", "scene_bounds"}}, "test");
    raster::VulkanContext ctx;
    TuneOptions o;
    o.knobs = knob_set(technique, std::vector<std::string>{"constant"});
    o.validate.use_cache = false;
    o.validate.oracle.progress = false;

    // No bias: acne on a part of the plane; that part as the limit is feasible, a hair less is not.
    const Setting none(1);
    double acne = 0;
    {
        Evaluator ev(sc, technique, o, ctx);
        acne = ev.evaluate(none).worst_acne;
    }
    ASSERT_GT(acne, 0.01);
    o.objective.max_acne = acne;
    {
        Evaluator ev(sc, technique, o, ctx);
        EXPECT_TRUE(ev.evaluate(none).feasible) << "acne " << acne << " at a limit of " << acne;
    }
    o.objective.max_acne = std::nextafter(acne, 0.0);
    {
        Evaluator ev(sc, technique, o, ctx);
        EXPECT_FALSE(ev.evaluate(none).feasible);
    }
    // Ample bias: no acne at all, feasible at a limit of 0.
    o.objective.max_acne = 0;
    Setting ample(1);
    ample[0] = 1e5;
    Evaluator ev(sc, technique, o, ctx);
    const Evaluation e = ev.evaluate(ample);
    ASSERT_EQ(e.worst_acne, 0.0);
    EXPECT_TRUE(e.feasible);
}

}  // namespace
}  // namespace penumbra::tune
