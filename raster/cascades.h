// Cascaded shadow maps (docs/raster.md, "Cascaded shadow maps"): the technique keys of the
// cascaded family and the placement of the splits along the camera's view depth, as pure
// functions. The fit of each cascade lives with the other fits (light_projection.h).
#pragma once

#include <optional>
#include <string_view>
#include <vector>

#include "raster/technique.h"

namespace penumbra::raster {

enum class CascadeSplit { practical, uniform, log, geometric, fractions };
enum class CascadeFit { sphere, bounds };
const char* to_string(CascadeSplit s);
const char* to_string(CascadeFit f);

inline constexpr int kMaxCascades = 8;

// The "cascades" object of a technique whose family is "cascaded" (Technique::family_parameters).
struct Cascades final : FamilyParameters {
    int count = 4;
    CascadeSplit split = CascadeSplit::practical;
    double lambda = 0.5;                  // practical: weight of the logarithmic split
    std::optional<double> first_far;      // geometric: far bound of the first cascade, metres
    std::vector<double> fractions;        // fractions: far bounds as fractions of max_distance
    std::optional<double> max_distance;   // metres of view depth; unset: the camera's zfar
    double overlap = 0;                   // fraction of a cascade blended with the next
    CascadeFit fit = CascadeFit::sphere;  // per-slice bounding sphere, or tight light-space bounds
    bool stabilize = true;                // snap the light-space origin to whole texels
    bool sdsm = false;                    // splits between the visible samples' least and greatest depth
    // Engines' per-cascade bias: bias.world and bias.constant are the first cascade's, and each
    // other cascade's is scaled by its texel over the first's (the constant also by the first's
    // depth range over its own, so that its metres grow with the texel). slope and
    // normal_offset scale with each cascade's texel either way.
    bool texel_scaled_bias = false;
};

// Far bound of cascade i of `count` between view depths `near` and `far` (i = 1 … count).
double uniform_split(double near, double far, int i, int count);
// n (f/n)^(i/c): seed 001's ratio form, r = (f/n)^(1/c) per cascade.
double log_split(double near, double far, int i, int count);
// Zhang et al. 2006: lambda · log + (1 − lambda) · uniform.
double practical_split(double near, double far, int i, int count, double lambda);
// bevy: first_far · r^(i−1) with r = (far / first_far)^(1/(count−1)), ending at far.
double geometric_split(double first_far, double far, int i, int count);

// The far bounds (view depth, metres) of every cascade, increasing, the last the range's end.
// `near`: the camera's znear; `far`: max_distance or the camera's zfar.
std::vector<double> cascade_far_bounds(const Cascades& c, double near, double far);

// SDSM (Lauritzen, Salvi and Lefohn, "Sample Distribution Shadow Maps", I3D 2011): the far
// bounds of the split scheme applied to the visible samples' view depths [lo, hi] instead of
// [near, far]. [lo, hi] is first clamped to [near, far]. uniform, log and practical are their
// closed forms on [lo, hi]; fractions are fractions of that range (lo + f (hi - lo)); geometric's
// first_far keeps its place as a fraction of [near, far], carried to [lo, hi].
std::vector<double> sdsm_far_bounds(const Cascades& c, double near, double far, double lo, double hi);

// How technique `t`'s bias key `key` ("bias.world", …) applies across the cascades of a sun: "" when
// `t` is not cascaded; "texel_scaled" (scaled by each cascade's texel: slope and normal_offset
// always, world and constant with texel_scaled_bias), or "same" in every cascade.
const char* cascade_bias_scaling(const Technique& t, std::string_view key);

// The cascades of technique `t`, or null when its family is not "cascaded".
const Cascades* cascades_of(const Technique& t);

}  // namespace penumbra::raster
