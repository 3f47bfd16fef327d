// The filterable families (docs/raster.md, "Filterable shadow maps"): variance shadow maps
// (Donnelly & Lauritzen 2006), exponential shadow maps (Annen et al. 2008) and exponential
// variance shadow maps (Lauritzen & McCool 2008), with two or four moments. They share the
// depth-map family's map and keys (resolution, format, fit, cull, bias, lights), and its lookup
// gathers the moments of the map's depths under a separable Gaussian and a bilinear tap, which
// is what sampling a blurred moment map with hardware bilinear filtering gives.
#include "raster/filterable.h"

#include <fmt/format.h>

#include "common/json_reader.h"
#include "raster/technique_family.h"

namespace penumbra::raster {

const char* to_string(MomentKind k) {
    static const char* const kNames[] = {"vsm", "esm", "evsm2", "evsm4"};
    return kNames[static_cast<int>(k)];
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
    if (o.boolean("mipmaps", false))
        o.fail("mipmaps", "mip-mapped moments are not implemented yet (false is the only value)");
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
    } else {
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
    }
    t.family_parameters = std::move(p);
}

nlohmann::json moment_keys_json(const Technique& t) {
    const MomentParameters& p = parameters_of(t);
    nlohmann::json j = depth_map_keys_json(t);
    j["blur"] = p.blur;
    j["mipmaps"] = false;
    switch (p.kind) {
        case MomentKind::vsm: j["vsm"] = {{"min_variance", p.min_variance}, {"light_bleed", p.light_bleed}}; break;
        case MomentKind::esm: j["esm"] = {{"exponent", p.exponent}}; break;
        case MomentKind::evsm2:
        case MomentKind::evsm4:
            j["evsm"] = {{"exponents", {p.exponent, p.negative_exponent}},
                         {"min_variance", p.min_variance},
                         {"light_bleed", p.light_bleed}};
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
        return nlohmann::json{{"moments",
                               {{"kind", to_string(p.kind)},
                                {"count", p.kind == MomentKind::esm     ? 1
                                          : p.kind == MomentKind::evsm4 ? 4
                                                                        : 2},
                                {"blur_texels", p.blur},
                                {"gathered_in_lookup", true}}}};
    };
    for (const char* k : {"blur"}) e.sweep_keys.push_back(k);
    const std::string own = kind == MomentKind::vsm ? "vsm" : kind == MomentKind::esm ? "esm" : "evsm";
    std::erase_if(e.sweep_keys, [](const std::string& k) { return k.rfind("filter.", 0) == 0; });
    // tune searches bias knobs only (tune/tune.h) and has none yet for the variance floor, the
    // light-bleed reduction or the exponents that tune a moment family: it refuses the family
    // by name (exit 2) rather than search the wrong knobs.
    e.tune_knobs.clear();
    if (kind == MomentKind::esm) {
        e.sweep_keys.push_back("esm.exponent");
    } else {
        for (const char* k : {".min_variance", ".light_bleed"}) e.sweep_keys.push_back(own + k);
        if (kind != MomentKind::vsm) e.sweep_keys.push_back("evsm.exponents");
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
}

}  // namespace penumbra::raster
