// What tune reports: the recommendation re-validated (before and after, on the scenarios it was
// tuned on and on hold-out scenarios), the bias in the units each API takes, and tune.json.
#pragma once

#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "pipeline/validate.h"
#include "tune/tune.h"

namespace penumbra::tune {

// A depth bias in the units people type, for one light (docs/tune.md, "Units"). The constant
// factor is a depth offset D = constant x r; r is the format's (unorm: 2^-n) or, for float
// depth, 2^(e - 23) with e the exponent of the depth (taken at the receivers' median depth).
struct ApiBias {
    std::size_t scenario = 0, light = 0;
    double median_depth = 0;                                       // the receivers' depth in the map
    double depth_to_m = 0;                                         // metres along the light ray per depth unit there
    double footprint_m = 0;                                        // median texel footprint at the receivers
    double depth_offset = 0;                                       // D, depth units
    double vk_constant = 0, vk_slope = 0, vk_clamp = 0;            // the chosen format
    long long d3d12_depth_bias_d24 = 0, d3d12_depth_bias_d32 = 0;  // D3D12 DepthBias (integer)
    double d3d12_slope = 0, d3d12_clamp = 0;                       // SlopeScaledDepthBias, DepthBiasClamp
    double gl_factor = 0, gl_units = 0;                            // glPolygonOffset(factor, units), chosen format
    double constant_m = 0, world_m = 0, normal_offset_texels = 0, normal_offset_m = 0;
    // `tune --units ENGINE`: the bias in that engine's parameters with the assumptions they hold
    // under (docs/units.md); null without --units.
    nlohmann::json engine;
};

// The re-validation of one technique on one scenario (full validate: lookups and pictures).
struct Revalidation {
    const Scenario* scenario = nullptr;
    ValidateResult before, after;  // the starting technique, the recommendation
};

// Validates `before` and `after` on each scenario (oracle from the cache, one warm session each).
std::vector<Revalidation> revalidate(std::span<const Scenario> scenarios, const raster::Technique& before,
                                     const raster::Technique& after, const ValidateOptions& options,
                                     const raster::VulkanContext& ctx);
// The same on the scenes the search used: their oracle and warm session, not made again.
std::vector<Revalidation> revalidate(Evaluator& ev, const raster::Technique& before, const raster::Technique& after,
                                     const ValidateOptions& options);

// The lights (scenario light index) on which `after` re-validated worse than `before` on some
// scenario: more visible acne + peter-panning, or a larger mean perceptual error; with why,
// naming the scenario by `files` (docs/tune.md, "Never worse than the start").
std::vector<std::pair<std::size_t, std::string>> worse_lights(std::span<const Revalidation> rs,
                                                              std::span<const std::string> files);

// Re-validates r.recommended against `start` on the evaluator's scenes, keeping the start for
// each light that came out worse (worse_lights, keep_start), then validating again: what tune
// recommends is never worse than the start on any light. `files` name the scenarios.
std::vector<Revalidation> revalidate_never_worse(Evaluator& ev, const raster::Technique& start, TuneResult& r,
                                                 const TuneOptions& options, std::span<const std::string> files);

// The bias of `r.after` in API units, per light (the lookups of its re-validation give the depths).
std::vector<ApiBias> api_units(std::span<const Revalidation> revalidations);

struct TuneReport {
    std::vector<std::string> scenario_files, holdout_files;
    raster::Technique start;
    TuneOptions options;
    TuneResult result;
    std::vector<Revalidation> tuned, holdout;
    std::vector<ApiBias> units;
    double seconds = 0;
};

nlohmann::json to_json(const Setting& s, const KnobSet& knobs);
nlohmann::json tune_json(const TuneReport& r);
// One row per evaluation: the setting, worst acne, the objective, on_front, chosen.
std::string pareto_csv(const TuneReport& r);

}  // namespace penumbra::tune
