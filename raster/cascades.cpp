// The cascaded family's keys and split placement (raster/cascades.h). Its drawing is the depth
// map's (raster/depth_map.cpp), which gives a directional light one layer per cascade when the
// technique carries Cascades; spot, point and area lights are drawn as the depth_map family draws them.
#include "raster/cascades.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "common/json_reader.h"
#include "raster/technique_family.h"

namespace penumbra::raster {

const char* to_string(CascadeSplit s) {
    static const char* const kNames[] = {"practical", "uniform", "log", "geometric", "fractions"};
    return kNames[static_cast<int>(s)];
}
const char* to_string(CascadeFit f) {
    static const char* const kNames[] = {"sphere", "bounds"};
    return kNames[static_cast<int>(f)];
}

double uniform_split(double near, double far, int i, int count) {
    return near + (far - near) * i / count;
}

double log_split(double near, double far, int i, int count) {
    return near * std::pow(far / near, static_cast<double>(i) / count);
}

double practical_split(double near, double far, int i, int count, double lambda) {
    return lambda * log_split(near, far, i, count) + (1 - lambda) * uniform_split(near, far, i, count);
}

double geometric_split(double first_far, double far, int i, int count) {
    if (count == 1) return far;
    return first_far * std::pow(far / first_far, static_cast<double>(i - 1) / (count - 1));
}

std::vector<double> cascade_far_bounds(const Cascades& c, double near, double far) {
    std::vector<double> bounds;
    for (int i = 1; i <= c.count; ++i) {
        double b = far;
        switch (c.split) {
            case CascadeSplit::uniform: b = uniform_split(near, far, i, c.count); break;
            case CascadeSplit::log: b = log_split(near, far, i, c.count); break;
            case CascadeSplit::practical: b = practical_split(near, far, i, c.count, c.lambda); break;
            case CascadeSplit::geometric: b = geometric_split(c.first_far.value_or(far), far, i, c.count); break;
            case CascadeSplit::fractions:
                b = i - 1 < static_cast<int>(c.fractions.size()) ? c.fractions[i - 1] * far : far;
                break;
        }
        bounds.push_back(i == c.count ? far : b);  // the last ends exactly at the range's end
    }
    return bounds;
}

std::vector<double> sdsm_far_bounds(const Cascades& c, double near, double far, double lo, double hi) {
    lo = std::clamp(lo, near, far);
    hi = std::clamp(hi, lo, far);
    if (!(hi > lo)) hi = std::min(far, lo + std::max(1e-6, 1e-6 * std::abs(lo)));  // one depth seen
    if (c.split == CascadeSplit::fractions) {
        std::vector<double> bounds;
        for (int i = 1; i <= c.count; ++i)
            bounds.push_back(
                i < c.count && i - 1 < static_cast<int>(c.fractions.size()) ? lo + c.fractions[i - 1] * (hi - lo) : hi);
        return bounds;
    }
    Cascades scaled = c;
    if (c.split == CascadeSplit::geometric && c.first_far)
        scaled.first_far = lo + (*c.first_far - near) / (far - near) * (hi - lo);
    return cascade_far_bounds(scaled, lo, hi);
}

const char* cascade_bias_scaling(const Technique& t, std::string_view key) {
    const Cascades* c = cascades_of(t);
    if (!c) return "";
    if (key == "bias.slope" || key == "bias.normal_offset") return "texel_scaled";
    if (key == "bias.world" || key == "bias.constant") return c->texel_scaled_bias ? "texel_scaled" : "same";
    return "same";
}

const Cascades* cascades_of(const Technique& t) {
    return t.family == "cascaded" ? dynamic_cast<const Cascades*>(t.family_parameters.get()) : nullptr;
}

namespace {

Cascades parse_cascades(JsonObject& o) {
    Cascades c;
    const bool has_fractions = o.has("fractions");
    if (has_fractions) {
        const nlohmann::json& f = o.get("fractions");
        if (!f.is_array() || f.empty())
            o.fail("fractions", "expected a non-empty array of fractions of max_distance, e.g. [0.1, 0.2, 0.5]");
        double previous = 0;
        for (const nlohmann::json& x : f) {
            if (!x.is_number()) o.fail("fractions", "expected numbers");
            const double v = x.get<double>();
            if (!(v > previous && v <= 1))
                o.fail("fractions", fmt::format("{} is not increasing in (0, 1] (fractions of max_distance)", v));
            previous = v;
            c.fractions.push_back(v);
        }
        // The last cascade ends at max_distance: a trailing 1 says so, and is implied without it.
        if (c.fractions.back() == 1.0) c.fractions.pop_back();
    }
    const int implied = static_cast<int>(c.fractions.size()) + 1;
    c.count = static_cast<int>(o.integer("count", has_fractions ? implied : 4, 1, kMaxCascades));
    c.split = pick_enum(o, "split", has_fractions ? CascadeSplit::fractions : CascadeSplit::practical,
                        {CascadeSplit::practical, CascadeSplit::uniform, CascadeSplit::log, CascadeSplit::geometric,
                         CascadeSplit::fractions});
    c.lambda = o.number_in("lambda", 0.5, 0.0, 1.0, "a weight in [0, 1]");
    if (o.has("first_far")) c.first_far = o.number_in("first_far", 1e-6, 1e12, "metres > 0");
    if (o.has("max_distance")) c.max_distance = o.number_in("max_distance", 1e-6, 1e12, "metres > 0");
    c.overlap = o.number_in("overlap", 0.0, 0.0, 0.5, "a fraction in [0, 0.5]");
    c.fit = pick_enum(o, "fit", CascadeFit::sphere, {CascadeFit::sphere, CascadeFit::bounds});
    c.stabilize = o.boolean("stabilize", true);
    c.sdsm = o.boolean("sdsm", false);
    c.texel_scaled_bias = o.boolean("texel_scaled_bias", false);
    if (c.split == CascadeSplit::fractions) {
        if (c.fractions.empty() && c.count > 1)
            o.fail("split", "\"fractions\" needs the fractions key, e.g. \"fractions\": [0.1, 0.2, 0.5]");
        if (implied != c.count)
            o.fail("fractions",
                   fmt::format("{} fractions end {} cascades, but count is {}", c.fractions.size(), implied, c.count));
    } else if (has_fractions) {
        o.fail("fractions",
               fmt::format("only split \"fractions\" reads fractions (split is \"{}\")", to_string(c.split)));
    }
    if (c.split == CascadeSplit::geometric) {
        if (!c.first_far) o.fail("split", "\"geometric\" needs first_far, the first cascade's far bound in metres");
        if (c.max_distance && *c.first_far >= *c.max_distance)
            o.fail("first_far", fmt::format("{} m is not less than max_distance {} m", *c.first_far, *c.max_distance));
    } else if (c.first_far) {
        o.fail("first_far",
               fmt::format("only split \"geometric\" reads first_far (split is \"{}\")", to_string(c.split)));
    }
    o.finish();
    return c;
}

nlohmann::json cascades_json(const Cascades& c) {
    nlohmann::json j = {{"count", c.count},        {"split", to_string(c.split)},
                        {"lambda", c.lambda},      {"overlap", c.overlap},
                        {"fit", to_string(c.fit)}, {"stabilize", c.stabilize},
                        {"sdsm", c.sdsm},          {"texel_scaled_bias", c.texel_scaled_bias}};
    if (c.first_far) j["first_far"] = *c.first_far;
    if (!c.fractions.empty()) j["fractions"] = c.fractions;
    if (c.max_distance) j["max_distance"] = *c.max_distance;
    return j;
}

}  // namespace

FamilyEntry cascaded_family_entry() {
    // The depth map's keys, scoring and drawing, with a layer per cascade for directional lights.
    FamilyEntry e = depth_map_family_entry();
    e.name = "cascaded";
    e.description =
        "cascaded shadow maps: a directional light's view depth split into technique.cascades.count slices, one "
        "map each (resolution, bias and filter per cascade); other lights drawn as depth_map draws them";
    e.parse = [](JsonObject& o, Technique& t) {
        parse_depth_map_keys(o, t);
        if (o.has("area_samples") && o.integer("area_samples", 0, 256) > 0)
            o.fail("area_samples", "only the averaged_area family draws area samples (\"family\": \"averaged_area\")");
        Cascades c;
        if (o.has("cascades")) {
            JsonObject co = o.object("cascades");
            c = parse_cascades(co);
        }
        t.family_parameters = std::make_shared<const Cascades>(c);
    };
    e.write = [](const Technique& t, nlohmann::json& j) {
        j.update(depth_map_keys_json(t));
        j["area_samples"] = 0;
        const Cascades* c = cascades_of(t);
        j["cascades"] = cascades_json(c ? *c : Cascades{});
    };
    e.memory = [](const Technique& t) {
        RasterMemory m = depth_map_family_entry().memory(t);
        const Cascades* c = cascades_of(t);
        m.directional_layers = c ? c->count : Cascades{}.count;
        return m;
    };
    // raster.json: with SDSM, the view depths the splits were placed between.
    e.describe_light = [](const Technique& t, const Light& light, const RasterLightStats& stats) {
        nlohmann::json j = depth_map_family_entry().describe_light(t, light, stats);
        if (const auto& r = stats.projection.sdsm_range) j["sdsm"] = {{"near_m", r->x}, {"far_m", r->y}};
        return j;
    };
    for (const char* key :
         {"cascades.count", "cascades.split", "cascades.lambda", "cascades.first_far", "cascades.max_distance",
          "cascades.overlap", "cascades.fit", "cascades.stabilize", "cascades.sdsm", "cascades.texel_scaled_bias"})
        e.sweep_keys.push_back(key);
    return e;
}

}  // namespace penumbra::raster
