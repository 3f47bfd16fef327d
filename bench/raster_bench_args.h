// What the raster benches share: their options (--repeat N, --device D, --scenario FILE and,
// where a bench has it, --terrain / --terrain-grid N) and the median they report.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "common/scene.h"
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

// A 16 m wavy terrain of grid x grid quads (2 grid^2 triangles) under the scene, to load the
// rasteriser (--terrain-grid 1024: 2.1M triangles).
inline void add_terrain(Scene& s, int grid) {
    const double extent = 16.0;
    std::uint32_t base = static_cast<std::uint32_t>(s.positions.size());
    for (int j = 0; j <= grid; ++j)
        for (int i = 0; i <= grid; ++i) {
            double x = -extent / 2 + extent * i / grid, z = -extent / 2 + extent * j / grid;
            glm::dvec3 p(x, -0.05 + 0.04 * std::sin(3.1 * x) * std::cos(2.3 * z), z);
            s.positions.push_back(p);
            s.bounds.grow(p);
        }
    for (int j = 0; j < grid; ++j)
        for (int i = 0; i < grid; ++i) {
            std::uint32_t a = base + j * (grid + 1) + i, b = a + 1, c = a + grid + 1, d = c + 1;
            s.triangles.push_back({a, c, b});
            s.triangles.push_back({b, c, d});
            for (int k = 0; k < 2; ++k) {
                s.double_sided.push_back(1);
                s.triangle_node.push_back(0);
            }
        }
}

inline double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

}  // namespace penumbra::bench
