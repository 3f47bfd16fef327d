// The filterable (moment) families of docs/raster.md, "Filterable shadow maps": vsm, esm, evsm2
// and evsm4. Each draws the depth-map family's map and filters moments of its depths instead of
// comparing them; this header is what the depth-map renderer and the tests read of them.
#pragma once

#include <algorithm>
#include <cmath>

#include "raster/technique.h"

namespace penumbra::raster {

enum class MomentKind { vsm, esm, evsm2, evsm4 };
const char* to_string(MomentKind k);

// A moment family's own keys (Technique::family_parameters).
struct MomentParameters final : FamilyParameters {
    MomentKind kind = MomentKind::vsm;
    int blur = 0;                  // separable Gaussian radius in texels (sigma = radius / 2), 0 = none
    double min_variance = 1e-6;    // vsm, evsm: the variance floor, squared depth units of the map
    double light_bleed = 0.15;     // vsm, evsm: linstep(light_bleed, 1, p) on Chebyshev's bound
    double exponent = 80;          // esm: c of exp(c d); evsm: the positive exponent
    double negative_exponent = 5;  // evsm4: the negative warp's exponent (a magnitude)
};

// The family's parameters when `t` is drawn by a moment family, else null.
const MomentParameters* moment_parameters(const Technique& t);

// Largest exponents the float32 moments hold: exp(c) for esm (exp(88.7) is FLT_MAX), exp(2c)
// for evsm's second moment over depths warped to [-1, 1] (Filament's "42 fp32").
inline constexpr double kMaxEsmExponent = 88;
inline constexpr double kMaxEvsmExponent = 42;
// evsm's default variance floor, squared depth units: TheRealMJP/Shadows' VSMBias 0.01 (a
// deviation of 5e-5 depth units).
inline constexpr double kEvsmMinVariance = 2.5e-9;

// The math of shaders/lookup.comp's moment filters, on the CPU, for tests.
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

}  // namespace penumbra::raster
