// The filterable (moment) families of docs/raster.md, "Filterable shadow maps": vsm, esm, evsm2,
// evsm4 and msm. Each draws the depth-map family's map and filters moments of its depths instead of
// comparing them; this header is what the depth-map renderer and the tests read of them.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/vec4.hpp>

#include "raster/technique.h"

namespace penumbra::raster {

// The order is the shaders' kMoment* (raster/filterable.glsl).
enum class MomentKind { vsm, esm, evsm2, evsm4, msm };
const char* to_string(MomentKind k);

// Moment shadow maps' reconstruction (Peters & Klein 2015): the sharpest lower bound on the
// shadow over every depth distribution with the four moments (Hamburger: on the real line), or
// over those supported on [0, 1] (Hausdorff).
enum class MsmVariant { hamburger, hausdorff };
const char* to_string(MsmVariant v);

// A moment family's own keys (Technique::family_parameters).
struct MomentParameters final : FamilyParameters {
    MomentKind kind = MomentKind::vsm;
    int blur = 0;                  // separable Gaussian radius in texels (sigma = radius / 2), 0 = none
    bool mipmaps = false;          // the moments' mip chain after the blur, sampled trilinearly
    double min_variance = 1e-6;    // vsm, evsm: the variance floor, squared depth units of the map
    double light_bleed = 0.15;     // vsm, evsm: linstep(light_bleed, 1, p) on Chebyshev's bound
    double exponent = 80;          // esm: c of exp(c d); evsm: the positive exponent
    double negative_exponent = 5;  // evsm4: the negative warp's exponent (a magnitude)
    MsmVariant variant = MsmVariant::hamburger;
    int storage_bits = 32;      // msm: 32 (float moments) or 16 (Peters & Klein's optimised quantisation)
    double moment_bias = 3e-5;  // msm: alpha of the lerp of the moments towards (0.5, 0.5, 0.5, 0.5)
};

// The lookup shader's LookupParams::moments for `p` (shaders/penumbra_shared.h).
glm::vec4 moment_uniform(const MomentParameters& p);

// The family's parameters when `t` is drawn by a moment family, else null.
const MomentParameters* moment_parameters(const Technique& t);

// Largest exponents the float32 moments hold: exp(c) for esm (exp(88.7) is FLT_MAX), exp(2c)
// for evsm's second moment over depths warped to [-1, 1] (Filament's "42 fp32").
inline constexpr double kMaxEsmExponent = 88;
inline constexpr double kMaxEvsmExponent = 42;
// evsm's default variance floor, squared depth units: TheRealMJP/Shadows' VSMBias 0.01 (a
// deviation of 5e-5 depth units).
inline constexpr double kEvsmMinVariance = 2.5e-9;
// msm's default moment bias (alpha) per storage: the quantisation error it must cover is far
// larger at 16 bits (Peters & Klein 2015, section 5; docs/raster.md has the choice).
inline constexpr double kMsmMomentBias32 = 3e-5;
inline constexpr double kMsmMomentBias16 = 6e-5;

// The math of raster/filterable_lookup.comp's moment filters, on the CPU, for tests.
// One-tailed Chebyshev upper bound on P(d >= t) from the first two moments (Donnelly & Lauritzen
// 2006), the variance floored at `min_variance`.
inline double chebyshev_upper_bound(double m1, double m2, double t, double min_variance) {
    if (t <= m1) return 1.0;
    const double variance = std::max(m2 - m1 * m1, min_variance);
    const double d = t - m1;
    return variance / (variance + d * d);
}
// Light-bleed reduction: linstep(amount, 1, p).
inline double reduce_light_bleeding(double p, double amount) {
    return amount >= 1 ? (p >= 1 ? 1.0 : 0.0) : std::clamp((p - amount) / (1.0 - amount), 0.0, 1.0);
}

// Moment shadow maps (Peters & Klein, "Moment Shadow Mapping", I3D 2015). b = (E[d], E[d^2],
// E[d^3], E[d^4]) of the filtered depths; returns the visibility (1 lit) of a receiver at depth
// `z`, after the moment bias `alpha`. Double precision; the shader's float version is
// msm_visibility in raster/filterable_lookup.comp.
double msm_visibility(const std::array<double, 4>& b, double z, double alpha, MsmVariant variant);
// The optimised quantisation of Peters & Klein 2015 (section 4.3): an affine map of the four
// moments of a depth in [0, 1] onto [0, 1]^4 that spreads them over the 16-bit range, its
// inverse, and the rounding to 16-bit UNORM in between.
std::array<double, 4> msm_optimise(const std::array<double, 4>& b);
std::array<double, 4> msm_unoptimise(const std::array<double, 4>& q);
std::array<double, 4> round_to_unorm16(const std::array<double, 4>& q);

}  // namespace penumbra::raster
