// The raster tests' plain render: a Vulkan context with the Khronos validation layer on (one that
// cannot be made fails the test, no skip), and a technique given as JSON drawn in it.
#pragma once

#include <nlohmann/json.hpp>

#include "raster/raster.h"
#include "raster/technique.h"

namespace penumbra::test {

inline raster::ContextOptions with_validation() {
    raster::ContextOptions options;
    options.validation = true;
    return options;
}

inline raster::RasterResult render(const Scenario& sc, const nlohmann::json& technique, raster::VulkanContext& ctx) {
    return raster::run_raster(sc, raster::parse_technique(technique, "test: technique"), ctx);
}

}  // namespace penumbra::test
