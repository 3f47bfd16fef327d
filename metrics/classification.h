// The verdict per pixel: compares what a technique decided (RasterFrame) with the truth
// (OracleFrame) and gives every wrong pixel exactly one class, by the rules of docs/metrics.md
// ("What the error classes mean"); docs/metrics.md states each rule with its units.
#pragma once

#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "common/frames.h"

namespace penumbra::metrics {

// Per-pixel class ids, as stored in errors.exr (`light<i>.class`). Stable numbers.
enum class PixelClass : std::uint8_t {
    background = 0,         // no surface in the oracle's image
    back_facing = 1,        // the surface cannot be lit (N.L <= 0, or outside a spot cone)
    uncertain = 2,          // the oracle's answer is within float error of a boundary
    coverage_mismatch = 3,  // the raster path saw another triangle (silhouettes)
    correct = 4,            // scored, |error| within tolerance
    aliasing = 5,
    acne = 6,
    peter_panning = 7,
    false_shadow = 8,
    false_lit = 9,
};
inline constexpr int kPixelClassCount = 10;
std::string_view to_string(PixelClass c);

// The five error classes in report order (counts/rates keys).
inline constexpr std::array<PixelClass, 5> kErrorClasses = {
    PixelClass::acne, PixelClass::peter_panning, PixelClass::aliasing, PixelClass::false_shadow, PixelClass::false_lit};
// Position of an error class in kErrorClasses (kErrorClasses.size() for the other classes).
constexpr std::size_t error_class_index(PixelClass c) {
    std::size_t k = 0;
    while (k < kErrorClasses.size() && kErrorClasses[k] != c) ++k;
    return k;
}

// How one light is judged; the caller derives the last two from the technique.
struct ScoringOptions {
    float tolerance = 1.0f / 255.0f;   // tau: a pixel is wrong when |error| > tolerance + oracle E
    float filter_reach_texels = 1.0f;  // aliasing band: this many texel footprints around a true boundary
    float depth_quantum = 0.0f;        // the depth format's resolution r (depth units), 0 for float
    double pixels_per_degree = 67.0;   // viewing condition of the perceptual error (FLIP's default)
    bool soft = false;                 // an area light: also score the penumbra (SoftScore)
};

struct PixelCounts {
    std::uint64_t surface = 0, scored = 0, back_facing = 0, uncertain = 0, coverage_mismatch = 0;
};

struct MeanMax {
    double mean = 0, max = 0;
};

// Soft shadows (docs/metrics.md, "Soft shadows"). Scored pixels fall in the oracle's umbra (V
// within tau + E of 0), lit region (of 1) or penumbra (between).
struct SoftScore {
    std::uint64_t umbra_pixels = 0, penumbra_pixels = 0, lit_pixels = 0;
    double penumbra_mae = 0;           // mean |error| inside the true penumbra
    double penumbra_mae_beyond_e = 0;  // mean max(0, |error| - E) there: what oracle noise cannot cause
    double umbra_mae = 0, lit_mae = 0;
    // Relative width of the raster's penumbrae against the truth's: pixels with V in (0.05,
    // 0.95) in each, raster / oracle - 1 (the band's area is its width times the shadow
    // outline, which both share). +0.3: penumbrae 30% too wide; -1: hard shadows.
    double penumbra_width_error = 0;
    std::uint64_t width_pixels_oracle = 0, width_pixels_raster = 0;
};

struct LightScore {
    PixelCounts pixels;
    std::array<std::uint64_t, 5> counts{};  // indexed like kErrorClasses
    std::uint64_t wrong = 0;
    double mae = 0, rmse = 0, wrong_fraction = 0;
    double bias = 0;                          // mean signed error (raster - oracle) over scored pixels
    MeanMax peter_panning_gap;                // metres along the shadow ray to the true occluder, peter-panning pixels
    MeanMax acne_depth;                       // metres the receiver lies behind its own stored surface, acne pixels
    MeanMax perceptual;                       // FLIP-style error in [0, 1] over surface pixels (see perceptual.h)
    std::optional<SoftScore> soft;            // area lights only
    std::uint64_t count(PixelClass c) const;  // 0 for classes that are not errors
    double rate(PixelClass c) const;          // count / scored
};

struct LightErrorImage {
    std::vector<float> error;       // raster V - oracle V where scored, 0 elsewhere
    std::vector<std::uint8_t> cls;  // PixelClass per pixel
    std::vector<float> perceptual;  // per-pixel perceptual error
};

struct FrameScore {
    std::vector<LightScore> lights;
    std::vector<LightErrorImage> images;
};

// Scores every light of the two frames. `options` has one entry per light (or a single entry
// used for all). Throws std::invalid_argument when the frames do not describe the same image.
FrameScore score_frames(const OracleFrame& oracle, const RasterFrame& raster, std::span<const ScoringOptions> options);

// The light's numbers as report.json writes them (docs/design.md, "report.json"), less "index" and "type".
nlohmann::json to_json(const LightScore& s);

}  // namespace penumbra::metrics
