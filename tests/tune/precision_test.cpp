// tune's precision contract as a property (docs/tune.md, "Search", 2.; issue 40): whatever the
// true least feasible value of a knob, over six decades, the search returns a feasible value
// within a factor 1 + precision of it, for each continuous knob alone and with a second knob
// enabled that cannot cure the acne. A single true answer can sit where a bracket that is too
// short or a bisection that stops too early still lands.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>

#include "tune/tune.h"

namespace penumbra::tune {
namespace {

// Acne falls linearly to 0 at `knob` = truth, feasible from truth x (1 - 0.002) on; peter-panning
// grows with every knob, so the least feasible value is the optimum.
EvaluateFn linear_cure(std::size_t knob, double truth, const KnobSet& knobs) {
    std::vector<double> weight;  // of each knob in the peter-panning
    for (const raster::KnobDecl& k : knobs) weight.push_back(k.name == "constant" ? 1e-4 : 1e-2);
    return [=](const Setting& s) {
        Evaluation e;
        e.setting = s;
        e.worst_acne = std::max(0.0, 0.5 - 0.5 * s[knob] / truth);
        double pp = 0;
        for (std::size_t i = 0; i < weight.size(); ++i) pp += weight[i] * s[i];
        e.minimized = pp;
        e.then = 0;
        e.feasible = e.worst_acne <= 0.001;
        return e;
    };
}

// `count` true answers spread evenly on the log scale over [lo, hi], none on a round number.
std::vector<double> truths(double lo, double hi, int count) {
    std::vector<double> t;
    for (int i = 0; i < count; ++i) t.push_back(lo * std::pow(hi / lo, (i + 0.37) / count));
    return t;
}

// `knob` is the position in `knobs` (depth-map knobs by name) of the one that cures.
void expect_within_precision(std::size_t knob, const std::vector<std::string>& knobs, double lo, double hi) {
    for (const double precision : {0.02, 0.05}) {
        int checked = 0;
        for (const double truth : truths(lo, hi, 41)) {
            TuneOptions o;
            o.knobs = knob_set(raster::Technique{}, knobs);
            o.precision = precision;
            const TuneResult r = search(linear_cure(knob, truth, o.knobs), o);
            const std::string where =
                fmt::format("{} knob(s), precision {}, true answer {:.6g}", knobs.size(), precision, truth);
            ASSERT_TRUE(r.winner) << where;
            const double found = r.evaluations[*r.winner].setting[knob];
            const double least = truth * (1 - 0.002);
            EXPECT_GE(found, least) << where;
            EXPECT_LE(found, least * (1 + precision)) << where;
            ++checked;
        }
        EXPECT_EQ(checked, 41);
    }
}

TEST(TunePrecision, TheConstantIsFoundWithinPrecisionWhateverItsTrueValue) {
    expect_within_precision(0, {"constant"}, 0.3, 3e5);
}

TEST(TunePrecision, TheSlopeIsFoundWithinPrecisionWhateverItsTrueValue) {
    expect_within_precision(0, {"slope"}, 0.03, 30);
}

TEST(TunePrecision, ASecondKnobThatCannotCureLeavesThePrecisionIntact) {
    expect_within_precision(0, {"constant", "slope"}, 0.3, 3e5);
    expect_within_precision(1, {"constant", "slope"}, 0.03, 30);
}

}  // namespace
}  // namespace penumbra::tune
