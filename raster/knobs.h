// A technique family's tune knobs as data (docs/tune.md, "Knobs"): each knob says how the command
// line names it, the technique key it moves, the range and unit tune searches it in, and how its
// value is read from and written into a technique. tune reads nothing else of a family's
// parameters, so a family's knobs live in its own file (the depth map's biases here, the moment
// families' in raster/filterable.cpp) and tune has no list of its own.
#pragma once

#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "raster/technique.h"

namespace penumbra::raster {

// How tune searches a knob.
enum class KnobScale {
    log,     // a number in [lower, upper], searched on a log scale, plus 0 ("off")
    on_off,  // a switch: both values are searched (the value is 0 or 1)
};
const char* to_string(KnobScale s);

// Where a knob's value lives, which decides how tune searches it.
enum class KnobScope {
    light,      // in a light's bias (Technique::bias and each light's override): each light its own
    technique,  // in the family's parameters: one value for every light
};

struct KnobDecl {
    std::string name;  // as --knobs spells it: "constant"
    std::string key;   // the technique key it moves: "bias.constant", "evsm.exponents"
    std::string unit;  // of the value tune searches: "r", "texel footprints"
    KnobScale scale = KnobScale::log;
    double lower = 0, upper = 0;  // log: the range searched, in `unit`
    // The knob caps the bias the others add instead of adding its own (the clamp): its 0 is
    // Vulkan's "unclamped", the most bias, and it cannot cure acne alone.
    bool caps = false;
    KnobScope scope = KnobScope::light;
    // Searched when --knobs is not given.
    bool by_default = false;

    // scope light: the value in `b`, in `unit` (`footprint_m`, the reference texel footprint in
    // metres, is the unit of a knob counted in footprints: the bias holds metres); `b` with the
    // value written; and a light's override given the value of `from` (null: the override's
    // value cleared, so the technique's own applies).
    std::function<double(const Bias& b, double footprint_m)> read_bias;
    std::function<void(Bias& b, double value, double footprint_m)> write_bias;
    std::function<void(BiasOverride& o, const Bias* from)> set_override;
    // scope technique: the value in `t`, and `t` with the value written (clamped to what the
    // family can draw).
    std::function<double(const Technique& t)> read;
    std::function<void(Technique& t, double value)> write;
    // Keys tune.json adds to this knob's entry for technique `t` (may be unset: none), e.g. how
    // a cascaded technique applies it per cascade.
    std::function<nlohmann::json(const Technique& t)> describe;
};

// The depth-map family's bias knobs, in this order: constant (the format's r), slope (Vulkan's
// factor), clamp (depth units), world (texel footprints), normal_offset (texels),
// receiver_plane (on/off); constant and slope by default. Every family that draws the depth
// map's biases declares these (depth_map, averaged_area, cascaded).
std::vector<KnobDecl> depth_map_bias_knobs();

}  // namespace penumbra::raster
