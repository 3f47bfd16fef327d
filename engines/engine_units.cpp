#include "engines/engine_units.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include "common/errors.h"
#include "raster/light_projection.h"
#include "raster/technique_family.h"

namespace penumbra::engines {

namespace {

using nlohmann::json;
constexpr double kPi = 3.14159265358979323846;
constexpr double kSqrt2 = 1.41421356237309504880;

// The engines' tables (docs/units.md has the same, with every source). Keys keep the engine's own
// spelling, so that a user can paste them.
std::vector<EngineInfo> make_engines() {
    std::vector<EngineInfo> e;
    e.push_back(
        {"bevy",
         "bevyengine/bevy v0.19.1: crates/bevy_light/src/directional_light.rs (defaults), "
         "crates/bevy_pbr/src/render/light.rs extract_lights (normal bias x sqrt(2)), "
         "crates/bevy_pbr/src/render/shadows.wgsl (receiver offsets)",
         {{"shadow_depth_bias", "m", false, 0.02,
           "receiver moved towards the light by this many metres (shadows.wgsl: depth_offset = "
           "shadow_depth_bias * direction_to_light)"},
          {"shadow_normal_bias", "texels", false, 1.8,
           "receiver moved along its normal by value * sqrt(2) * the cascade's texel, no N.L factor (light.rs: "
           "\"worst-case diagonal offset\"; shadows.wgsl: normal_offset = shadow_normal_bias * texel_size * normal)"}},
         false});
    e.push_back(
        {"godot",
         "godotengine/godot 4.x (Forward+): servers/rendering/renderer_rd/storage_rd/light_storage.cpp "
         "(shadow_bias / 100 * bias_scale * soft_shadow_scale; normal bias * shadow_texel_size), "
         "renderer_scene_render_rd.cpp directional_soft_shadow_filter_set_quality (quality radius), "
         "scene_forward_clustered.glsl BIAS_FUNC",
         {{"shadow_bias", "1/100 of the split's depth range", false, 0.1,
           "receiver moved towards the light by shadow_bias / 100 * the split's depth range * shadow_blur * "
           "quality radius (directional lights)"},
          {"shadow_normal_bias", "texels", false, 2.0,
           "receiver moved by value * the split's texel along its normal minus the normal's component along L "
           "(BIAS_FUNC). The shader's factor (1 - max(0, dot(L, -N))) is 1 on every lit receiver: L is the "
           "direction to the light there"},
          {"shadow_blur", "factor", true, 1.0, "DirectionalLight3D.shadow_blur: scales the depth bias too"},
          {"soft_shadow_filter_quality", "hard|soft_very_low|soft_low|soft_medium|soft_high|soft_ultra", true,
           "soft_low",
           "rendering/lights_and_shadows/directional_shadow/soft_shadow_filter_quality: quality radius 1, 1.5, 2, "
           "2, 3, 4 (applied to the depth bias without a light size)"}},
         false});
    e.push_back(
        {"unity-urp",
         "Unity-Technologies/Graphics com.unity.render-pipelines.universal: Runtime/ShadowUtils.cs GetShadowBias "
         "and RenderShadowSlice, ShaderLibrary/Shadows.hlsl ApplyShadowBias, Runtime/Data/"
         "UniversalRenderPipelineAsset.cs (defaults)",
         {{"depth_bias", "texels", false, 1.0,
           "casters moved away from the light by value * the cascade's texel (x the soft-shadow kernel radius)"},
          {"normal_bias", "texels", false, 1.0,
           "casters moved inward along their normal by value * texel * (1 - saturate(N.L)) (x the kernel radius)"},
          {"soft_shadows", "bool", true, false, "soft shadows on: both biases x the kernel radius"},
          {"soft_shadow_quality", "low|medium|high", true, "medium", "kernel radius 1.5, 2.5, 3.5"},
          {"hardware_constant", "r of the map's format", true, 1.0,
           "CommandBuffer.SetGlobalDepthBias(1.0, 2.5) while casters are drawn (\"match HDRP defaults\")"},
          {"hardware_slope", "slope factor", true, 2.5, "the same call's slope bias"}},
         false});
    e.push_back(
        {"unreal",
         "Unreal Engine 5 CSM (no Epic source read: a third-party copy of Renderer/Private/ShadowRendering.cpp "
         "FProjectedShadowInfo::UpdateShaderDepthBias; the shadow-depth vertex shader's slope term and the "
         "defaults are unverified)",
         {{"ShadowBias", "factor", false, 0.5,
           "casters moved away from the light by r.Shadow.CSMDepthBias * lerp(1 cm, ShadowBounds.W / "
           "ResolutionX, CascadeBiasDistribution) * ShadowBias (W / ResolutionX is half a texel)"},
          {"ShadowSlopeBias", "factor", false, 0.5,
           "adds that depth offset * r.Shadow.CSMSlopeScaleDepthBias * ShadowSlopeBias * min(tan(theta), "
           "r.Shadow.ShadowMaxSlopeScaleDepthBias): a multiple of the depth bias"},
          {"CSMDepthBias", "cvar", true, 10.0, "r.Shadow.CSMDepthBias (UE4 copies show 20; unverified)"},
          {"CSMSlopeScaleDepthBias", "cvar", true, 3.0, "r.Shadow.CSMSlopeScaleDepthBias (unverified)"},
          {"CascadeBiasDistribution", "fraction", true, 1.0, "UDirectionalLightComponent (unverified)"},
          {"ShadowMaxSlopeScaleDepthBias", "cvar", true, 1.0, "r.Shadow.ShadowMaxSlopeScaleDepthBias (unverified)"}},
         true});
    e.push_back(
        {"three",
         "mrdoob/three.js r17x-r18x: src/renderers/shaders/ShaderChunk/shadowmap_pars_fragment.glsl.js "
         "(shadowCoord.z += bias), shadowmap_vertex.glsl.js (worldPosition + normal * normalBias), "
         "src/lights/LightShadow.js (defaults)",
         {{"bias", "normalised depth", false, 0.0,
           "added to the receiver's [0, 1] depth of the shadow camera's near..far before the <= compare: "
           "a negative bias moves it towards the light"},
          {"normalBias", "m", false, 0.0, "receiver moved along its normal by this many metres, no N.L factor"}},
         false});
    e.push_back(
        {"filament",
         "google/filament: filament/src/ShadowMap.cpp (constantBias translates the light camera), "
         "filament/src/ShadowMapManager.cpp (0.5 * normalBias * texelSizeAtOneMeterWs), shaders "
         "computeLightSpacePosition (p += n * sin(theta) * b), filament/include/filament/LightManager.h (defaults)",
         {{"constantBias", "m", false, 0.001, "casters drawn this many metres farther from the light"},
          {"normalBias", "half texels", false, 1.0,
           "receiver moved along its normal by 0.5 * value * texel * sin(theta)"},
          {"polygonOffsetConstant", "r of the map's format", true, 0.5,
           "glPolygonOffset units while casters are drawn"},
          {"polygonOffsetSlope", "slope factor", true, 2.0, "glPolygonOffset factor while casters are drawn"}},
         false});
    e.push_back({"babylon",
                 "BabylonJS/Babylon.js (@babylonjs/core 8.49): Shaders/ShadersInclude/shadowMapVertexMetric.fx "
                 "(bias added to the caster's depth; BIASFACTOR: half a depth unit on the depth-texture path), "
                 "shadowMapVertexNormalBias.fx (worldPos -= N * normalBias * sin), Lights/Shadows/shadowGenerator.ts "
                 "(defaults; SM_DEPTHTEXTURE = PCF or PCSS)",
                 {{"bias", "normalised depth", false, 0.00005,
                   "added to the caster's depth in the light's [0, 1] range (x 0.5 with a depth texture: PCF, "
                   "PCSS, CSM)"},
                  {"normalBias", "m", false, 0.0, "casters moved inward along their normal by value * sin(theta)"},
                  {"pcf", "bool", true, false,
                   "percentage-closer filtering (or PCSS) on: the depth-texture path (the CSM generator forces PCF)"}},
                 false});
    e.push_back(
        {"penumbra",
         "penumbra's technique bias keys (docs/raster.md; issue #38's contract)",
         {{"constant", "r of the map's format", false, 0.0, "hardware depth bias (Vulkan depthBiasConstantFactor)"},
          {"slope", "slope factor", false, 0.0, "hardware slope bias (Vulkan depthBiasSlopeFactor)"},
          {"clamp", "depth units", false, 0.0, "hardware bias clamp (not modelled by the conversion)"},
          {"world", "m", false, 0.0, "receiver towards the light"},
          {"normal_offset", "texels", false, 0.0, "receiver along its normal"},
          {"normal_offset_m", "m", false, 0.0, "receiver along its normal"},
          {"normal_factor", "none|one_minus_ndotl|sin", false, "none", "factor on the receiver's normal offsets"},
          {"normal_perpendicular", "bool", false, false, "the receiver's normal offset loses its component along L"},
          {"world_depth_range", "fraction of the depth range", false, 0.0, "receiver towards the light"},
          {"shader_depth", "depth units", false, 0.0, "subtracted from the receiver's map depth"},
          {"receiver_plane", "bool", false, false, "receiver-plane depth bias (not modelled by the conversion)"},
          {"caster.world", "m", false, 0.0, "casters away from the light"},
          {"caster.world_texels", "texels", false, 0.0, "casters away from the light"},
          {"caster.normal", "m", false, 0.0, "casters inward along their normal"},
          {"caster.normal_texels", "texels", false, 0.0, "casters inward along their normal"},
          {"caster.normal_factor", "none|one_minus_ndotl|sin", false, "none", "factor on the caster normal offsets"},
          {"caster.depth", "depth units", false, 0.0, "added to the casters' depth"}},
         false});
    return e;
}

const std::vector<EngineInfo>& engines() {
    static const std::vector<EngineInfo> kEngines = make_engines();
    return kEngines;
}

const std::vector<std::string> kNormalFactors = {"none", "one_minus_ndotl", "sin"};
const std::vector<std::string> kGodotQualities = {"hard",        "soft_very_low", "soft_low",
                                                  "soft_medium", "soft_high",     "soft_ultra"};
const std::vector<std::string> kUnityQualities = {"low", "medium", "high"};

// The choices a string key takes.
const std::vector<std::string>* choices(const std::string& key) {
    if (key == "normal_factor" || key == "caster.normal_factor") return &kNormalFactors;
    if (key == "soft_shadow_filter_quality") return &kGodotQualities;
    if (key == "soft_shadow_quality") return &kUnityQualities;
    return nullptr;
}

std::string join(const std::vector<std::string>& v) {
    std::string s;
    for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
    return s;
}

const KeyInfo* find_key(const EngineInfo& e, std::string_view key) {
    for (const auto& k : e.keys)
        if (k.name == key) return &k;
    return nullptr;
}

double num(const json& j, const char* key) {
    const auto it = j.find(key);
    return it == j.end() || !it->is_number() ? 0.0 : it->get<double>();
}
bool flag(const json& j, const char* key) {
    const auto it = j.find(key);
    return it != j.end() && it->is_boolean() && it->get<bool>();
}
std::string text(const json& j, const char* key, const char* fallback) {
    const auto it = j.find(key);
    return it == j.end() || !it->is_string() ? fallback : it->get<std::string>();
}

// The factor "none" | "one_minus_ndotl" | "sin" multiplies a normal offset by, at cos θ = c.
double normal_factor(const std::string& f, double c) {
    if (f == "one_minus_ndotl") return 1.0 - c;
    if (f == "sin") return std::sqrt(std::max(0.0, 1.0 - c * c));
    return 1.0;
}

double godot_quality_radius(const std::string& q) {
    static const std::map<std::string, double> kRadius = {{"hard", 1.0},      {"soft_very_low", 1.5},
                                                          {"soft_low", 2.0},  {"soft_medium", 2.0},
                                                          {"soft_high", 3.0}, {"soft_ultra", 4.0}};
    const auto it = kRadius.find(q);
    return it == kRadius.end() ? 2.0 : it->second;
}

// URP's GetShadowBias: both biases x the soft-shadow kernel radius when soft shadows are on.
double unity_kernel(const json& a) {
    if (!flag(a, "soft_shadows")) return 1.0;
    const std::string q = text(a, "soft_shadow_quality", "medium");
    return q == "low" ? 1.5 : q == "high" ? 3.5 : 2.5;
}

// Unreal: the CSM depth offset per unit of ShadowBias, metres (ShadowBounds.W / ResolutionX is half
// a texel; the cvar alone is in centimetres, Unreal's world unit).
double unreal_depth_unit(const json& a, const MapContext& c) {
    return num(a, "CSMDepthBias") * std::lerp(0.01, 0.5 * c.texel_m, num(a, "CascadeBiasDistribution"));
}
double unreal_slope(const json& a, const MapContext& c) {
    return std::min(std::tan(c.angle_rad), num(a, "ShadowMaxSlopeScaleDepthBias"));
}

// What a normal-type parameter is multiplied by to give its clearance; 0 where it has no effect.
[[noreturn]] void cannot_carry(std::string_view engine, std::string_view key, const MapContext& c,
                               std::string_view why) {
    throw InputError(fmt::format("{} cannot carry this bias at the reference angle {:.3g} deg: its {} {}", engine,
                                 c.angle_rad * 180.0 / kPi, key, why));
}

double divide(double value, double per_unit, std::string_view engine, std::string_view key, const MapContext& c) {
    if (per_unit == 0.0) {
        if (value == 0.0) return 0.0;
        cannot_carry(engine, key, c, "has no effect there (give another --angle-deg)");
    }
    return value / per_unit;
}

json flatten(const json& j, const std::string& prefix = "") {
    json out = json::object();
    for (auto it = j.begin(); it != j.end(); ++it) {
        const std::string key = prefix.empty() ? it.key() : prefix + "." + it.key();
        if (it->is_object())
            out.update(flatten(*it, key));
        else
            out[key] = *it;
    }
    return out;
}

}  // namespace

const std::vector<std::string>& engine_names() {
    static const std::vector<std::string> kNames = [] {
        std::vector<std::string> n;
        for (const auto& e : engines()) n.push_back(e.name);
        return n;
    }();
    return kNames;
}

const EngineInfo& engine_info(std::string_view name, std::string_view option) {
    for (const auto& e : engines())
        if (e.name == name) return e;
    throw InputError(fmt::format("{}: no engine \"{}\" (engines: {})", option, name, join(engine_names())));
}

EngineBias engine_defaults(std::string_view engine, const nlohmann::json& assumptions) {
    const EngineInfo& e = engine_info(engine);
    EngineBias b;
    b.engine = e.name;
    for (const auto& k : e.keys) (k.assumption ? b.assumptions : b.values)[k.name] = k.default_value;
    for (auto it = assumptions.begin(); it != assumptions.end(); ++it) b.assumptions[it.key()] = *it;
    return b;
}

EngineBias parse_engine_bias(std::string_view engine, const std::vector<std::string>& assignments,
                             const std::string& where, bool assumptions_only) {
    const EngineInfo& e = engine_info(engine, where);
    EngineBias b = engine_defaults(engine);
    std::map<std::string, std::string> given;  // each key's assignment, by the key's own name
    for (const std::string& a : assignments) {
        const auto eq = a.find('=');
        if (eq == std::string::npos || eq == 0) throw InputError(fmt::format("{}: \"{}\" is not KEY=VALUE", where, a));
        std::string key = a.substr(0, eq);
        const std::string raw = a.substr(eq + 1);
        if (e.name == "penumbra" && key.rfind("bias.", 0) == 0) key = key.substr(5);
        const KeyInfo* k = find_key(e, key);
        std::vector<std::string> names;
        for (const auto& x : e.keys)
            if (!assumptions_only || x.assumption) names.push_back(x.name);
        if (!k || (assumptions_only && !k->assumption))
            throw InputError(fmt::format("{}: {} has no {}key \"{}\" (its keys: {})", where, e.name,
                                         assumptions_only ? "assumption " : "", key, join(names)));
        // A key given twice (or under both spellings) would silently take the last: which was meant
        // cannot be guessed.
        if (const auto [it, fresh] = given.emplace(k->name, a); !fresh)
            throw InputError(
                fmt::format("{}: {} \"{}\" is given twice (\"{}\" and \"{}\")", where, e.name, k->name, it->second, a));
        json value = json::parse(raw, nullptr, false);
        if (value.is_discarded()) value = raw;
        const auto bad = [&](std::string_view want) {
            return InputError(fmt::format("{}: {} {}={}: {}", where, e.name, key, raw, want));
        };
        if (k->default_value.is_number()) {
            if (!value.is_number() || !std::isfinite(value.get<double>())) throw bad("not a finite number");
            value = value.get<double>();
        } else if (k->default_value.is_boolean()) {
            if (value.is_number_integer() && (value == 0 || value == 1)) value = value == 1;
            if (!value.is_boolean()) throw bad("not true or false");
        } else {
            const auto* c = choices(key);
            if (!value.is_string() || (c && std::find(c->begin(), c->end(), value.get<std::string>()) == c->end()))
                throw bad(fmt::format("not one of {}", c ? join(*c) : std::string("its words")));
        }
        (k->assumption ? b.assumptions : b.values)[key] = value;
    }
    return b;
}

Clearance clearance(const EngineBias& b, const MapContext& c) {
    const json &v = b.values, &a = b.assumptions;
    const double cos_t = std::cos(c.angle_rad), sin_t = std::sin(c.angle_rad), tan_t = std::tan(c.angle_rad);
    Clearance out;
    if (b.engine == "bevy") {
        out.constant_m = num(v, "shadow_depth_bias");
        out.angular_m = num(v, "shadow_normal_bias") * kSqrt2 * c.texel_m / cos_t;
    } else if (b.engine == "godot") {
        const double scale = num(a, "shadow_blur") * godot_quality_radius(text(a, "soft_shadow_filter_quality", ""));
        out.constant_m = num(v, "shadow_bias") / 100.0 * c.depth_range_m * scale;
        // N minus its component along L: (N - cos θ L)·N = sin² θ.
        out.angular_m = num(v, "shadow_normal_bias") * c.texel_m * sin_t * sin_t / cos_t;
    } else if (b.engine == "unity-urp") {
        const double k = unity_kernel(a);
        out.constant_m =
            num(v, "depth_bias") * k * c.texel_m + num(a, "hardware_constant") * c.depth_r * c.metres_per_depth;
        out.angular_m = num(v, "normal_bias") * k * c.texel_m * (1.0 - cos_t) / cos_t +
                        num(a, "hardware_slope") * c.texel_m * tan_t;
    } else if (b.engine == "unreal") {
        const double depth_m = num(v, "ShadowBias") * unreal_depth_unit(a, c);
        out.constant_m = depth_m;
        out.angular_m = depth_m * num(a, "CSMSlopeScaleDepthBias") * num(v, "ShadowSlopeBias") * unreal_slope(a, c);
    } else if (b.engine == "three") {
        out.constant_m = -num(v, "bias") * c.metres_per_depth;
        out.angular_m = num(v, "normalBias") / cos_t;
    } else if (b.engine == "filament") {
        out.constant_m = num(v, "constantBias") + num(a, "polygonOffsetConstant") * c.depth_r * c.metres_per_depth;
        out.angular_m =
            0.5 * num(v, "normalBias") * c.texel_m * sin_t / cos_t + num(a, "polygonOffsetSlope") * c.texel_m * tan_t;
    } else if (b.engine == "babylon") {
        const double k = flag(a, "pcf") ? 0.5 : 1.0;
        out.constant_m = num(v, "bias") * k * c.metres_per_depth;
        out.angular_m = num(v, "normalBias") * sin_t / cos_t;
    } else if (b.engine == "penumbra") {
        out.constant_m = num(v, "world") + num(v, "world_depth_range") * c.depth_range_m +
                         num(v, "shader_depth") * c.metres_per_depth +
                         num(v, "constant") * c.depth_r * c.metres_per_depth + num(v, "caster.world") +
                         num(v, "caster.world_texels") * c.texel_m + num(v, "caster.depth") * c.metres_per_depth;
        const double receiver = (num(v, "normal_offset") * c.texel_m + num(v, "normal_offset_m")) *
                                normal_factor(text(v, "normal_factor", "none"), cos_t) *
                                (flag(v, "normal_perpendicular") ? sin_t * sin_t : 1.0);
        const double caster = (num(v, "caster.normal") + num(v, "caster.normal_texels") * c.texel_m) *
                              normal_factor(text(v, "caster.normal_factor", "none"), cos_t);
        out.angular_m = (receiver + caster) / cos_t + num(v, "slope") * c.texel_m * tan_t;
    } else {
        engine_info(b.engine);  // throws for an unknown engine
    }
    return out;
}

EngineBias from_clearance(std::string_view engine, const Clearance& target, const MapContext& c,
                          const nlohmann::json& assumptions) {
    EngineBias b = engine_defaults(engine, assumptions);
    const json& a = b.assumptions;
    json& v = b.values;
    // The fixed terms: the engine's clearance with both free parameters at 0.
    EngineBias zero = b;
    for (auto it = zero.values.begin(); it != zero.values.end(); ++it)
        if (it->is_number()) *it = 0.0;
    const Clearance fixed = clearance(zero, c);
    // What the free parameters must add; a difference within rounding of the terms is 0.
    auto rest = [](double target_m, double fixed_m) {
        const double d = target_m - fixed_m;
        return std::abs(d) <= 1e-12 * std::max(std::abs(target_m), std::abs(fixed_m)) ? 0.0 : d;
    };
    const double constant = rest(target.constant_m, fixed.constant_m),
                 angular = rest(target.angular_m, fixed.angular_m);
    // Each free parameter's clearance per unit, from the engine's own formula.
    auto per_unit = [&](const char* key) {
        EngineBias one = zero;
        one.values[key] = 1.0;
        const Clearance k = clearance(one, c);
        return std::pair{k.constant_m - fixed.constant_m, k.angular_m - fixed.angular_m};
    };
    const std::string name = b.engine;
    if (name == "bevy" || name == "godot" || name == "unity-urp" || name == "three" || name == "filament" ||
        name == "babylon") {
        static const std::map<std::string, std::pair<const char*, const char*>> kFree = {
            {"bevy", {"shadow_depth_bias", "shadow_normal_bias"}}, {"godot", {"shadow_bias", "shadow_normal_bias"}},
            {"unity-urp", {"depth_bias", "normal_bias"}},          {"three", {"bias", "normalBias"}},
            {"filament", {"constantBias", "normalBias"}},          {"babylon", {"bias", "normalBias"}}};
        const auto [depth_key, normal_key] = kFree.at(name);
        v[depth_key] = divide(constant, per_unit(depth_key).first, name, depth_key, c);
        v[normal_key] = divide(angular, per_unit(normal_key).second, name, normal_key, c);
    } else if (name == "unreal") {
        const double shadow_bias = divide(target.constant_m, unreal_depth_unit(a, c), name, "ShadowBias", c);
        v["ShadowBias"] = shadow_bias;
        const double per_slope = target.constant_m * num(a, "CSMSlopeScaleDepthBias") * unreal_slope(a, c);
        if (per_slope == 0.0 && target.angular_m != 0.0)
            cannot_carry(name, "ShadowSlopeBias", c,
                         "multiplies its ShadowBias, which is 0 here, or the slope term is 0 at this angle");
        v["ShadowSlopeBias"] = per_slope == 0.0 ? 0.0 : target.angular_m / per_slope;
    } else {  // penumbra: a world bias and a normal offset in metres, no hardware bias
        v["world"] = target.constant_m;
        v["normal_offset_m"] = target.angular_m * std::cos(c.angle_rad);
    }
    return b;
}

nlohmann::json penumbra_keys(const EngineBias& b, const MapContext& c) {
    if (b.engine == "penumbra") return b.values;
    const json &v = b.values, &a = b.assumptions;
    // Every key the contract has, 0 / none where the engine has nothing: a technique's default
    // hardware bias (0.5, 2.0) must not stay in.
    json k = {{"constant", 0.0},
              {"slope", 0.0},
              {"world", 0.0},
              {"normal_offset", 0.0},
              {"normal_offset_m", 0.0},
              {"normal_factor", "none"},
              {"normal_perpendicular", false},
              {"world_depth_range", 0.0},
              {"shader_depth", 0.0},
              {"caster.world", 0.0},
              {"caster.world_texels", 0.0},
              {"caster.normal", 0.0},
              {"caster.normal_texels", 0.0},
              {"caster.normal_factor", "none"},
              {"caster.depth", 0.0}};
    if (b.engine == "bevy") {
        k["world"] = num(v, "shadow_depth_bias");
        k["normal_offset"] = num(v, "shadow_normal_bias") * kSqrt2;
    } else if (b.engine == "godot") {
        k["world_depth_range"] = num(v, "shadow_bias") / 100.0 * num(a, "shadow_blur") *
                                 godot_quality_radius(text(a, "soft_shadow_filter_quality", ""));
        k["normal_offset"] = num(v, "shadow_normal_bias");
        k["normal_perpendicular"] = true;
    } else if (b.engine == "unity-urp") {
        const double kr = unity_kernel(a);
        k["caster.world_texels"] = num(v, "depth_bias") * kr;
        k["caster.normal_texels"] = num(v, "normal_bias") * kr;
        k["caster.normal_factor"] = "one_minus_ndotl";
        k["constant"] = num(a, "hardware_constant");
        k["slope"] = num(a, "hardware_slope");
    } else if (b.engine == "unreal") {
        // The depth offset moves the casters; its slope term has the hardware slope's tan θ shape up to
        // the cvar's clamp, so it becomes a slope factor that gives the same clearance at θ.
        const double depth_m = num(v, "ShadowBias") * unreal_depth_unit(a, c);
        k["caster.world"] = depth_m;
        const double tan_t = std::tan(c.angle_rad), slope = unreal_slope(a, c);
        const double shape = tan_t > 0 ? slope / tan_t : 1.0;
        k["slope"] = c.texel_m > 0
                         ? depth_m * num(a, "CSMSlopeScaleDepthBias") * num(v, "ShadowSlopeBias") * shape / c.texel_m
                         : 0.0;
    } else if (b.engine == "three") {
        k["shader_depth"] = -num(v, "bias");
        k["normal_offset_m"] = num(v, "normalBias");
    } else if (b.engine == "filament") {
        k["caster.world"] = num(v, "constantBias");
        k["normal_offset"] = 0.5 * num(v, "normalBias");
        k["normal_factor"] = "sin";
        k["constant"] = num(a, "polygonOffsetConstant");
        k["slope"] = num(a, "polygonOffsetSlope");
    } else if (b.engine == "babylon") {
        k["caster.depth"] = num(v, "bias") * (flag(a, "pcf") ? 0.5 : 1.0);
        k["caster.normal"] = num(v, "normalBias");
        k["caster.normal_factor"] = "sin";
    }
    return k;
}

nlohmann::json nested_bias(const nlohmann::json& flat) {
    json out = json::object();
    for (auto it = flat.begin(); it != flat.end(); ++it) {
        const std::string& key = it.key();
        const auto dot = key.find('.');
        if (dot == std::string::npos)
            out[key] = *it;
        else
            out[key.substr(0, dot)][key.substr(dot + 1)] = *it;
    }
    return out;
}

EngineBias penumbra_bias(const raster::Bias& bias) {
    raster::Technique t;
    t.bias = bias;
    EngineBias b = engine_defaults("penumbra");
    const json written = flatten(t.to_json().value("bias", json::object()));
    for (auto it = written.begin(); it != written.end(); ++it)
        if (b.values.contains(it.key())) b.values[it.key()] = *it;
    return b;
}

EngineBias convert(const EngineBias& from, std::string_view to, const MapContext& c,
                   const nlohmann::json& to_assumptions) {
    if (to == "penumbra") {
        EngineBias out = engine_defaults("penumbra");
        out.values = penumbra_keys(from, c);
        return out;
    }
    return from_clearance(to, clearance(from, c), c, to_assumptions);
}

ReferenceReceiver reference_receiver(const Scenario& s, const Light& light, std::optional<double> angle_deg,
                                     std::string_view edge_on_hint) {
    const Scene& scene = s.scene;
    if (scene.triangles.empty()) throw InputError(fmt::format("{}: the scene has no triangle", s.label));
    const double radius = std::max(scene.bounds.radius(), 1e-9);
    const bool directional = light.type == LightType::directional;
    // Planes keyed by their quantised normal (made to face +x, +y or +z first: a plane counts from
    // either side) and offset.
    struct Plane {
        double area = 0;
        glm::dvec3 normal{0.0}, weighted{0.0};
    };
    std::map<std::tuple<long long, long long, long long, long long>, Plane> planes;
    for (const auto& tri : scene.triangles) {
        const glm::dvec3 &p0 = scene.positions[tri.x], &p1 = scene.positions[tri.y], &p2 = scene.positions[tri.z];
        const glm::dvec3 cross = glm::cross(p1 - p0, p2 - p0);
        const double len = glm::length(cross);
        if (!(len > 0)) continue;
        glm::dvec3 n = cross / len;
        const double first = std::abs(n.x) > 1e-9 ? n.x : std::abs(n.y) > 1e-9 ? n.y : n.z;
        if (first < 0) n = -n;
        const double d = glm::dot(n, p0);
        auto q = [](double x, double step) { return static_cast<long long>(std::llround(x / step)); };
        Plane& p = planes[{q(n.x, 1e-3), q(n.y, 1e-3), q(n.z, 1e-3), q(d, 1e-3 * radius)}];
        p.area += 0.5 * len;
        p.normal = n;
        p.weighted += (p0 + p1 + p2) / 3.0 * (0.5 * len);
    }
    if (planes.empty()) throw InputError(fmt::format("{}: the scene has no triangle with an area", s.label));
    const Plane* best = nullptr;
    for (const auto& [key, p] : planes)
        if (!best || p.area > best->area) best = &p;
    ReferenceReceiver r;
    r.area_m2 = best->area;
    r.point = best->weighted / best->area;
    const glm::dvec3 to_light = directional ? -light.direction : glm::normalize(light.position - r.point);
    r.normal = glm::dot(best->normal, to_light) < 0 ? -best->normal : best->normal;
    if (angle_deg) {
        r.angle_rad = *angle_deg * kPi / 180.0;
        r.source = "--angle-deg";
        return r;
    }
    const double cos_t = std::clamp(glm::dot(r.normal, to_light), -1.0, 1.0);
    if (!(cos_t > std::cos(89.0 * kPi / 180.0)))
        throw InputError(fmt::format("{}: the scene's largest plane ({:.4g} m^2) is edge-on to {}; {}", s.label,
                                     r.area_m2, light.origin, edge_on_hint));
    r.angle_rad = std::acos(cos_t);
    r.source = "largest receiver plane";
    return r;
}

std::vector<MapContext> map_contexts(const Scenario& s, const raster::Technique& t, std::size_t light_index,
                                     const ReferenceReceiver& ref) {
    const raster::FamilyEntry& family = raster::family_of(t);
    if (family.hints(t).exact)
        throw InputError(
            fmt::format("technique family \"{}\" draws no shadow map: it has no bias to convert", t.family));
    if (light_index >= s.lights.size())
        throw InputError(
            fmt::format("--light: {} is not a light of {} (it has {})", light_index, s.label, s.lights.size()));
    Light light = s.lights[light_index];
    if (is_area_light(light.type)) light.type = LightType::point;  // drawn from its centre
    const glm::dvec3 origin = s.camera.eye;
    const raster::LightProjection lp =
        raster::fit_for_technique(light, s.scene, s.camera, s.width, s.height, t, origin);
    const auto views = raster::shadow_views(lp);
    const glm::dvec3 p_rel = ref.point - origin;
    std::vector<MapContext> out;
    for (std::size_t k = 0; k < views.size(); ++k) {
        const raster::ShadowView& v = views[k];
        if (v.kind == raster::ViewKind::cube_face) {
            // The face the reference point falls in (the largest component of the way to it).
            const glm::dvec3 d = ref.point - light.position;
            const int axis = std::abs(d.x) >= std::abs(d.y) && std::abs(d.x) >= std::abs(d.z) ? 0
                             : std::abs(d.y) >= std::abs(d.z)                                 ? 1
                                                                                              : 2;
            if (k != static_cast<std::size_t>(2 * axis + (d[axis] < 0 ? 1 : 0))) continue;
        }
        MapContext c;
        c.angle_rad = ref.angle_rad;
        const glm::dvec4 clip = v.view_proj * glm::dvec4(p_rel, 1.0);
        const double depth = clip.w != 0 ? clip.z / clip.w : clip.z;
        if (v.kind == raster::ViewKind::ortho || v.kind == raster::ViewKind::cascade) {
            c.texel_m = v.metres_per_texel;
            c.depth_range_m = v.kind == raster::ViewKind::cascade ? lp.cascade_depth_range[k] : v.far - v.near;
            c.metres_per_depth = c.depth_range_m;
        } else {
            // Depth along the view's axis; z_w = f (1 - n / z) / (f - n), so dz/dz_w = z² (f - n) / (f n).
            const double z = std::max(glm::dot(ref.point - light.position, v.axis), v.near);
            c.texel_m = v.metres_per_texel_per_metre * z;
            c.metres_per_depth = z * z * (v.far - v.near) / (v.far * v.near);
            c.depth_range_m = v.far - v.near;
        }
        if (v.kind == raster::ViewKind::cascade) {
            c.cascade = static_cast<int>(k);
            c.split_near = v.split_near;
            c.split_far = v.split_far;
        }
        const double r = raster::depth_resolution(t.depth_format);
        if (r > 0) {
            c.depth_r = r;
        } else {  // float: 2^(e - 23) at the reference receiver's depth (Vulkan's depth-bias r)
            int e = 0;
            std::frexp(std::max(depth, 1e-30), &e);
            c.depth_r = std::ldexp(1.0, e - 1 - 23);
        }
        out.push_back(c);
    }
    return out;
}

nlohmann::json to_json(const MapContext& c) {
    json j = {{"cascade", c.cascade ? json(*c.cascade) : json()},
              {"texel_m", c.texel_m},
              {"depth_range_m", c.depth_range_m},
              {"metres_per_depth", c.metres_per_depth},
              {"depth_r", c.depth_r},
              {"reference_angle_deg", c.angle_rad * 180.0 / kPi}};
    if (c.cascade) j["split"] = {c.split_near, c.split_far};
    return j;
}

}  // namespace penumbra::engines
