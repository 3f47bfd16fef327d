// Engine units (issue #38, docs/units.md): each engine's shadow-bias parameters as that engine
// applies them, converted to and from penumbra's technique bias for one map of one light.
//
// Every bias, on whatever side it acts (receiver or caster, along L or along N, in metres, texels
// or normalised depth), is reduced to the *clearance* it gives a receiver on a plane at the
// reference angle θ between its normal N and the direction to the light L: how far, in metres
// along L, the receiver ends up in front of the surface the map stored. A receiver offset v gives
// (v·N)/cos θ; a caster offset u gives −(u·N)/cos θ; a hardware slope factor s gives
// s·texel·tan θ. That is what penumbra's peter-panning rule calls the bias reach (bias_m).
//
// The clearance is kept in two channels, one for each free parameter an engine has: `constant`
// (the terms that do not depend on the receiver's angle: offsets along L, depth offsets) and
// `angular` (normal offsets and slope terms, evaluated at θ). Converting A → B solves B's depth
// parameter from the constant channel and its normal (or slope) parameter from the angular
// channel, with B's fixed terms (hardware bias, kernel scale: its "assumptions") subtracted. So
// A → B → A is exact, and a conversion between engines whose angular factors differ (sin θ,
// 1 − cos θ, none) is exact at θ only.
#pragma once

#include <glm/vec3.hpp>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/scenario.h"
#include "raster/technique.h"

namespace penumbra::engines {

// The engines `penumbra units` converts between, in the order the docs list them (docs/units.md),
// "penumbra" (the technique's own bias keys) last.
const std::vector<std::string>& engine_names();

// Where a conversion is made: one map (or one cascade) of one light, at the reference receiver.
struct MapContext {
    double texel_m = 0;                    // world size of one map texel at the reference receiver
    double metres_per_depth = 0;           // metres along L per unit of the map's normalised [0, 1] depth there
    double depth_r = 0;                    // the map format's r (depth units) at the reference receiver's depth
    double angle_rad = 0;                  // θ: the reference receiver's normal to the direction to the light
    std::optional<int> cascade;            // the cascade, for a cascaded sun
    double depth_range_m = 0;              // orthographic: far − near of the map (its depth range)
    double split_near = 0, split_far = 0;  // cascade: the view depths it serves
};

// The clearance of a bias at the reference angle, metres along L (see the top of this file).
struct Clearance {
    double constant_m = 0;  // terms independent of the receiver's angle
    double angular_m = 0;   // normal offsets and slope terms, at θ
    double total() const { return constant_m + angular_m; }
};

// An engine's bias as its user types it: the engine name, its two free parameters and its
// assumptions (fixed terms and settings the conversion needs, e.g. Godot's filter quality), as a
// flat JSON object of key → value. For "penumbra" the keys are the technique's bias keys,
// dotted ("world", "caster.normal_texels", …).
struct EngineBias {
    std::string engine;
    nlohmann::json values = nlohmann::json::object();       // the free parameters
    nlohmann::json assumptions = nlohmann::json::object();  // the fixed terms and settings
};

// One key an engine takes.
struct KeyInfo {
    std::string name;
    std::string unit;
    bool assumption = false;  // a fixed term or setting, not solved by a conversion
    nlohmann::json default_value;
    std::string meaning;  // how the engine applies it, with the source it was read from
};
struct EngineInfo {
    std::string name;
    std::string source;  // engine version / files the formulas come from
    std::vector<KeyInfo> keys;
    bool unverified = false;  // some formula or default not confirmed from the engine's own source
};
// Throws InputError naming `option` and the known engines for an unknown name.
const EngineInfo& engine_info(std::string_view name, std::string_view option = "engine");

// `key=value` assignments (value JSON where it parses as JSON, else a string) over the engine's
// defaults: an unknown key, a value of the wrong type or a non-finite number is InputError naming
// `where` and the key. `assumptions_only` refuses the free parameters (--assume).
EngineBias parse_engine_bias(std::string_view engine, const std::vector<std::string>& assignments,
                             const std::string& where, bool assumptions_only = false);
// The engine's defaults (values and assumptions) with `assumptions` applied over them.
EngineBias engine_defaults(std::string_view engine, const nlohmann::json& assumptions = nlohmann::json::object());

// The clearance `b` gives at the context's reference receiver.
Clearance clearance(const EngineBias& b, const MapContext& c);
// The bias of `engine` that gives clearance `target`, with `assumptions` (over the engine's
// defaults) as its fixed terms. InputError where the engine cannot carry it: its angular factor
// is 0 at θ (Godot, Unity at θ = 0), or Unreal's slope bias, a multiple of its depth bias, with a
// zero depth bias. For "penumbra" the result is the technique's world bias (constant channel)
// and normal offset in metres (angular channel), no hardware bias.
EngineBias from_clearance(std::string_view engine, const Clearance& target, const MapContext& c,
                          const nlohmann::json& assumptions = nlohmann::json::object());

// The technique bias keys that reproduce `b` as its engine applies it (the contract keys of issue
// #38; hardware constant and slope set, 0 where the engine has none), flat and dotted. A
// "penumbra" bias is returned as given.
nlohmann::json penumbra_keys(const EngineBias& b, const MapContext& c);
// The same nested as a technique's "bias" object ("caster.world" under "caster").
nlohmann::json nested_bias(const nlohmann::json& flat);
// A technique's bias for one light as a "penumbra" EngineBias (every key the conversion reads).
EngineBias penumbra_bias(const raster::Bias& bias);

// Converts `from` to engine `to` at `c`: to "penumbra", the technique keys that reproduce it;
// otherwise from_clearance(to, clearance(from, c), c, to_assumptions).
EngineBias convert(const EngineBias& from, std::string_view to, const MapContext& c,
                   const nlohmann::json& to_assumptions = nlohmann::json::object());

// The reference receiver of a light: the scene's largest plane (triangles grouped by their plane,
// areas summed; a plane counts from either side), its normal turned towards the light, and its
// area-weighted centroid.
struct ReferenceReceiver {
    glm::dvec3 normal{0, 1, 0}, point{0.0};
    double area_m2 = 0;
    double angle_rad = 0;
    std::string source;  // "largest receiver plane" or "--angle-deg"
};
// InputError when the scene has no triangle or its largest plane is edge-on to the light (give
// an angle instead). `angle_deg` (in [0, 89]) replaces the plane's angle; the plane still gives
// the point. `edge_on_hint` ends the edge-on message: what the calling command lets the user do.
ReferenceReceiver reference_receiver(const Scenario& s, const Light& light, std::optional<double> angle_deg,
                                     std::string_view edge_on_hint = "give the reference angle with --angle-deg");

// The maps of light `light_index` of `s` under technique `t` (the depth map, or one per cascade),
// each as a context at `ref`: penumbra's own fit (raster/light_projection.h), no device. An area
// light counts as a point light at its centre, as the depth-map family draws it. InputError for a
// technique without a shadow map (shadow volumes, planar projection).
std::vector<MapContext> map_contexts(const Scenario& s, const raster::Technique& t, std::size_t light_index,
                                     const ReferenceReceiver& ref);

// Every value as JSON: the context of a map ({"cascade", "texel_m", …}).
nlohmann::json to_json(const MapContext& c);

}  // namespace penumbra::engines
