// penumbra sweep: error against run time over technique configurations (docs/sweep.md). One
// oracle (cache), one RasterSession; per configuration the verdict (a diagnostic render with
// the depth-map lookups) and the time an engine would pay (a production render: shadow pass and
// V alone, maps redrawn), both from GPU timestamps. Shards split the configurations across
// machines; merge() puts shard tables back together into what one run gives.
#pragma once

#include <functional>
#include <span>
#include <string>
#include <vector>

#include "pipeline/validate.h"
#include "raster/vulkan_context.h"
#include "sweep/sweep_table.h"

namespace penumbra::sweep {

// The verdict columns of sweep.csv: metric paths (metrics/metric_table.h), pooled over the
// scenario's lights weighted by scored pixels. Soft-shadow columns only with area lights.
std::vector<std::string> verdict_columns(const Scenario& scenario);

struct SweepOptions {
    ValidateOptions validate;
    int repeat = 3;
    std::function<void(const Row&, std::size_t done, std::size_t of)> progress;
};

// The shard's configurations (`configs`, of `total` in the whole sweep); `fingerprint` is the
// definition_fingerprint of the whole sweep, carried into sweep.json for merge.
Table run_sweep(const Scenario& scenario, const std::string& scenario_name, std::span<const std::string> keys,
                std::span<const Config> configs, std::size_t total, Shard shard, const SweepOptions& options,
                const raster::VulkanContext& ctx, const std::string& fingerprint = {});

}  // namespace penumbra::sweep
