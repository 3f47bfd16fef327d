// tune's Pareto front of (worst acne, objective) at its ties (issue 40): equal points appear once,
// as the earliest evaluation, and a point equal on one axis and worse on the other is dominated.
#include <gtest/gtest.h>

#include "tune/tune.h"

namespace penumbra::tune {
namespace {

TEST(TuneFront, EqualPointsAppearOnceAndTiesOnOneAxisAreDominated) {
    TuneResult r;
    auto add = [&](double acne, double objective) {
        Evaluation e;
        e.setting = Setting(1);
        e.setting[0] = static_cast<double>(r.evaluations.size() + 1);  // distinct settings
        e.worst_acne = acne;
        e.minimized = objective;
        e.feasible = acne <= 0.001;
        r.evaluations.push_back(e);
    };
    add(0.1, 1.0);   // 0: on the front
    add(0.0, 2.0);   // 1: on the front
    add(0.0, 2.0);   // 2: equal to 1: 1 stands for both
    add(0.1, 1.0);   // 3: equal to 0
    add(0.05, 1.5);  // 4: on the front
    add(0.05, 1.6);  // 5: equal acne to 4, worse objective: dominated
    add(0.2, 1.0);   // 6: equal objective to 0, more acne: dominated
    const KnobSet knobs = knob_set(raster::Technique{}, std::vector<std::string>{"constant"});
    rank(r, knobs, Objective{});
    EXPECT_EQ(r.front, (std::vector<std::size_t>{1, 4, 0}));
}

}  // namespace
}  // namespace penumbra::tune
