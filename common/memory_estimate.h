// How much memory a run will need, estimated from plain numbers before anything large is
// allocated, so that an input too big for the machine is refused (exit 2) up front instead of
// ending in an allocation failure half way or the OOM killer. The costs per triangle, pixel
// and texel are measured peaks (docs/testing.md, "Memory estimate"), rounded up.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/scenario.h"

namespace penumbra {

// The raster path's own bounds, shared with it so that the estimate follows them: the maps of
// all lights together are kept one per light up to this size (raster/depth_map.cpp), and
// averaged area-light samples are drawn this many at a time (raster/averaged_area.cpp).
inline constexpr std::uint64_t kShadowMapBudget = std::uint64_t{512} << 20;
inline constexpr int kAveragedSamplesAtOnce = 64;

// What a command will hold. Counts are plain numbers so that common/ knows nothing of the
// oracle or the raster path; the command line fills them in.
struct MemoryInputs {
    std::uint64_t triangles = 0, vertices = 0;
    std::uint64_t width = 0, height = 0;
    std::uint64_t lights = 0;       // every light of the scenario
    std::uint64_t area_lights = 0;  // rect, disk, sphere (the oracle samples them)
    bool oracle = false;            // traces the oracle (Embree scene + oracle frame)
    bool raster = false;            // draws with the raster path
    bool metrics = false;           // scores and writes the report (validate)
    // Raster path: lights drawn (an area light as min(area_samples, kAveragedSamplesAtOnce)
    // lights, at least 1), the shadow maps' side, their layers together (a map per light with
    // RasterMemory's layers for its kind; one shared map of the most beyond kShadowMapBudget)
    // and bytes per texel.
    std::uint64_t raster_lights = 0;
    std::uint64_t shadow_resolution = 0, shadow_layers = 0, shadow_texel_bytes = 0;
    // A family's own targets and geometry (RasterMemory's pixel and triangle terms), in bytes.
    std::uint64_t family_bytes = 0;
};

struct MemoryTerm {
    std::string name;  // "oracle frame (1024x1024 px, 3 lights)"
    std::uint64_t bytes = 0;
};

struct MemoryEstimate {
    std::vector<MemoryTerm> terms;
    std::uint64_t total() const;
    const MemoryTerm& biggest() const;
};

// Bytes the flattened scene and the structures built from it (Embree BVH, GPU buffers) take
// per triangle and per vertex; measured 162 (oracle) + 92 (raster) per triangle with its
// vertices on a 3.2M-triangle grid (docs/testing.md).
inline constexpr std::uint64_t kBytesPerTriangle = 256;
inline constexpr std::uint64_t kBytesPerVertex = 72;

MemoryEstimate estimate_memory(const MemoryInputs& in);

// The raster path's numbers, plain, as the technique's family gives them
// (raster/technique_family.h): the shadow-map side, bytes per depth texel, area_samples, and
// the layers a light's map has by the light's kind (cascades: their count for the sun).
struct RasterMemory {
    int resolution = 0;
    int depth_bytes = 4;
    int area_samples = 0;
    int directional_layers = 1, spot_layers = 1, cube_layers = 6;  // cube: point lights, area lights' points
    // What a family without a map holds instead (shadow volumes, planar projection): targets at
    // the image's size, once and per light drawn, and geometry per scene triangle per light.
    int pixel_bytes = 0, pixel_bytes_per_light = 0, triangle_bytes_per_light = 0;
};

// The inputs of a command on `scenario` (after load_scenario): the oracle when `oracle`, the
// raster path when `raster` is given, scoring and the report when `metrics`.
MemoryInputs memory_inputs(const Scenario& scenario, bool oracle, const RasterMemory* raster, bool metrics);

// Throws InputError when the estimate exceeds `budget_bytes`, naming the estimate, its biggest
// term and the budget: "needs about 12.3 GiB (biggest: ...), more than --max-memory 8 GiB".
void check_memory(const MemoryEstimate& estimate, std::uint64_t budget_bytes, const std::string& what);

// The default --max-memory: 3/4 of the memory this process may use (physical memory, lowered
// by a cgroup limit or RLIMIT_AS / RLIMIT_DATA when one is set).
std::uint64_t default_memory_budget();

// Parses --max-memory: a byte count with an optional K, M, G or T suffix (binary, "8G" is
// 8 GiB), or "0" for no limit. Throws InputError naming the option.
std::uint64_t parse_memory_size(const std::string& text);

// The budget for `--max-memory TEXT`: the default when TEXT is empty, unlimited for "0".
std::uint64_t memory_budget(const std::string& text);

// "12.3 GiB"
std::string format_bytes(std::uint64_t bytes);

}  // namespace penumbra
