// A perceptual error in the spirit of NVIDIA FLIP (Andersson et al. 2020, "FLIP: A Difference
// Evaluator for Alternating Images"), restricted to what a visibility image is: luminance only.
// Kept from FLIP: the achromatic contrast-sensitivity filter (a Gaussian of variance
// b1/(2 pi^2) deg^2, b1 = 0.0047) before the colour difference; the difference in CIE L*
// raised to 0.7 (FLIP's q_c); edge and point features from first and second Gaussian
// derivatives (width 0.082 deg) and their difference raised to 0.5 (q_f); the combination
// e = e_c^(1 - e_f). Left out: the chromatic channels and Hunt adjustment (V has no colour),
// and FLIP's colour-difference compression above p_c (the achromatic range is normalised
// to [0, 1] instead). The displayed image is luminance Y = V.
#pragma once

#include <vector>

namespace penumbra::metrics {

// Per-pixel error in [0, 1] between two visibility images (row-major, width x height),
// viewed at `pixels_per_degree` (67: a 0.7 m distance from a 24" 4K screen, FLIP's default).
std::vector<float> perceptual_error(const std::vector<float>& reference, const std::vector<float>& test, int width,
                                    int height, double pixels_per_degree);

}  // namespace penumbra::metrics
