// compare's input files: the engine's shadow image and depth buffer, read through image_io/
// (OpenImageIO, in its plugin), with every check that names the file and what was expected (docs/compare.md).
#pragma once

#include <filesystem>
#include <optional>

#include "pipeline/compare.h"

namespace penumbra {

// The engine frame from an image of shadow factors (1 = lit) for each of `lights` (indices into
// the scenario's lights, in the order the frame's V is built) and, optionally, its depth buffer.
// Channels: `light<i>.V` when the image names them; else one channel per light in order; one
// light takes the first channel. Throws InputError naming the file and what was expected.
EngineFrame load_engine_frame(const Scenario& scenario, const std::filesystem::path& image,
                              const std::vector<std::size_t>& lights, const std::optional<std::filesystem::path>& depth,
                              DepthSpace depth_space);

}  // namespace penumbra
