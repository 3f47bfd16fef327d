// What the raster benches share: their options (--repeat N, --device D, --scenario FILE and,
// where a bench has it, --terrain) and the median they report.
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
    bool terrain = false;
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
            args.terrain = true;
        } else {
            std::fprintf(stderr, "usage: %s [--repeat N] [--device D] [--scenario FILE]%s\n", name,
                         has_terrain ? " [--terrain]" : "");
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
