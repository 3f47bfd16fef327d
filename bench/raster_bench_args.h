// What the raster benches share: their options (--repeat N, --device D, --scenario FILE and,
// where a bench has it, --terrain / --terrain-grid N) and the median they report.
#pragma once

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "tests/data_dir.h"

namespace penumbra::bench {

struct RasterBenchArgs {
    int repeat = 3;
    std::string device;  // empty: $PENUMBRA_VK_DEVICE, else lavapipe
    std::filesystem::path scenario = test::data_dir() / "default/scenario.json";
    int terrain_grid = 0;  // > 0: add a terrain of grid x grid quads (2 grid^2 triangles)
};

// Prints the usage line and returns nothing on an unknown or incomplete option.
inline std::optional<RasterBenchArgs> parse_raster_bench_args(int argc, char** argv, const char* name, int repeat,
                                                              bool has_terrain) {
    RasterBenchArgs args;
    args.repeat = repeat;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--repeat" && i + 1 < argc) {
            args.repeat = std::max(1, std::atoi(argv[++i]));
        } else if (a == "--device" && i + 1 < argc) {
            args.device = argv[++i];
        } else if (a == "--scenario" && i + 1 < argc) {
            args.scenario = argv[++i];
        } else if (has_terrain && a == "--terrain") {
            args.terrain_grid = 256;  // 131k triangles
        } else if (has_terrain && a == "--terrain-grid" && i + 1 < argc) {
            args.terrain_grid = std::clamp(std::atoi(argv[++i]), 1, 4096);
        } else {
            std::fprintf(stderr, "usage: %s [--repeat N] [--device D] [--scenario FILE]%s\n", name,
                         has_terrain ? " [--terrain | --terrain-grid N]" : "");
            return std::nullopt;
        }
    }
    return args;
}

inline double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

}  // namespace penumbra::bench
