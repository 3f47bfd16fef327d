#include "raster/technique.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <stdexcept>

#include "common/errors.h"
#include "common/json_reader.h"
#include "raster/technique_family.h"

namespace penumbra::raster {

using nlohmann::json;

// Names indexed by the enums' values, in declaration order (technique.h).
const char* to_string(Fit f) {
    static const char* const kNames[] = {"scene_sphere", "scene_bounds", "camera_frustum"};
    return kNames[static_cast<int>(f)];
}
const char* to_string(DepthFormat f) {
    static const char* const kNames[] = {"d16", "d24", "d32"};
    return kNames[static_cast<int>(f)];
}
const char* to_string(Cull c) {
    static const char* const kNames[] = {"none", "back", "front", "material"};
    return kNames[static_cast<int>(c)];
}
std::string to_string(Blend b, double cutoff) {
    if (b == Blend::cutout) return fmt::format("cutout({:g})", cutoff);
    return b == Blend::none ? "none" : "opaque";
}
const char* to_string(DepthLayer d) {
    static const char* const kNames[] = {"first", "midpoint", "second"};
    return kNames[static_cast<int>(d)];
}
const char* to_string(Precision p) {
    static const char* const kNames[] = {"camera_relative", "world_float32"};
    return kNames[static_cast<int>(p)];
}
const char* to_string(NormalFactor f) {
    static const char* const kNames[] = {"none", "one_minus_ndotl", "sin"};
    return kNames[static_cast<int>(f)];
}
double depth_resolution(DepthFormat f) {
    switch (f) {
        case DepthFormat::d16: return std::ldexp(1.0, -16);
        case DepthFormat::d24: return std::ldexp(1.0, -24);
        case DepthFormat::d32: return 0.0;
    }
    return 0.0;
}

double filter_reach_texels(const Filter& f) {
    const double bilinear = f.bilinear_taps ? 0.5 : 0.0;
    switch (f.type) {
        case FilterType::none: return 1.0;
        case FilterType::hw2x2: return 1.0;
        case FilterType::pcf: return std::max(1.0, 0.5 * f.size + bilinear);
        case FilterType::poisson:
        case FilterType::vogel: return std::max(1.0, f.radius_texels + bilinear);
        case FilterType::pcss: return std::max(1.0, f.max_radius_texels);
    }
    return 1.0;
}

const char* to_string(FilterType f) {
    static const char* const kNames[] = {"none", "hw2x2", "pcf", "poisson", "pcss", "vogel"};
    return kNames[static_cast<int>(f)];
}

const std::vector<Preset>& presets() {
    // Every bias key at zero: the presets that mean "no bias of any kind" say so key by key.
    static const json kNoBias = {
        {"constant", 0},          {"slope", 0}, {"clamp", 0}, {"world", 0}, {"normal_offset", 0}, {"shader_depth", 0},
        {"receiver_plane", false}};
    // The configurations of references 000-004 (docs/design.md, "References") in technique keys.
    static const std::vector<Preset> kPresets = {
        {"d3d12-textbook",
         "references 000/003: D3D12 textbook demo. Sphere fit, D24, DepthBias 100000 (r = 2^-24, the same r in "
         "Vulkan), SlopeScaledDepthBias 1.0, no clamp, 3x3 PCF of hardware 2x2 compare taps, 2048^2",
         json{{"resolution", 2048},
              {"depth_format", "d24"},
              {"fit", "scene_sphere"},
              {"cull", "back"},
              {"bias", {{"constant", 100000}, {"slope", 1.0}, {"clamp", 0.0}}},
              {"filter", {{"type", "pcf"}, {"size", 3}, {"bilinear_taps", true}}}}},
        {"diligent-tutorial13",
         "reference 002: Diligent Engine Tutorial13. Light-space scene-extent fit, depth clip off (clamp), 2x2 "
         "comparison filter; no bias. Not modelled: the tutorial draws only the cube into the map and only the "
         "plane receives, so no surface both casts and receives; here every surface does (expect acne)",
         json{{"fit", "scene_bounds"},
              {"cull", "back"},
              {"bias", {{"constant", 0}, {"slope", 0}}},
              {"filter", {{"type", "hw2x2"}}}}},
        {"camera-frustum-article",
         "reference 004: MonoGame-style article. Ortho box fitted to the camera frustum's corners in light space, "
         "float depth, constant bias subtracted in the shader (0.001: the article leaves the value to the reader), "
         "single tap, 4096^2. Not modelled: the article's fit and shader bias are for a directional light; spot "
         "and point lights get the same bias in their perspective depth, where it means other distances",
         json{{"resolution", 4096},
              {"depth_format", "d32"},
              {"fit", "camera_frustum"},
              {"cull", "none"},
              {"bias", {{"constant", 0}, {"slope", 0}, {"shader_depth", 0.001}}},
              {"filter", {{"type", "none"}}}}},
        {"pcss",
         "reference 001 / Fernando 2005: percentage-closer soft shadows from the area light's centre, 16-tap "
         "blocker search and filter up to 32 texels, receiver-plane and slope bias 1.5 (wide kernels need the "
         "first), 2048^2",
         json{{"bias", {{"slope", 1.5}, {"constant", 2}, {"receiver_plane", true}}},
              {"filter", {{"type", "pcss"}, {"taps", 16}, {"max_radius_texels", 32}}}}},
        {"averaged-hard-shadows",
         "reference 001: 16 hard shadow maps from points spread over the area light, averaged; slope bias 1.5, "
         "2048^2",
         json{{"bias", {{"slope", 1.5}, {"constant", 2}}}, {"filter", {{"type", "none"}}}, {"area_samples", 16}}},
        {"no-bias",
         "no bias of any kind, back-face culling, a single tap: penumbra's default before the biased default. "
         "Every surface that both casts and receives shows acne; the setup to see a scene's raw acne",
         json{{"cull", "back"}, {"bias", kNoBias}, {"filter", {{"type", "none"}}}}},
        {"rtr-shadow-volume",
         "seed 001's stencil shadow volumes: silhouettes extruded to infinity, z-fail (Carmack's reverse) with "
         "two-sided stencil (Everitt & Kilgard 2002); open meshes cast as two-sided sheets",
         json{{"family", "shadow_volume"}, {"shadow_volume", {{"open_meshes", "include"}, {"method", "zfail"}}}}},
        {"rtr-midpoint",
         "seed 001's midpoint row (Woo, Graphics Gems III, 1992): the map stores the midpoint between the nearest "
         "surface and the next one behind it (a second, peeled depth pass), both faces drawn, no bias of any kind, "
         "a single tap",
         json{{"family", "depth_map"},
              {"depth_layer", "midpoint"},
              {"cull", "none"},
              {"bias", kNoBias},
              {"filter", {{"type", "none"}}}}},
        {"rtr-planar",
         "seed 001's planar-projection row (Blinn, \"Me and My (Fake) Shadow\", 1988): casters flattened onto the "
         "scene's largest upward plane by the light's projection matrix, drawn once per pixel through a stencil; "
         "only that plane receives shadow",
         json{{"family", "planar_projection"}}},
        // Engines' defaults for a sun (docs/engines.md has every value's source and conversion).
        // A preset does not know the scene, so spot and point lights get the sun's keys; where an
        // engine differs for them, docs/engines.md says what the preset draws instead.
        {"bevy",
         "bevy 0.19 (main 4805ca7): 4 cascades, geometric far bounds from 10 m to 150 m, 20% overlap blended, "
         "2048^2 per cascade, Depth32Float reverse-Z, shadow_depth_bias 0.02 m along L and shadow_normal_bias 1.8 "
         "texels x sqrt2 along the normal (no N.L term); Gaussian filter approximated by 5x5 bilinear PCF",
         json{{"family", "cascaded"},
              {"resolution", 2048},
              {"depth_format", "d32"},
              {"reversed_z", true},
              {"cull", "back"},
              {"bias", {{"constant", 0}, {"slope", 0}, {"world", 0.02}, {"normal_offset", 1.8 * 1.4142135623730951}}},
              {"cascades",
               {{"count", 4},
                {"split", "geometric"},
                {"first_far", 10.0},
                {"max_distance", 150.0},
                {"overlap", 0.2},
                {"fit", "sphere"},
                {"stabilize", true}}},
              {"filter", {{"type", "pcf"}, {"size", 5}, {"bilinear_taps", true}}}}},
        {"godot",
         "Godot 4 Forward+: PSSM 4 splits at 0.1/0.2/0.5 of 100 m, 2048^2 per split (half the 4096 atlas), 16-bit "
         "depth, shadow_bias 0.1 -> 0.002 x each split's depth range (x blur 1 x Soft Low radius 2), normal bias 2 "
         "texels along the normal without its component along L (BIAS_FUNC's 1 - max(0, dot(L, -N)) is 1 on every "
         "lit receiver); Soft Low filter approximated by 4 Poisson taps of radius 2 texels",
         json{{"family", "cascaded"},
              {"resolution", 2048},
              {"depth_format", "d16"},
              {"cull", "back"},
              {"bias",
               {{"constant", 0},
                {"slope", 0},
                {"world_depth_range", 0.002},
                {"normal_offset", 2.0},
                {"normal_factor", "none"},
                {"normal_perpendicular", true}}},
              {"cascades",
               {{"split", "fractions"},
                {"fractions", {0.1, 0.2, 0.5}},
                {"max_distance", 100.0},
                {"fit", "sphere"},
                {"stabilize", true}}},
              {"filter", {{"type", "poisson"}, {"taps", 4}, {"radius_texels", 2.0}, {"bilinear_taps", true}}}}},
        {"unity-urp",
         "Unity URP (new asset): one cascade over a 50 m shadow distance, 2048^2, 16-bit, sphere fit; casters "
         "moved 1 texel away from the light and 1 texel x (1 - N.L) inward while the map is drawn, hardware "
         "bias (1.0, 2.5); soft shadows off: one bilinear compare",
         json{{"family", "cascaded"},
              {"resolution", 2048},
              {"depth_format", "d16"},
              {"cull", "back"},
              {"bias",
               {{"constant", 1.0},
                {"slope", 2.5},
                {"caster", {{"world_texels", 1.0}, {"normal_texels", 1.0}, {"normal_factor", "one_minus_ndotl"}}}}},
              {"cascades", {{"count", 1}, {"max_distance", 50.0}, {"fit", "sphere"}, {"stabilize", true}}},
              {"filter", {{"type", "hw2x2"}}}}},
        {"unreal-csm",
         "Unreal Engine 5 cascaded shadow maps (not the default virtual shadow maps): 3 cascades, distribution "
         "exponent 3 over 200 m (far bounds 1/13, 4/13, 1), 2048^2, caster depth bias 10 cm x ShadowBias 0.5 and "
         "slope 3 x 0.5 (unverified: Epic's source was not read); filter approximated by 3x3 bilinear PCF",
         json{{"family", "cascaded"},
              {"resolution", 2048},
              {"depth_format", "d16"},
              {"cull", "back"},
              {"bias", {{"constant", 0}, {"slope", 1.5}, {"caster", {{"world", 0.05}}}}},
              {"cascades",
               {{"split", "fractions"},
                {"fractions", {1.0 / 13.0, 4.0 / 13.0}},
                {"max_distance", 200.0},
                {"fit", "sphere"},
                {"stabilize", true}}},
              {"filter", {{"type", "pcf"}, {"size", 3}, {"bilinear_taps", true}}}}},
        {"three",
         "three.js r187: 512^2, 24-bit, no cascades; the fixed +-5 m shadow camera (which scenes always replace) "
         "fitted to the scene's bounding sphere; culled by material (shadowSide): a FrontSide material's back faces "
         "drawn into the map, a DoubleSide one's both; bias 0, normalBias 0; PCFShadowMap: 5 bilinear compares on a "
         "Vogel disk of radius 1 texel turned per "
         "pixel by interleaved gradient noise",
         json{{"family", "depth_map"},
              {"resolution", 512},
              {"depth_format", "d24"},
              {"fit", "scene_sphere"},
              {"cull", "material"},
              {"single_sided_cull", "front"},
              {"bias", {{"constant", 0}, {"slope", 0}, {"shader_depth", 0}, {"normal_offset_m", 0}}},
              {"filter", {{"type", "vogel"}, {"taps", 5}, {"radius_texels", 1.0}, {"bilinear_taps", true}}}}},
        {"three-csm",
         "three.js r187 CSM addon: 3 cascades, practical split lambda 0.5 to the camera's far plane, 2048^2, "
         "24-bit, diagonal fit snapped to texels, culled by material (shadowSide: a FrontSide material's back faces, a "
         "DoubleSide one's both), shadowBias 1e-6 added to the "
         "receiver's depth, the renderer's 5-tap Vogel PCF",
         json{{"family", "cascaded"},
              {"resolution", 2048},
              {"depth_format", "d24"},
              {"cull", "material"},
              {"single_sided_cull", "front"},
              {"bias", {{"constant", 0}, {"slope", 0}, {"shader_depth", -1e-6}}},
              {"cascades",
               {{"count", 3}, {"split", "practical"}, {"lambda", 0.5}, {"fit", "sphere"}, {"stabilize", true}}},
              {"filter", {{"type", "vogel"}, {"taps", 5}, {"radius_texels", 1.0}, {"bilinear_taps", true}}}}},
        {"filament",
         "Filament (LightManager::ShadowOptions): one 1024^2 map fitted to the view, constantBias 1 mm towards "
         "the light, normalBias 1 -> 0.5 texel x sin(theta) along the normal, polygon offset 0.5/2.0, PCF "
         "approximated by 2x2 bilinear taps (a 3x3 footprint); LiSPSM not modelled",
         json{{"family", "depth_map"},
              {"resolution", 1024},
              {"depth_format", "d32"},
              {"fit", "camera_frustum"},
              {"cull", "back"},
              {"bias",
               {{"constant", 0.5}, {"slope", 2.0}, {"world", 0.001}, {"normal_offset", 0.5}, {"normal_factor", "sin"}}},
              {"filter", {{"type", "pcf"}, {"size", 2}, {"bilinear_taps", true}}}}},
        {"babylon",
         "Babylon.js 9.28 ShadowGenerator: 1024^2 (the docs' choice: the size is a constructor argument), light "
         "frustum fitted to the casters, culled by material (backFaceCulling: a double-sided material casts both "
         "faces), bias 0.00005 of the map's depth range added to the casters' depth, normalBias 0, filter none",
         json{{"family", "depth_map"},
              {"resolution", 1024},
              {"depth_format", "d32"},
              {"fit", "scene_bounds"},
              {"cull", "material"},
              {"bias", {{"constant", 0}, {"slope", 0}, {"caster", {{"depth", 0.00005}, {"normal", 0}}}}},
              {"filter", {{"type", "none"}}}}},
        {"babylon-csm",
         "Babylon.js 9.28 CascadedShadowGenerator: 4 cascades, practical split lambda 0.5, 10% blend, tight "
         "(unstabilised) fit, depth clamp, 1024^2, caster depth bias 0.00005, PCF (high quality approximated "
         "by 5x5 bilinear PCF)",
         json{{"family", "cascaded"},
              {"resolution", 1024},
              {"depth_format", "d32"},
              {"cull", "material"},
              {"bias", {{"constant", 0}, {"slope", 0}, {"caster", {{"depth", 0.00005}, {"normal", 0}}}}},
              {"cascades",
               {{"count", 4},
                {"split", "practical"},
                {"lambda", 0.5},
                {"overlap", 0.1},
                {"fit", "bounds"},
                {"stabilize", false}}},
              {"filter", {{"type", "pcf"}, {"size", 5}, {"bilinear_taps", true}}}}},
    };
    return kPresets;
}

namespace {

// Reads the bias keys an object gives (any subset), checked; unknown keys are errors.
BiasOverride read_bias(JsonObject& b) {
    BiasOverride o;
    auto number = [](JsonObject& from, const char* key, std::optional<double>& out, double lo, double hi,
                     const char* what) {
        if (from.has(key)) out = from.number_in(key, lo, hi, what);
    };
    auto factor = [](JsonObject& from, std::optional<NormalFactor>& out) {
        if (from.has("normal_factor"))
            out = pick_enum(from, "normal_factor", NormalFactor::none,
                            {NormalFactor::none, NormalFactor::one_minus_ndotl, NormalFactor::sin});
    };
    number(b, "constant", o.constant, -1e9, 1e9, "a depth-bias constant factor within +-1e9");
    number(b, "slope", o.slope, -1e4, 1e4, "a slope factor within +-1e4");
    number(b, "clamp", o.clamp, -1.0, 1.0, "a clamp within [-1, 1] depth units");
    number(b, "world", o.world, -1e6, 1e6, "metres within +-1e6");
    number(b, "normal_offset", o.normal_offset, -1e3, 1e3, "texel footprints within +-1000");
    number(b, "shader_depth", o.shader_depth, -1.0, 1.0, "depth units within [-1, 1]");
    if (b.has("receiver_plane")) o.receiver_plane = b.boolean("receiver_plane", false);
    number(b, "normal_offset_m", o.normal_offset_m, -1e6, 1e6, "metres within +-1e6");
    factor(b, o.normal_factor);
    if (b.has("normal_perpendicular")) o.normal_perpendicular = b.boolean("normal_perpendicular", false);
    number(b, "world_depth_range", o.world_depth_range, 0.0, 1.0, "a fraction of the map's depth range in [0, 1]");
    if (b.has("caster")) {
        JsonObject c = b.object("caster");
        CasterBiasOverride& k = o.caster;
        number(c, "world", k.world, -1e6, 1e6, "metres within +-1e6");
        number(c, "world_texels", k.world_texels, -1e3, 1e3, "texels within +-1000");
        number(c, "normal", k.normal, -1e6, 1e6, "metres within +-1e6");
        number(c, "normal_texels", k.normal_texels, -1e3, 1e3, "texels within +-1000");
        factor(c, k.normal_factor);
        number(c, "depth", k.depth, -1.0, 1.0, "normalised depth within [-1, 1]");
        c.finish();
    }
    b.finish();
    return o;
}

void apply(const BiasOverride& o, Bias& b) {
    if (o.constant) b.constant = *o.constant;
    if (o.slope) b.slope = *o.slope;
    if (o.clamp) b.clamp = *o.clamp;
    if (o.world) b.world = *o.world;
    if (o.normal_offset) b.normal_offset = *o.normal_offset;
    if (o.shader_depth) b.shader_depth = *o.shader_depth;
    if (o.receiver_plane) b.receiver_plane = *o.receiver_plane;
    if (o.normal_offset_m) b.normal_offset_m = *o.normal_offset_m;
    if (o.normal_factor) b.normal_factor = *o.normal_factor;
    if (o.normal_perpendicular) b.normal_perpendicular = *o.normal_perpendicular;
    if (o.world_depth_range) b.world_depth_range = *o.world_depth_range;
    const CasterBiasOverride& k = o.caster;
    if (k.world) b.caster.world = *k.world;
    if (k.world_texels) b.caster.world_texels = *k.world_texels;
    if (k.normal) b.caster.normal = *k.normal;
    if (k.normal_texels) b.caster.normal_texels = *k.normal_texels;
    if (k.normal_factor) b.caster.normal_factor = *k.normal_factor;
    if (k.depth) b.caster.depth = *k.depth;
}

json bias_json(const BiasOverride& o) {
    json j = json::object();
    if (o.constant) j["constant"] = *o.constant;
    if (o.slope) j["slope"] = *o.slope;
    if (o.clamp) j["clamp"] = *o.clamp;
    if (o.world) j["world"] = *o.world;
    if (o.normal_offset) j["normal_offset"] = *o.normal_offset;
    if (o.shader_depth) j["shader_depth"] = *o.shader_depth;
    if (o.receiver_plane) j["receiver_plane"] = *o.receiver_plane;
    if (o.normal_offset_m) j["normal_offset_m"] = *o.normal_offset_m;
    if (o.normal_factor) j["normal_factor"] = to_string(*o.normal_factor);
    if (o.normal_perpendicular) j["normal_perpendicular"] = *o.normal_perpendicular;
    if (o.world_depth_range) j["world_depth_range"] = *o.world_depth_range;
    const CasterBiasOverride& k = o.caster;
    if (k != CasterBiasOverride{}) {
        json c = json::object();
        if (k.world) c["world"] = *k.world;
        if (k.world_texels) c["world_texels"] = *k.world_texels;
        if (k.normal) c["normal"] = *k.normal;
        if (k.normal_texels) c["normal_texels"] = *k.normal_texels;
        if (k.normal_factor) c["normal_factor"] = to_string(*k.normal_factor);
        if (k.depth) c["depth"] = *k.depth;
        j["caster"] = c;
    }
    return j;
}

// The family a technique object names, or the one it implies without "family": area_samples
// > 0 drew averaged hard shadows before the key existed, and still does.
const FamilyEntry& family_named(JsonObject& o, const json& merged) {
    if (!o.has("family")) {
        const json* samples = merged.contains("area_samples") ? &merged["area_samples"] : nullptr;
        const bool averaged = samples && samples->is_number() && samples->get<double>() > 0;
        const FamilyEntry* inferred = find_technique_family(averaged ? "averaged_area" : kDefaultFamily);
        if (!inferred) throw std::logic_error("the built-in technique families are not registered");
        return *inferred;
    }
    const std::string name = o.string("family");
    if (const FamilyEntry* f = find_technique_family(name)) return *f;
    std::string known, like;
    for (const FamilyEntry& f : technique_families()) {
        known += fmt::format("{}\"{}\"", known.empty() ? "" : ", ", f.name);
        if (like.empty() && name.size() >= 3 &&
            (f.name.find(name) != std::string::npos || edit_distance(name, f.name) <= 2))
            like = f.name;
    }
    o.fail("family", fmt::format("\"{}\" is not a technique family{} (have {})", name,
                                 like.empty() ? "" : fmt::format(" (did you mean \"{}\"?)", like), known));
}

// `blend` (every family): "opaque", "none" or "cutout(T)", T a number in [0, 1].
void read_blend(JsonObject& o, Technique& t) {
    if (!o.has("blend")) return;
    const std::string b = o.string("blend");
    double cutoff = 0.5;
    bool cutout = b == "cutout";
    if (b.size() > 8 && b.starts_with("cutout(") && b.ends_with(")")) {
        const std::string inner = b.substr(7, b.size() - 8);
        char* end = nullptr;
        cutoff = std::strtod(inner.c_str(), &end);
        cutout = end == inner.c_str() + inner.size();
    }
    if (b == "none") {
        t.blend = Blend::none;
    } else if (cutout) {
        if (!(cutoff >= 0 && cutoff <= 1)) o.fail("blend", fmt::format("\"{}\": the cutoff must lie in [0, 1]", b));
        t.blend = Blend::cutout;
        t.blend_cutoff = cutoff;
    } else if (b != "opaque") {
        o.fail("blend", fmt::format("\"{}\" is not opaque, none or cutout(T) (T in [0, 1], e.g. cutout(0.5))", b));
    }
}

}  // namespace

Bias Technique::bias_for(std::size_t light) const {
    Bias b = bias;
    if (light < lights.size()) apply(lights[light].bias, b);
    return b;
}

Technique Technique::for_light(std::size_t light) const {
    Technique t = *this;
    t.bias = bias_for(light);
    t.lights.clear();
    return t;
}

Technique parse_technique(const json& value, const std::string& label) {
    if (!value.is_object()) throw InputError(fmt::format("{}: expected an object", label));
    json merged = value;
    if (value.contains("preset")) {
        const json& name = value["preset"];
        const Preset* found = nullptr;
        for (const auto& p : presets())
            if (name.is_string() && p.name == name.get<std::string>()) found = &p;
        if (!found) {
            std::string names;
            for (const auto& p : presets()) names += fmt::format("{}\"{}\"", names.empty() ? "" : ", ", p.name);
            throw InputError(fmt::format("{}.preset: {} is not a preset (have {})", label, name.dump(), names));
        }
        merged = found->technique;
        merged.merge_patch(value);  // the user's keys win over the preset's
    }

    // `label` is "file: technique" or a file name; JsonObject prefixes paths with it.
    auto colon = label.find(": ");
    std::string file = colon == std::string::npos ? label : label.substr(0, colon);
    std::string path = colon == std::string::npos ? "" : label.substr(colon + 2);
    JsonObject o(merged, file, path);
    Technique t;
    t.preset = o.string("preset", "");
    const FamilyEntry& family = family_named(o, merged);
    t.family = family.name;
    family.parse(o, t);
    read_blend(o, t);
    if (o.has("alpha")) {
        JsonObject a = o.object("alpha");
        t.alpha_mipmaps = a.boolean("mipmaps", false);
        a.finish();
    }
    t.precision =
        pick_enum(o, "precision", Precision::camera_relative, {Precision::camera_relative, Precision::world_float32});
    // A key of another family ("cascades" without "family": "cascaded") names that family.
    for (const std::string& key : o.unread_keys())
        for (const FamilyEntry& other : technique_families()) {
            if (other.name == family.name) continue;
            for (const std::string& k : sweep_keys_of(other))
                if (k == key || k.starts_with(key + "."))
                    o.fail(key, fmt::format("a key of the \"{}\" family, not of \"{}\": add \"family\": \"{}\" (or "
                                            "--set family={})",
                                            other.name, family.name, other.name, other.name));
        }
    o.finish();
    return t;
}

void parse_depth_map_keys(JsonObject& o, Technique& t) {
    const std::string& file = o.file_label();
    t.resolution = static_cast<int>(o.integer("resolution", 2048, 16, 16384));
    t.depth_format =
        pick_enum(o, "depth_format", DepthFormat::d32, {DepthFormat::d16, DepthFormat::d24, DepthFormat::d32});
    t.fit = pick_enum(o, "fit", Fit::scene_bounds, {Fit::scene_sphere, Fit::scene_bounds, Fit::camera_frustum});
    t.shadow_distance = o.number_in("shadow_distance", 0.0, 0.0, 1e12, "metres >= 0 (0: the whole view)");
    if (t.shadow_distance > 0 && t.fit != Fit::camera_frustum)
        o.fail("shadow_distance", "only the camera_frustum fit has a shadow distance");
    t.cull = pick_enum(o, "cull", Cull::back, {Cull::none, Cull::back, Cull::front, Cull::material});
    // Checked whatever `cull` is, used only with material: `--preset three --set cull=none` (or a
    // sweep varying cull over that preset) keeps the preset's value without meaning it.
    const Cull single_sided = pick_enum(o, "single_sided_cull", Cull::back, {Cull::back, Cull::front});
    if (t.cull == Cull::material) t.single_sided_cull = single_sided;
    t.reversed_z = o.boolean("reversed_z", false);
    if (o.has("bias")) {
        JsonObject b = o.object("bias");
        apply(read_bias(b), t.bias);
    }
    if (o.has("lights")) {
        const json& entries = o.get("lights");
        if (!entries.is_array())
            o.fail("lights", "expected an array of per-light overrides, e.g. [{\"bias\": {\"slope\": 2}}, {}]");
        for (std::size_t i = 0; i < entries.size(); ++i) {
            JsonObject l(entries[i], file, fmt::format("{}[{}]", o.path_of("lights"), i));
            LightOverride lo;
            if (l.has("bias")) {
                JsonObject b = l.object("bias");
                lo.bias = read_bias(b);
            }
            l.finish();
            t.lights.push_back(lo);
        }
    }
    if (o.has("filter")) {
        JsonObject f = o.object("filter");
        t.filter.type = pick_enum(f, "type", FilterType::none,
                                  {FilterType::none, FilterType::hw2x2, FilterType::pcf, FilterType::poisson,
                                   FilterType::pcss, FilterType::vogel});
        t.filter.size = static_cast<int>(f.integer("size", 3, 1, 15));
        t.filter.taps = static_cast<int>(f.integer("taps", 16, 1, 64));
        t.filter.radius_texels = f.number_in("radius_texels", 1.5, 0.0, 64.0, "texels in [0, 64]");
        t.filter.bilinear_taps = f.boolean("bilinear_taps", false);
        t.filter.max_radius_texels = f.number_in("max_radius_texels", 32.0, 1.0, 256.0, "texels in [1, 256]");
        f.finish();
    }
}

namespace {

void flatten(const json& j, const std::string& prefix, std::map<std::string, json>& out) {
    if (j.is_object() && !j.empty()) {
        for (auto it = j.begin(); it != j.end(); ++it)
            flatten(it.value(), prefix.empty() ? it.key() : prefix + "." + it.key(), out);
    } else {
        out[prefix] = j;
    }
}

}  // namespace

json preset_differences(const Technique& t) {
    json out = json::object();
    if (t.preset.empty()) return out;
    std::map<std::string, json> mine, theirs;
    flatten(t.to_json(), "", mine);
    flatten(parse_technique(json{{"preset", t.preset}}, "preset " + t.preset).to_json(), "", theirs);
    for (const auto& [key, value] : mine)
        if (const auto it = theirs.find(key); it == theirs.end() || it->second != value)
            out[key] = {{"preset", it == theirs.end() ? json() : it->second}, {"technique", value}};
    for (const auto& [key, value] : theirs)
        if (!mine.contains(key)) out[key] = {{"preset", value}, {"technique", nullptr}};
    return out;
}

Technique parse_technique(const json& value, const std::string& label, const std::vector<Light>& lights) {
    Technique t = parse_technique(value, label);
    check_technique_lights(t, lights, label);
    return t;
}

void check_technique_lights(const Technique& t, const std::vector<Light>& lights, const std::string& label) {
    // `label` is "file: technique" or a file name, as in parse_technique.
    const char* separator = label.find(": ") != std::string::npos ? "." : ": ";
    if (t.lights.size() > lights.size())
        throw InputError(
            fmt::format("{}{}lights: {} entries, but the scenario has {} light{} (entry i overrides "
                        "lights[i])",
                        label, separator, t.lights.size(), lights.size(), lights.size() == 1 ? "" : "s"));
    if (t.filter.type != FilterType::pcss) return;
    for (const Light& l : lights) {
        if (is_soft_light(l)) continue;  // an area light, or a sun with an angular_diameter_deg
        // Name the preset when it, not the user's own keys, chose PCSS.
        std::string from_preset;
        for (const auto& p : presets())
            if (p.name == t.preset && p.technique.contains("filter") &&
                p.technique["filter"].value("type", "") == "pcss")
                from_preset = fmt::format(" (from preset \"{}\")", p.name);
        throw InputError(
            fmt::format("{}{}filter.type: \"pcss\"{} needs a light with a size; {} is {} (only rect, "
                        "disk and sphere lights have one, and directional lights with angular_diameter_deg > 0)",
                        label, separator, from_preset, l.origin, to_string(l.type)));
    }
}

json Technique::to_json() const {
    json j = {{"family", family}};
    family_of(*this).write(*this, j);
    j["precision"] = to_string(precision);
    if (blend != Blend::opaque) j["blend"] = to_string(blend, blend_cutoff);  // absent: what it was before
    if (alpha_mipmaps) j["alpha"] = {{"mipmaps", true}};
    if (!preset.empty()) j["preset"] = preset;
    return j;
}

json depth_map_keys_json(const Technique& t) {
    const Bias& bias = t.bias;
    const Filter& filter = t.filter;
    json j{{"resolution", t.resolution},
           {"depth_format", to_string(t.depth_format)},
           {"fit", to_string(t.fit)},
           {"shadow_distance", t.shadow_distance},
           {"cull", to_string(t.cull)},
           {"bias",
            {{"constant", bias.constant},
             {"slope", bias.slope},
             {"clamp", bias.clamp},
             {"world", bias.world},
             {"normal_offset", bias.normal_offset},
             {"shader_depth", bias.shader_depth},
             {"receiver_plane", bias.receiver_plane},
             {"normal_offset_m", bias.normal_offset_m},
             {"normal_factor", to_string(bias.normal_factor)},
             {"normal_perpendicular", bias.normal_perpendicular},
             {"world_depth_range", bias.world_depth_range},
             {"caster",
              {{"world", bias.caster.world},
               {"world_texels", bias.caster.world_texels},
               {"normal", bias.caster.normal},
               {"normal_texels", bias.caster.normal_texels},
               {"normal_factor", to_string(bias.caster.normal_factor)},
               {"depth", bias.caster.depth}}}}},
           {"reversed_z", t.reversed_z},
           {"filter",
            {{"type", to_string(filter.type)},
             {"size", filter.size},
             {"taps", filter.taps},
             {"radius_texels", filter.radius_texels},
             {"bilinear_taps", filter.bilinear_taps},
             {"max_radius_texels", filter.max_radius_texels}}}};
    if (t.cull == Cull::material) j["single_sided_cull"] = to_string(t.single_sided_cull);
    if (!t.lights.empty()) {
        json entries = json::array();
        for (const LightOverride& l : t.lights)
            entries.push_back(l.bias == BiasOverride{} ? json::object() : json{{"bias", bias_json(l.bias)}});
        j["lights"] = entries;
    }
    return j;
}

void apply_override(json& technique, const std::string& assignment) {
    auto eq = assignment.find('=');
    if (eq == std::string::npos || eq == 0)
        throw InputError(fmt::format("--set {}: expected key.path=value", assignment));
    std::string key = assignment.substr(0, eq), text = assignment.substr(eq + 1);
    json value;
    try {
        value = parse_json_strict(text, "--set " + key);
    } catch (const InputError&) {
        value = text;  // a bare word such as pcf or d24
    }
    json* node = &technique;
    std::size_t start = 0;
    for (;;) {
        auto dot = key.find('.', start);
        std::string part = key.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
        if (part.empty()) throw InputError(fmt::format("--set {}: empty key segment", assignment));
        if (!node->is_object()) throw InputError(fmt::format("--set {}: '{}' is not an object", assignment, part));
        if (dot == std::string::npos) {
            (*node)[part] = value;
            return;
        }
        node = &(*node)[part];
        if (node->is_null()) *node = json::object();
        start = dot + 1;
    }
}

}  // namespace penumbra::raster
