// Area lights as a shadow-mapping engine draws them: as point lights. With area_samples = 0
// the light becomes one point light at its centre carrying the light's size (its radius, or
// a rect's equal-area radius) for PCSS; with N > 0, N point lights spread over the light whose
// verdicts are averaged ("averaged hard shadows", reference 001). Punctual lights pass through.
#pragma once

#include <cstddef>
#include <vector>

#include "common/scene.h"
#include "raster/raster.h"
#include "raster/technique.h"

namespace penumbra::raster {

struct ExpandedLights {
    std::vector<Light> lights;       // what the renderer draws, all punctual
    std::vector<std::size_t> first;  // per scenario light: its first drawn light
    std::vector<std::size_t> count;  // ... and how many
};
ExpandedLights expand_area_lights(const std::vector<Light>& lights, const Technique& technique);

// `technique` with its per-light overrides repeated for each drawn light of their scenario light.
Technique expand_light_overrides(const ExpandedLights& expanded, const Technique& technique);

// The drawn lights' frames and statistics folded back to one per scenario light: V is the mean
// of the drawn lights' V (each 0 where its point is behind the receiver's tangent plane); the
// lookup channels are the first drawn light's.
RasterResult fold_area_lights(const ExpandedLights& expanded, RasterResult drawn);

}  // namespace penumbra::raster
