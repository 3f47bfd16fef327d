// The raster technique (docs/design.md, "Technique"): what a shadow-mapping implementation does,
// as a validated value. Named presets reproduce the seed systems of docs/design.md's "References".
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/scene.h"

namespace penumbra {
class JsonObject;
}

namespace penumbra::raster {

enum class Fit { scene_sphere, scene_bounds, camera_frustum };
enum class DepthFormat { d16, d24, d32 };
// material: each material's doubleSided decides (docs/raster.md, "Culling by material"): a
// double-sided one casts both faces, a single-sided one is culled on `single_sided_cull`'s side.
enum class Cull { none, back, front, material };
// How the shadow pass draws a BLEND material (docs/raster.md, "Blended materials"): as an opaque
// caster (three.js), not at all, or alpha-tested at blend_cutoff like a cut-out.
enum class Blend { opaque, none, cutout };
// vogel: `taps` taps on a Vogel (golden-angle) disk of `radius_texels`, rotated per pixel by
// interleaved gradient noise (Jimenez 2014): three.js r18x's PCFShadowMap (5 taps, radius 1).
enum class FilterType { none, hw2x2, pcf, poisson, pcss, vogel };
// Which depth the map stores (docs/raster.md, "Midpoint and second depth"): the nearest surface
// (first), Woo's midpoint between the nearest and the next surface behind it (Graphics Gems III,
// 1992), or the back faces alone (second: Wang & Molnar's second-depth shadow mapping, 1994).
enum class DepthLayer { first, midpoint, second };
// How the raster path spends float precision (docs/raster.md, "precision"): camera_relative
// subtracts the camera in double before anything is float; world_float32 keeps vertex and light
// positions and the light matrices in world-space float32, as most engines do, so that a scene
// far from the origin degrades as it does there (godot #72015).
enum class Precision { camera_relative, world_float32 };

// How a normal offset scales with the angle between the surface and the light (docs/raster.md,
// "Bias as engines apply it"): not at all, by 1 - max(0, N.L) (Godot, Unity URP), or by
// sin(theta) = sqrt(1 - (N.L)^2) (Filament, Babylon).
enum class NormalFactor { none, one_minus_ndotl, sin };

// Offsets applied to the casters while the map is drawn (Unity URP, Babylon): the stored surface
// moves away from the light.
struct CasterBias {
    double world = 0;                                 // along L, metres
    double world_texels = 0;                          // along L, texels of the map or cascade
    double normal = 0;                                // inward along the vertex normal (-N), metres
    double normal_texels = 0;                         // inward along the vertex normal, texels of the map or cascade
    NormalFactor normal_factor = NormalFactor::none;  // of `normal` and `normal_texels`
    double depth = 0;                                 // added to the drawn depth, [0, 1] of the map's depth range
    bool operator==(const CasterBias&) const = default;
};

struct Bias {
    double constant = 0;       // Vulkan depthBiasConstantFactor, units of the format's r
    double slope = 0;          // Vulkan depthBiasSlopeFactor
    double clamp = 0;          // Vulkan depthBiasClamp, depth units (0 = unclamped)
    double world = 0;          // receiver moved towards the light, metres
    double normal_offset = 0;  // receiver moved along its normal, shadow-map texel footprints
    double shader_depth = 0;   // subtracted from the receiver depth in the shader, depth units
    bool receiver_plane = false;
    double normal_offset_m = 0;  // receiver moved along its normal, metres (added to normal_offset's)
    NormalFactor normal_factor = NormalFactor::none;  // of both receiver normal offsets
    bool normal_perpendicular = false;                // the receiver's normal offset loses its component along L
    double world_depth_range = 0;  // receiver moved towards the light, fraction of the map's depth range
    CasterBias caster;
};

// The caster keys one light gives over the technique's `bias.caster`.
struct CasterBiasOverride {
    std::optional<double> world, world_texels, normal, normal_texels, depth;
    std::optional<NormalFactor> normal_factor;
    bool operator==(const CasterBiasOverride&) const = default;
};

// The bias keys one light gives over the technique's `bias` (engines set bias per light).
struct BiasOverride {
    std::optional<double> constant, slope, clamp, world, normal_offset, shader_depth;
    std::optional<bool> receiver_plane;
    std::optional<double> normal_offset_m, world_depth_range;
    std::optional<NormalFactor> normal_factor;
    std::optional<bool> normal_perpendicular;
    CasterBiasOverride caster;
    bool operator==(const BiasOverride&) const = default;
};

// `lights[i]` of a technique: what light i of the scenario does differently.
struct LightOverride {
    BiasOverride bias;
    bool operator==(const LightOverride&) const = default;
};

struct Filter {
    FilterType type = FilterType::none;
    int size = 3;                // pcf: taps per side
    int taps = 16;               // poisson, vogel: number of taps
    double radius_texels = 1.5;  // poisson, vogel: disk radius
    bool bilinear_taps = false;  // pcf, poisson, vogel: each tap a 2x2 bilinear compare (reference 000)
    // pcss (Fernando 2005): `taps` Poisson taps for the blocker search and again for the
    // filter, neither wider than this many texels.
    double max_radius_texels = 32;
};

// The parameters a family keeps of its own (cascades, moments, shadow volumes, planar projection,
// or a family registered from outside: technique_family.h): its entry's `parse` makes them, its
// `write` and its renderer read them back with Technique::parameters<P>().
struct FamilyParameters {
    virtual ~FamilyParameters() = default;
};

// The family a technique names when it has no "family" key and no area_samples > 0.
inline constexpr const char* kDefaultFamily = "depth_map";

struct Technique {
    std::string preset;  // empty when none
    // The technique family that draws it (docs/raster.md, "Adding a technique family"): a name of
    // technique_families(). Its entry parsed the keys below and writes them back.
    std::string family = kDefaultFamily;
    int resolution = 2048;
    DepthFormat depth_format = DepthFormat::d32;
    Fit fit = Fit::scene_bounds;
    double shadow_distance = 0;  // camera_frustum: metres of view depth the map covers (0: all)
    Cull cull = Cull::back;
    // With cull material: the side culled on single-sided materials (back: Babylon, PlayCanvas,
    // Godot; front: three.js, whose shadowSide casts a FrontSide material's back faces).
    Cull single_sided_cull = Cull::back;
    Blend blend = Blend::opaque;
    double blend_cutoff = 0.5;  // Blend::cutout's alpha threshold
    // alpha.mipmaps: the shadow pass's alpha test samples the mip level its footprint selects, as
    // an engine's mipmapped textures do (the truth keeps level 0: minified cut-outs lose coverage).
    bool alpha_mipmaps = false;
    // The default bias is what a careful engine ships, not none (46-49% acne on every real model
    // tried): Filament's polygon offset, LightManager::ShadowOptions polygonOffsetConstant 0.5
    // and polygonOffsetSlope 2.0 (../shared/reference/engines.md, section 6). The `no-bias`
    // preset keeps the bias-free setup.
    Bias bias = [] {
        Bias b;
        b.constant = 0.5;
        b.slope = 2.0;
        return b;
    }();
    Filter filter;
    // The depth_map family's `depth_layer` (first in every other family). `second` draws with
    // cull front: parse sets `cull` so.
    DepthLayer depth_layer = DepthLayer::first;
    // Area lights: 0 renders one map from the light's centre (filtered by `filter`, e.g. pcss);
    // N > 0 renders N maps from points spread over the light and averages their (filtered)
    // verdicts: "averaged hard shadows" (reference 001), the raster path's own slow reference.
    // Read and written by the averaged_area family only (0 in every other family).
    int area_samples = 0;
    Precision precision = Precision::camera_relative;
    // Depth-map families: the map stores 1 - z, cleared to 0 and compared greater-or-equal, with
    // the hardware bias's sign flipped (bevy's reverse-Z Depth32Float). Lookups report depth
    // converted back, so the metrics read the forward convention either way.
    bool reversed_z = false;
    // Per-light overrides, indexed as the scenario's lights (may be shorter than them): their
    // keys win over `bias` for that light.
    std::vector<LightOverride> lights;
    // The family's own parameters, made by its entry's `parse` (null for a family whose keys are
    // all fields above). Read them through parameters<P>().
    std::shared_ptr<const FamilyParameters> family_parameters;

    // The family's parameters as its type P, or null when the technique keeps none of that type:
    // the one way a family (or its tests) reads its own keys back.
    template <class P>
    const P* parameters() const {
        return dynamic_cast<const P*>(family_parameters.get());
    }

    // The bias light `light` (the scenario's index) is drawn with: `bias` under its overrides.
    Bias bias_for(std::size_t light) const;
    // This technique as light `light` sees it: bias_for(light) as `bias`, no overrides.
    Technique for_light(std::size_t light) const;

    nlohmann::json to_json() const;  // every key, resolved (`lights` only when it has entries)
};

struct Preset {
    std::string name;
    std::string description;
    nlohmann::json technique;
};
const std::vector<Preset>& presets();

// Validates a technique object; `label` names its source ("scene.json: technique").
// A "preset" key supplies defaults for the keys the object leaves out. The "family" key picks
// the family (technique_families()) that parses the other keys; without it, area_samples > 0
// means averaged_area (as before the key existed) and anything else depth_map.
Technique parse_technique(const nlohmann::json& value, const std::string& label);

// Refuses a technique that some light cannot be drawn with (InputError, exit 2): more `lights`
// entries than the scenario has lights, or PCSS without a light size. PCSS sizes
// its penumbra by the light's size: spot and point lights and a punctual sun have none, so it
// would shrink to a one-texel filter and silently draw a hard shadow (docs/raster.md,
// "Technique"); a sun's size is its angular_diameter_deg. `label` names the technique as for
// parse_technique; lights are named by their origin ("lights[0]").
void check_technique_lights(const Technique& technique, const std::vector<Light>& lights, const std::string& label);

// parse_technique, then check_technique_lights: where the technique meets the scenario's
// lights, before any work.
Technique parse_technique(const nlohmann::json& value, const std::string& label, const std::vector<Light>& lights);

// The keys of every family that draws depth maps (resolution, depth_format, fit,
// shadow_distance, cull, bias, lights, filter; not area_samples): read from `o` into `t`, in
// that order, checked. A family's `parse` calls it for the keys it shares with the depth map.
void parse_depth_map_keys(JsonObject& o, Technique& t);
// The same keys of `t`, every one resolved (`lights` only when it has entries).
nlohmann::json depth_map_keys_json(const Technique& t);

// What `t` changes of its preset (empty without one): each key, dotted ("bias.constant"), whose
// resolved value differs from the preset's alone, as {"preset": value or null, "technique":
// value or null}. The rule is design.md's (the object's keys, then --preset's defaults, then
// each --set; later sources win): this says what the run kept from the sources that are not the
// preset, printed by the commands and written to report.json.
nlohmann::json preset_differences(const Technique& t);

// Applies `--set key.path=value` overrides: value is parsed as JSON when it is JSON
// (numbers, true/false, quoted strings), else taken as a string.
void apply_override(nlohmann::json& technique, const std::string& assignment);

// The format's minimum resolvable difference r (depth units); 0 for float, where r depends on
// the depth (Vulkan's depth-bias definition).
double depth_resolution(DepthFormat f);

// How far, in shadow-map texels, the filter reaches from the lookup point (at least one
// texel): where a wrong verdict within that distance of a true boundary is aliasing.
double filter_reach_texels(const Filter& f);

const char* to_string(Fit f);
const char* to_string(DepthFormat f);
const char* to_string(Cull c);
std::string to_string(Blend b, double cutoff);
const char* to_string(FilterType f);
const char* to_string(DepthLayer d);
const char* to_string(Precision p);
const char* to_string(NormalFactor f);

}  // namespace penumbra::raster
