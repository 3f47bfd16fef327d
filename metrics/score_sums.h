// The sums a light's score is made of (metrics-internal): one per image row, then added in row
// order so the totals do not depend on how rows were shared between threads, and the score they
// make. The CPU scorer (classification.cpp) and the GPU one (gpu_classification.cpp) share both,
// so that their scores are the same arithmetic.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "metrics/classification.h"

namespace penumbra::metrics::detail {

struct RowSums {
    PixelCounts pixels;
    std::array<std::uint64_t, kErrorClasses.size()> counts{}, counts_visible{};
    double abs_sum = 0, sq_sum = 0, signed_sum = 0;
    double gap_sum = 0, gap_max = 0, acne_sum = 0, acne_max = 0;
    std::uint64_t acne_measured = 0;
    std::vector<float> gaps;  // peter-panning gaps, for their percentile
    // Soft lights: per oracle region (umbra, penumbra, lit) pixels and |error| sums.
    std::array<std::uint64_t, 3> region_pixels{};
    std::array<double, 3> region_abs{};
    double penumbra_excess = 0;
    std::uint64_t band_oracle = 0, band_raster = 0;  // pixels with V in the width band

    void add(const RowSums& r);
};

// Everything of `s` that the sums give: pixels, counts, error means, gap and acne depth, the soft
// light's regions. Not the evidence, the gaps' percentile or the perceptual error.
void fill_score(const RowSums& t, const ScoringOptions& opt, LightScore& s);

}  // namespace penumbra::metrics::detail
