// The filterable families (docs/raster.md, "Filterable shadow maps"): variance shadow maps
// (Donnelly & Lauritzen 2006), exponential shadow maps (Annen et al. 2008) and exponential
// variance shadow maps (Lauritzen & McCool 2008), with two or four moments, and moment shadow
// maps (Peters & Klein 2015), with four. They share the
// depth-map family's map and keys (resolution, format, fit, cull, bias, lights); a moments pass,
// a separable Gaussian blur and optionally a mip chain follow the map (raster/depth_map.cpp,
// shaders/moments.comp), and the lookup samples the filtered moments bilinearly or trilinearly.
#include "raster/filterable.h"

#include <fmt/format.h>

#include "common/json_reader.h"
#include "raster/technique_family.h"

namespace penumbra::raster {

const char* to_string(MomentKind k) {
    static const char* const kNames[] = {"vsm", "esm", "evsm2", "evsm4", "msm"};
    return kNames[static_cast<int>(k)];
}

const char* to_string(MsmVariant v) {
    return v == MsmVariant::hamburger ? "hamburger" : "hausdorff";
}

glm::vec4 moment_uniform(const MomentParameters& p) {
    if (p.kind == MomentKind::msm)
        return glm::vec4(static_cast<float>(p.moment_bias), 0.0f, p.variant == MsmVariant::hausdorff ? 1.0f : 0.0f,
                         static_cast<float>(p.storage_bits));
    return glm::vec4(p.min_variance, p.light_bleed, p.exponent, p.negative_exponent);
}

double msm_visibility(const std::array<double, 4>& moments, double z, double alpha, MsmVariant variant) {
    // The bias mixes in a little of the moments of a spread-out distribution, so that the Hankel
    // matrix below stays positive definite under rounding (Peters & Klein 2015, section 5).
    std::array<double, 4> b{};
    for (int i = 0; i < 4; ++i) b[i] = (1 - alpha) * moments[i] + alpha * 0.5;
    // Solve B c = (1, z, z^2) for the Hankel matrix B = [[1, b1, b2], [b1, b2, b3], [b2, b3, b4]]
    // by its LDL^T factorisation: c's polynomial vanishes at the two other support points of
    // the distribution with these moments that puts weight on z.
    const double d22 = b[1] - b[0] * b[0];
    const double l32 = (b[2] - b[0] * b[1]) / d22;
    const double d33 = b[3] - b[1] * b[1] - l32 * l32 * d22;
    double c2 = z - b[0];
    double c3 = (z * z - b[1] - l32 * c2) / d33;
    c2 = c2 / d22 - l32 * c3;
    const double c1 = 1 - b[0] * c2 - b[1] * c3;
    const double p = c2 / c3, q = c1 / c3;
    const double r = std::sqrt(std::max(0.25 * p * p - q, 0.0));
    const double z2 = -0.5 * p - r, z3 = -0.5 * p + r;
    double shadow = 0;
    if (z > z3) {
        shadow = 1 - (z2 * z3 - b[0] * (z2 + z3) + b[1]) / ((z - z2) * (z - z3));
    } else if (z > z2) {
        shadow = (z * z3 - b[0] * (z + z3) + b[1]) / ((z3 - z2) * (z - z2));
    }
    if (variant == MsmVariant::hausdorff && (z2 < 0 || z3 > 1)) {
        // Those points leave [0, 1]: the bound of four points, one of them 0 or 1 (Peters &
        // Klein 2015, the Hausdorff moment problem). Where the receiver ties the free point the
        // formula is 0/0 and the three-point bound stays (penumbra's guard; the paper has none).
        const double free = ((b[2] - b[1]) * z + b[2] - b[3]) / ((b[1] - b[0]) * z + b[1] - b[2]);
        const double w = z > free ? 1.0 : 0.0;
        const double four =
            (b[1] - b[0] + (b[2] - b[0] - (free + 1) * (b[1] - b[0])) * (free - w - z) / (z * (z - free))) /
                (free - w) +
            1 - b[0];
        if (std::isfinite(four)) shadow = four;
    }
    return 1 - std::clamp(shadow, 0.0, 1.0);
}

namespace {

// Peters & Klein 2015, section 4.3: q = A b + (kOffset, 0, 0, 0), rows of A; and A's inverse.
constexpr double kMsmOffset = 0.035955884801;
constexpr double kMsmA[4][4] = {{-2.07224649, 32.23703778, -68.571074599, 39.3703274134},
                                {13.7948857237, -59.4683975703, 82.0359750338, -35.364903257},
                                {0.105877704, -1.9077466311, 9.3496555107, -6.6543490743},
                                {9.7924062118, -33.7652110555, 47.9456096605, -23.9728048165}};
constexpr double kMsmAInverse[4][4] = {{0.2227744146, 0.0771972861, 0.7926986636, 0.0319417555},
                                       {0.1549679261, 0.1394629426, 0.7963415838, -0.1722823173},
                                       {0.1451988946, 0.2120202157, 0.7258694464, -0.2758014811},
                                       {0.163127443, 0.2591432266, 0.6539092497, -0.3376131734}};

}  // namespace

std::array<double, 4> msm_optimise(const std::array<double, 4>& b) {
    std::array<double, 4> q{};
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) q[i] += kMsmA[i][j] * b[j];
    q[0] += kMsmOffset;
    return q;
}

std::array<double, 4> msm_unoptimise(const std::array<double, 4>& q) {
    std::array<double, 4> b{};
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) b[i] += kMsmAInverse[i][j] * (q[j] - (j == 0 ? kMsmOffset : 0.0));
    return b;
}

std::array<double, 4> round_to_unorm16(const std::array<double, 4>& q) {
    std::array<double, 4> r{};
    for (int i = 0; i < 4; ++i) r[i] = std::round(std::clamp(q[i], 0.0, 1.0) * 65535.0) / 65535.0;
    return r;
}

const MomentParameters* moment_parameters(const Technique& t) {
    return dynamic_cast<const MomentParameters*>(t.family_parameters.get());
}

namespace {

const MomentParameters& parameters_of(const Technique& t) {
    static const MomentParameters kNone;
    const MomentParameters* p = moment_parameters(t);
    return p ? *p : kNone;
}

void parse_moment_keys(MomentKind kind, JsonObject& o, Technique& t) {
    // The moments' variance floor stands in for a depth bias (Filament ignores its biases with
    // VSM): no hardware bias unless the technique asks for one.
    t.bias = Bias{};
    parse_depth_map_keys(o, t);
    if (t.filter.type != FilterType::none)
        o.fail("filter", fmt::format("the {} family filters its moments (\"blur\" and a bilinear tap); filter.type "
                                     "must be \"none\"",
                                     to_string(kind)));
    if (o.has("area_samples") && o.integer("area_samples", 0, 256) > 0)
        o.fail("area_samples", "only the averaged_area family draws area samples (\"family\": \"averaged_area\")");
    auto p = std::make_shared<MomentParameters>();
    p->kind = kind;
    p->blur = static_cast<int>(o.integer("blur", 0, 0, 32));
    p->mipmaps = o.boolean("mipmaps", false);
    if (kind == MomentKind::vsm) {
        if (o.has("vsm")) {
            JsonObject v = o.object("vsm");
            p->min_variance = v.number_in("min_variance", p->min_variance, 0.0, 1.0, "squared depth units in [0, 1]");
            p->light_bleed = v.number_in("light_bleed", p->light_bleed, 0.0, 0.999, "a fraction in [0, 0.999]");
            v.finish();
        }
    } else if (kind == MomentKind::esm) {
        if (o.has("esm")) {
            JsonObject e = o.object("esm");
            p->exponent = e.number_in("exponent", p->exponent, 0.0, 1e6, "a positive number");
            if (p->exponent <= 0) e.fail("exponent", "must be > 0");
            if (p->exponent > kMaxEsmExponent)
                e.fail("exponent", fmt::format("{} overflows float32 moments: exp(c) exceeds FLT_MAX beyond c = {}",
                                               p->exponent, kMaxEsmExponent));
            e.finish();
        }
    } else if (kind != MomentKind::msm) {
        p->exponent = 40;  // TheRealMJP/Shadows' defaults, +40 / -5 for fp32
        // Its VSMBias 0.01 floors the warped depth's deviation at 1e-4 c exp(c w), i.e. a depth
        // deviation of 5e-5. The floor must be small here: the warped gap t - mean is at most
        // exp(c w), so the floor alone leaks (2 c sigma)^2 of the light (0.0064 at sigma 1e-3).
        p->min_variance = kEvsmMinVariance;
        if (o.has("evsm")) {
            JsonObject e = o.object("evsm");
            if (e.has("exponents")) {
                const nlohmann::json& x = e.get("exponents");
                if (!x.is_array() || x.size() != 2 || !x[0].is_number() || !x[1].is_number())
                    e.fail("exponents", "expected [positive, negative], two numbers, e.g. [40, 5]");
                p->exponent = x[0].get<double>();
                p->negative_exponent = x[1].get<double>();
                for (double c : {p->exponent, p->negative_exponent}) {
                    if (!(c > 0)) e.fail("exponents", fmt::format("{} is not > 0 (both are magnitudes)", c));
                    if (c > kMaxEvsmExponent)
                        e.fail("exponents",
                               fmt::format("{} overflows float32 moments: the second moment exp(2c) exceeds FLT_MAX "
                                           "beyond c = {} (Filament's fp32 limit)",
                                           c, kMaxEvsmExponent));
                }
            }
            p->min_variance = e.number_in("min_variance", p->min_variance, 0.0, 1.0, "squared depth units in [0, 1]");
            p->light_bleed = e.number_in("light_bleed", p->light_bleed, 0.0, 0.999, "a fraction in [0, 0.999]");
            e.finish();
        }
    } else {
        // msm: Peters & Klein's bound needs no light-bleed reduction (TheRealMJP/Shadows: 0 by default).
        p->light_bleed = 0;
        p->min_variance = 0;
        if (o.has("msm")) {
            JsonObject m = o.object("msm");
            p->variant = pick_enum(m, "variant", MsmVariant::hamburger, {MsmVariant::hamburger, MsmVariant::hausdorff});
            p->storage_bits = static_cast<int>(m.integer("storage", 32, 16, 32));
            if (p->storage_bits != 16 && p->storage_bits != 32)
                m.fail("storage",
                       fmt::format("{} is not 16 (optimised 16-bit quantisation) or 32 (float)", p->storage_bits));
            p->moment_bias = m.number_in("moment_bias", p->storage_bits == 16 ? kMsmMomentBias16 : kMsmMomentBias32,
                                         0.0, 0.5, "a fraction in [0, 0.5]");
            m.finish();
        }
    }
    t.family_parameters = std::move(p);
}

nlohmann::json moment_keys_json(const Technique& t) {
    const MomentParameters& p = parameters_of(t);
    nlohmann::json j = depth_map_keys_json(t);
    j["blur"] = p.blur;
    j["mipmaps"] = p.mipmaps;
    switch (p.kind) {
        case MomentKind::vsm: j["vsm"] = {{"min_variance", p.min_variance}, {"light_bleed", p.light_bleed}}; break;
        case MomentKind::esm: j["esm"] = {{"exponent", p.exponent}}; break;
        case MomentKind::evsm2:
        case MomentKind::evsm4:
            j["evsm"] = {{"exponents", {p.exponent, p.negative_exponent}},
                         {"min_variance", p.min_variance},
                         {"light_bleed", p.light_bleed}};
            break;
        case MomentKind::msm:
            j["msm"] = {{"variant", to_string(p.variant)}, {"storage", p.storage_bits}, {"moment_bias", p.moment_bias}};
            break;
    }
    return j;
}

FamilyEntry moment_family_entry(MomentKind kind, std::string description) {
    FamilyEntry e = depth_map_family_entry();
    e.name = to_string(kind);
    e.description = std::move(description);
    e.parse = [kind](JsonObject& o, Technique& t) { parse_moment_keys(kind, o, t); };
    e.write = [](const Technique& t, nlohmann::json& j) { j.update(moment_keys_json(t)); };
    e.hints = [](const Technique& t) {
        // The filter reaches the blur radius plus the bilinear tap's texel; light bleeding is
        // a class of its own for these families (docs/metrics.md).
        ScoringHints h = depth_map_family_entry().hints(t);
        h.filter_reach_texels = 1.0 + parameters_of(t).blur;
        h.light_bleeding = true;
        return h;
    };
    e.describe_light = [](const Technique& t, const Light&, const RasterLightStats&) {
        const MomentParameters& p = parameters_of(t);
        return nlohmann::json{
            {"moments",
             {{"kind", to_string(p.kind)},
              {"count", p.kind == MomentKind::esm                                  ? 1
                        : p.kind == MomentKind::evsm4 || p.kind == MomentKind::msm ? 4
                                                                                   : 2},
              {"blur_texels", p.blur},
              {"format", p.kind == MomentKind::msm && p.storage_bits == 16          ? "rgba16_unorm"
                         : p.kind == MomentKind::esm                                ? "r32_sfloat"
                         : p.kind == MomentKind::vsm || p.kind == MomentKind::evsm2 ? "rg32_sfloat"
                                                                                    : "rgba32_sfloat"},
              {"sampled", p.mipmaps ? "trilinear" : "bilinear"},
              {"gathered_in_lookup", false}}}};
    };
    for (const char* k : {"blur", "mipmaps"}) e.sweep_keys.push_back(k);
    e.memory = [](const Technique& t) {
        // The depth map, and the moment texture with the blur's scratch (a third more with the
        // mip chain), counted as bytes of a map texel.
        const MomentParameters& p = parameters_of(t);
        RasterMemory m = depth_map_family_entry().memory(t);
        const int texel = p.kind == MomentKind::esm                                  ? 4
                          : p.kind == MomentKind::vsm || p.kind == MomentKind::evsm2 ? 8
                          : p.kind == MomentKind::msm && p.storage_bits == 16        ? 8
                                                                                     : 16;
        m.depth_bytes += texel + (p.mipmaps ? (texel * 4 + 2) / 3 : texel);
        return m;
    };
    const std::string own = kind == MomentKind::vsm   ? "vsm"
                            : kind == MomentKind::esm ? "esm"
                            : kind == MomentKind::msm ? "msm"
                                                      : "evsm";
    std::erase_if(e.sweep_keys, [](const std::string& k) { return k.rfind("filter.", 0) == 0; });
    // tune searches the family's own knobs (tune/tune.h): the variance floor, the light-bleed
    // reduction, the exponent, the moment bias. The depth-map biases stay keys, not knobs: the
    // family's defaults leave them off.
    e.tune_knobs.clear();
    if (kind == MomentKind::esm) {
        e.sweep_keys.push_back("esm.exponent");
        e.tune_knobs.push_back("esm.exponent");
    } else if (kind == MomentKind::msm) {
        for (const char* k : {"msm.variant", "msm.storage", "msm.moment_bias"}) e.sweep_keys.push_back(k);
        e.tune_knobs.push_back("msm.moment_bias");
    } else {
        for (const char* k : {".min_variance", ".light_bleed"}) {
            e.sweep_keys.push_back(own + k);
            e.tune_knobs.push_back(own + k);
        }
        if (kind != MomentKind::vsm) {
            e.sweep_keys.push_back("evsm.exponents");
            e.tune_knobs.push_back("evsm.exponents");
        }
    }
    return e;
}

}  // namespace

void add_filterable_families(std::deque<FamilyEntry>& families) {
    families.push_back(
        moment_family_entry(MomentKind::vsm,
                            "variance shadow maps (Donnelly & Lauritzen 2006): two moments, Chebyshev's bound with a "
                            "variance floor and light-bleed reduction; \"blur\" texels of separable Gaussian"));
    families.push_back(moment_family_entry(
        MomentKind::esm, "exponential shadow maps (Annen et al. 2008): exp(c d) filtered, visibility exp(c (d - z))"));
    families.push_back(
        moment_family_entry(MomentKind::evsm2,
                            "exponential variance shadow maps (Lauritzen & McCool 2008): Chebyshev on the positive "
                            "exponential warp of depth in [-1, 1]"));
    families.push_back(
        moment_family_entry(MomentKind::evsm4,
                            "exponential variance shadow maps (Lauritzen & McCool 2008): positive and negative "
                            "warps, the smaller Chebyshev bound"));
    families.push_back(
        moment_family_entry(MomentKind::msm,
                            "moment shadow maps (Peters & Klein 2015): four moments, the sharpest lower bound on the "
                            "shadow (Hamburger or Hausdorff), 32-bit or optimised 16-bit storage"));
}

}  // namespace penumbra::raster
