#include "common/memory_estimate.h"

#include <fmt/format.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>

#include "common/errors.h"

namespace penumbra {

namespace {

constexpr std::uint64_t kUnlimited = std::numeric_limits<std::uint64_t>::max();

// Peak bytes per pixel, fit to /usr/bin/time peaks of each command at 1024^2 and 2048^2 with 1
// and 3 lights on data/default (docs/testing.md, "Memory estimate"), plus 15%. The commands
// alone write their frames (EXR interleave buffers, previews), which validate does not.
struct PerPixel {
    std::uint64_t base, per_light;
};
constexpr PerPixel kOracleAlone{128, 84};      // measured 110 + 73 per light
constexpr PerPixel kRasterAlone{28, 124};      // measured 24 + 107 per light drawn
constexpr PerPixel kOracleInValidate{56, 40};  // validate measured 104 + 80 per light in all:
constexpr PerPixel kRasterInValidate{16, 40};  // these three sum to 120 + 92 per light
constexpr PerPixel kMetrics{48, 12};
constexpr std::uint64_t kOracleAreaPerPixel = 96;  // surface points kept for area sampling

// Saturating arithmetic: absurd inputs must give a huge estimate, not a wrapped small one.
std::uint64_t mul(std::uint64_t a, std::uint64_t b) {
    std::uint64_t r = 0;
    return __builtin_mul_overflow(a, b, &r) ? kUnlimited : r;
}
std::uint64_t add(std::uint64_t a, std::uint64_t b) {
    std::uint64_t r = 0;
    return __builtin_add_overflow(a, b, &r) ? kUnlimited : r;
}

std::uint64_t read_cgroup_limit() {
    std::ifstream in("/sys/fs/cgroup/memory.max");  // cgroup v2; "max" when unlimited
    std::string text;
    if (!(in >> text) || text.empty() || !std::isdigit(static_cast<unsigned char>(text[0]))) return kUnlimited;
    return std::stoull(text);
}

}  // namespace

std::uint64_t MemoryEstimate::total() const {
    std::uint64_t sum = 0;
    for (const MemoryTerm& t : terms) sum = add(sum, t.bytes);
    return sum;
}

const MemoryTerm& MemoryEstimate::biggest() const {
    static const MemoryTerm kNone{"nothing", 0};
    if (terms.empty()) return kNone;
    return *std::max_element(terms.begin(), terms.end(),
                             [](const MemoryTerm& a, const MemoryTerm& b) { return a.bytes < b.bytes; });
}

MemoryEstimate estimate_memory(const MemoryInputs& in) {
    MemoryEstimate e;
    const std::uint64_t px = mul(in.width, in.height);
    const std::string image = fmt::format("{}x{} px", in.width, in.height);
    e.terms.push_back({fmt::format("scene ({} triangles, {} vertices)", in.triangles, in.vertices),
                       add(mul(in.triangles, kBytesPerTriangle), mul(in.vertices, kBytesPerVertex))});
    const bool validate = in.oracle && in.raster;
    auto per_pixel = [&](PerPixel c, std::uint64_t lights) { return mul(px, add(c.base, mul(lights, c.per_light))); };
    if (in.oracle) {
        std::uint64_t bytes = per_pixel(validate ? kOracleInValidate : kOracleAlone, in.lights);
        if (in.area_lights) bytes = add(bytes, mul(px, kOracleAreaPerPixel));
        e.terms.push_back({fmt::format("oracle frame ({}, {} lights)", image, in.lights), bytes});
    }
    if (in.raster) {
        e.terms.push_back({fmt::format("raster frame ({}, {} lights drawn)", image, in.raster_lights),
                           per_pixel(validate ? kRasterInValidate : kRasterAlone, in.raster_lights)});
        const std::uint64_t texels = mul(mul(in.shadow_resolution, in.shadow_resolution), in.shadow_layers);
        e.terms.push_back({fmt::format("shadow maps ({}^2 x {} layers x {} bytes)", in.shadow_resolution,
                                       in.shadow_layers, in.shadow_texel_bytes),
                           mul(texels, in.shadow_texel_bytes)});
        if (in.family_bytes > 0)
            e.terms.push_back({"the technique's own targets and geometry (no shadow map)", in.family_bytes});
    }
    if (in.metrics)
        e.terms.push_back(
            {fmt::format("metrics and report ({}, {} lights)", image, in.lights), per_pixel(kMetrics, in.lights)});
    return e;
}

MemoryInputs memory_inputs(const Scenario& scenario, bool oracle, const RasterMemory* raster, bool metrics) {
    MemoryInputs in;
    in.triangles = scenario.scene.triangles.size();
    in.vertices = scenario.scene.positions.size();
    in.width = static_cast<std::uint64_t>(scenario.width);
    in.height = static_cast<std::uint64_t>(scenario.height);
    in.lights = scenario.lights.size();
    for (const Light& l : scenario.lights) in.area_lights += is_soft_light(l) ? 1 : 0;  // sampled by the oracle
    in.oracle = oracle;
    in.metrics = metrics;
    if (raster) {
        in.raster = true;
        // Every light keeps a map of its own while all of them fit kShadowMapBudget; beyond it one
        // map of the most layers is shared (raster/depth_map.cpp). Point lights, and area lights
        // (drawn from points), need a cube; the family says how many layers each kind takes.
        // Averaged area samples are drawn at most kAveragedSamplesAtOnce at a time, so their
        // outputs never exist all at once.
        std::uint64_t most = 0, layers = 0;
        for (const Light& l : scenario.lights) {
            const bool area = is_area_light(l.type);
            in.raster_lights +=
                area ? static_cast<std::uint64_t>(std::clamp(raster->area_samples, 1, kAveragedSamplesAtOnce)) : 1;
            const int of_light = area || l.type == LightType::point ? raster->cube_layers
                                 : l.type == LightType::spot        ? raster->spot_layers
                                                                    : raster->directional_layers;
            const auto n = static_cast<std::uint64_t>(std::max(of_light, 1));
            most = std::max(most, n);
            layers += n;
        }
        in.shadow_resolution = static_cast<std::uint64_t>(raster->resolution);
        in.shadow_texel_bytes = static_cast<std::uint64_t>(raster->depth_bytes) + 4;  // + the primitive id
        const std::uint64_t all =
            mul(mul(mul(in.shadow_resolution, in.shadow_resolution), layers), in.shadow_texel_bytes);
        in.shadow_layers = all <= kShadowMapBudget ? layers : std::max<std::uint64_t>(most, 1);
        const std::uint64_t px = mul(in.width, in.height), lights = in.lights;
        in.family_bytes =
            add(mul(px, add(static_cast<std::uint64_t>(raster->pixel_bytes),
                            mul(lights, static_cast<std::uint64_t>(raster->pixel_bytes_per_light)))),
                mul(mul(in.triangles, lights), static_cast<std::uint64_t>(raster->triangle_bytes_per_light)));
    }
    return in;
}

std::string format_bytes(std::uint64_t bytes) {
    if (bytes == kUnlimited) return "more than 16 EiB";
    const char* units[] = {"bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
    double v = static_cast<double>(bytes);
    int u = 0;
    while (v >= 1024 && u < 6) {
        v /= 1024;
        ++u;
    }
    return u == 0 ? fmt::format("{} bytes", bytes) : fmt::format("{:.1f} {}", v, units[u]);
}

void check_memory(const MemoryEstimate& estimate, std::uint64_t budget_bytes, const std::string& what) {
    const std::uint64_t total = estimate.total();
    if (total <= budget_bytes) return;
    const MemoryTerm& big = estimate.biggest();
    throw InputError(
        fmt::format("{}: needs about {} of memory (biggest: {}, {}), more than the {} allowed "
                    "(--max-memory; the default is 3/4 of this machine's memory)",
                    what, format_bytes(total), big.name, format_bytes(big.bytes), format_bytes(budget_bytes)));
}

std::uint64_t default_memory_budget() {
    std::uint64_t limit = mul(static_cast<std::uint64_t>(std::max(0L, ::sysconf(_SC_PHYS_PAGES))),
                              static_cast<std::uint64_t>(std::max(0L, ::sysconf(_SC_PAGE_SIZE))));
    if (limit == 0) limit = kUnlimited;
    limit = std::min(limit, read_cgroup_limit());
    for (int resource : {RLIMIT_AS, RLIMIT_DATA}) {
        rlimit r{};
        if (::getrlimit(resource, &r) == 0 && r.rlim_cur != RLIM_INFINITY)
            limit = std::min<std::uint64_t>(limit, r.rlim_cur);
    }
    return limit == kUnlimited ? kUnlimited : limit / 4 * 3;
}

std::uint64_t parse_memory_size(const std::string& text) {
    auto bad = [&]() -> std::uint64_t {
        throw InputError(fmt::format("--max-memory {}: expected a size such as 8G, 512M or 0 (no limit)", text));
    };
    std::size_t used = 0;
    double value = 0;
    try {
        value = std::stod(text, &used);
    } catch (const std::exception&) {
        return bad();
    }
    std::string suffix = text.substr(used);
    if (!suffix.empty() && (suffix.back() == 'B' || suffix.back() == 'b')) suffix.pop_back();
    if (!suffix.empty() && (suffix.back() == 'i')) suffix.pop_back();
    double scale = 1;
    if (suffix.size() > 1) return bad();
    if (suffix.size() == 1) {
        const std::string units = "KMGT";
        auto k = units.find(static_cast<char>(std::toupper(static_cast<unsigned char>(suffix[0]))));
        if (k == std::string::npos) return bad();
        scale = std::ldexp(1.0, 10 * static_cast<int>(k + 1));
    }
    const double bytes = value * scale;
    if (!(bytes >= 0) || !std::isfinite(bytes) || bytes >= 1.8e19) return bad();
    return static_cast<std::uint64_t>(bytes);
}

std::uint64_t memory_budget(const std::string& text) {
    if (text.empty()) return default_memory_budget();
    const std::uint64_t bytes = parse_memory_size(text);
    return bytes == 0 ? kUnlimited : bytes;
}

}  // namespace penumbra
