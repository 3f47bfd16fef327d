// The filterable families (issue #35): their keys, their refusals, and the Chebyshev math of
// the lookup shader against hand-computed values.
#include "raster/filterable.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/errors.h"
#include "raster/technique_family.h"

namespace penumbra {
namespace {

using raster::parse_technique;
using ::testing::HasSubstr;

std::string error_of(const nlohmann::json& j) {
    try {
        parse_technique(j, "s.json: technique");
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

TEST(Filterable, VsmKeysHaveTheirDefaultsAndNestUnderTheFamilysName) {
    const raster::Technique t = parse_technique({{"family", "vsm"}}, "s.json: technique");
    const raster::MomentParameters* p = raster::moment_parameters(t);
    ASSERT_NE(p, nullptr);
    EXPECT_EQ(p->kind, raster::MomentKind::vsm);
    EXPECT_EQ(p->blur, 0);
    EXPECT_DOUBLE_EQ(p->light_bleed, 0.15);  // Filament's lightBleedReduction
    EXPECT_EQ(t.bias.constant, 0.0);         // no hardware bias: the variance floor stands in for it
    const nlohmann::json j = t.to_json();
    EXPECT_EQ(j.at("vsm").at("light_bleed"), 0.15);
    EXPECT_EQ(j.at("blur"), 0);
    EXPECT_EQ(j.at("mipmaps"), false);

    nlohmann::json tech = {{"family", "vsm"}, {"vsm", {{"light_bleed", 0.3}}}, {"blur", 4}};
    raster::apply_override(tech, "vsm.min_variance=0.0001");
    const raster::Technique u = parse_technique(tech, "t");
    EXPECT_DOUBLE_EQ(raster::moment_parameters(u)->min_variance, 1e-4);
    EXPECT_DOUBLE_EQ(raster::moment_parameters(u)->light_bleed, 0.3);
    // The filter reaches the blur radius plus the bilinear tap's texel.
    EXPECT_DOUBLE_EQ(raster::family_of(u).hints(u).filter_reach_texels, 5.0);
    EXPECT_TRUE(raster::family_of(u).hints(u).light_bleeding);
    EXPECT_FALSE(raster::family_of(parse_technique(nlohmann::json::object(), "t"))
                     .hints(parse_technique(nlohmann::json::object(), "t"))
                     .light_bleeding);
}

TEST(Filterable, EveryFamilyWritesWhatItParses) {
    const std::vector<nlohmann::json> cases = {
        {{"family", "vsm"}, {"blur", 3}, {"vsm", {{"min_variance", 1e-5}, {"light_bleed", 0.2}}}},
        {{"family", "esm"}, {"esm", {{"exponent", 50}}}},
        {{"family", "evsm2"}, {"evsm", {{"exponents", {30, 4}}}}},
        {{"family", "evsm4"}, {"blur", 2}},
    };
    for (const auto& j : cases) {
        const raster::Technique t = parse_technique(j, "t");
        const nlohmann::json written = t.to_json();
        EXPECT_EQ(parse_technique(written, "t").to_json(), written) << j.dump();
    }
    EXPECT_EQ(parse_technique({{"family", "evsm4"}}, "t").to_json().at("evsm").at("exponents"),
              nlohmann::json({40.0, 5.0}));  // TheRealMJP/Shadows' +40 / -5
}

TEST(Filterable, BadKeysAreInputErrorsNamingTheKeyPathAndTheReason) {
    EXPECT_THAT(error_of({{"family", "vsm"}, {"vsm", {{"light_bleed", 1.5}}}}),
                HasSubstr("s.json: technique.vsm.light_bleed"));
    EXPECT_THAT(error_of({{"family", "vsm"}, {"vsm", {{"bleed", 0.1}}}}), HasSubstr("bleed"));
    EXPECT_THAT(error_of({{"family", "vsm"}, {"esm", {{"exponent", 10}}}}), HasSubstr("esm"));
    EXPECT_THAT(error_of({{"family", "esm"}, {"esm", {{"exponent", 100}}}}),
                AllOf(HasSubstr("technique.esm.exponent"), HasSubstr("float32")));
    EXPECT_THAT(error_of({{"family", "evsm4"}, {"evsm", {{"exponents", {50, 5}}}}}),
                AllOf(HasSubstr("technique.evsm.exponents"), HasSubstr("42")));
    EXPECT_THAT(error_of({{"family", "evsm2"}, {"evsm", {{"exponents", {40}}}}}), HasSubstr("[positive, negative]"));
    EXPECT_THAT(error_of({{"family", "vsm"}, {"filter", {{"type", "pcf"}}}}),
                AllOf(HasSubstr("technique.filter"), HasSubstr("moments")));
    EXPECT_THAT(error_of({{"family", "vsm"}, {"blur", -1}}), HasSubstr("technique.blur"));
    EXPECT_THAT(error_of({{"family", "vsm"}, {"mipmaps", true}}), HasSubstr("technique.mipmaps"));
    EXPECT_THAT(error_of({{"blur", 2}}), HasSubstr("blur"));  // not a depth-map key
}

// Two occluders in one filter footprint, half at each depth: the moments are their mean and
// mean square, and Chebyshev's bound for a receiver behind both is worked out by hand.
TEST(Filterable, ChebyshevBoundOfTwoDepthsMatchesTheHandComputedValue) {
    const double d1 = 0.2, d2 = 0.6, t = 0.7;
    const double m1 = 0.5 * (d1 + d2), m2 = 0.5 * (d1 * d1 + d2 * d2);  // mean 0.4, variance 0.04
    EXPECT_NEAR(raster::chebyshev_upper_bound(m1, m2, t, 0.0), 0.04 / (0.04 + 0.09), 1e-12);
    // A receiver at or in front of the mean is lit; the bound falls as it recedes.
    EXPECT_EQ(raster::chebyshev_upper_bound(m1, m2, 0.4, 0.0), 1.0);
    EXPECT_LT(raster::chebyshev_upper_bound(m1, m2, 0.9, 0.0), raster::chebyshev_upper_bound(m1, m2, t, 0.0));
    // That 0.31 is light bleeding: the receiver lies behind both occluders, truly in shadow.
    // The reduction linstep(0.35, 1, p) removes it, and keeps a fully lit receiver lit.
    EXPECT_EQ(raster::reduce_light_bleeding(0.04 / 0.13, 0.35), 0.0);
    EXPECT_EQ(raster::reduce_light_bleeding(1.0, 0.35), 1.0);
    EXPECT_NEAR(raster::reduce_light_bleeding(0.675, 0.35), 0.5, 1e-12);
    // One depth: zero variance, the floor decides how fast the receiver darkens behind it.
    EXPECT_NEAR(raster::chebyshev_upper_bound(0.5, 0.25, 0.51, 1e-4), 1e-4 / (1e-4 + 1e-4), 1e-9);
}

}  // namespace
}  // namespace penumbra
