// The verdict per pixel: compares what a technique decided (RasterFrame) with the truth
// (OracleFrame) and gives every wrong pixel exactly one class, by the rules of docs/metrics.md
// ("What the error classes mean"); docs/metrics.md states each rule with its units.
#pragma once

#include <array>
#include <cstdint>
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
    light_bleeding = 10,  // moment-map families only (ScoringOptions::light_bleeding)
};
inline constexpr int kPixelClassCount = 11;
std::string_view to_string(PixelClass c);

// The six error classes in report order (counts/rates keys).
inline constexpr std::array<PixelClass, 6> kErrorClasses = {PixelClass::acne,      PixelClass::peter_panning,
                                                            PixelClass::aliasing,  PixelClass::false_shadow,
                                                            PixelClass::false_lit, PixelClass::light_bleeding};
// Position of an error class in kErrorClasses (kErrorClasses.size() for the other classes).
constexpr std::size_t error_class_index(PixelClass c) {
    std::size_t k = 0;
    while (k < kErrorClasses.size() && kErrorClasses[k] != c) ++k;
    return k;
}

// How one light is judged; the caller derives filter_reach_texels and depth_quantum from the
// technique. The last two matter only for a light without depth-map lookups (docs/metrics.md,
// "V only"); each is estimated from the frames when not given.
struct ScoringOptions {
    float tolerance = 1.0f / 255.0f;         // tau: a pixel is wrong when |error| > tolerance + oracle E
    float visible_threshold = 0.1f;          // a wrong pixel is also *visible* when |error| >= this
    float filter_reach_texels = 1.0f;        // aliasing band: this many texel footprints around a true boundary
    float depth_quantum = 0.0f;              // the depth format's resolution r (depth units), 0 for float
    double pixels_per_degree = 67.0;         // viewing condition of the perceptual error (FLIP's default)
    bool soft = false;                       // an area light: also score the penumbra (SoftScore)
    bool perceptual = true;                  // false: skip the FLIP-style image (search loops need counts only)
    std::optional<float> texel_footprint_m;  // V only: shadow-map texel size at the receivers, metres
    std::optional<float> bias_reach_m;       // V only: every bias together, metres along the light ray
    // The technique filters moments (the vsm, esm and evsm families): a pixel brighter than a
    // true umbra, beyond the filter's and the bias's reach, is light_bleeding instead of
    // false_lit (docs/metrics.md). Off for depth-map families, whose verdicts it never changes.
    bool light_bleeding = false;
};

// What the classes of a light rest on (docs/metrics.md, "What each class rests on").
enum class Evidence : std::uint8_t {
    depth_map_lookups,  // the raster's lookup layer: stored depth and triangle, footprint and bias per pixel
    oracle_geometry,    // V only: the oracle's boundary and occluder distances, one footprint and bias reach
};
std::string_view to_string(Evidence e);

// Where a V-only scale came from.
enum class ScaleSource : std::uint8_t {
    given,      // ScoringOptions
    estimated,  // from the frames (estimate_aliasing_band_m, estimate_bias_reach_m)
    not_found,  // estimation found nothing to go on: the scale is 0 and its class does not fire
};
std::string_view to_string(ScaleSource s);

struct ClassificationEvidence {
    Evidence source = Evidence::depth_map_lookups;
    // oracle_geometry only: the scales the classes used.
    float texel_footprint_m = 0;  // aliasing band = filter_reach_texels x this
    ScaleSource texel_footprint_source = ScaleSource::given;
    float bias_reach_m = 0;  // peter-panning reach = this + one footprint
    ScaleSource bias_reach_source = ScaleSource::given;
};

struct PixelCounts {
    std::uint64_t surface = 0, scored = 0, back_facing = 0, uncertain = 0, coverage_mismatch = 0;
};

struct MeanMax {
    double mean = 0, max = 0;
};

// Soft shadows (docs/metrics.md, "Soft shadows"). Scored pixels fall in the oracle's umbra (V
// within tau + E of 0), lit region (of 1) or penumbra (between).
// Soft lights' penumbra-width band: V in (this, 1 - this), wide of the oracle's noise.
inline constexpr float kPenumbraWidthBand = 0.05f;

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

// Over a camera path (pipeline/camera_path.h): the flicker between consecutive frames, for the
// whole path (docs/metrics.md, "Flicker over a camera path").
struct TemporalScore {
    std::uint64_t points = 0;          // surface points seen in both frames of a pair, summed over pairs
    std::uint64_t flicker_pixels = 0;  // those that flickered
    double flicker_rate = 0;           // flicker_pixels / points (0 when none)
};

struct LightScore {
    PixelCounts pixels;
    std::array<std::uint64_t, kErrorClasses.size()> counts{};  // indexed like kErrorClasses
    std::uint64_t wrong = 0;
    // The wrong pixels whose |error| reaches ScoringOptions::visible_threshold: a pixel 1% too
    // dark and a missing shadow are one count above, only the second one here.
    std::array<std::uint64_t, kErrorClasses.size()> counts_visible{};
    std::uint64_t wrong_visible = 0;
    double mae = 0, rmse = 0, wrong_fraction = 0;
    double bias = 0;                          // mean signed error (raster - oracle) over scored pixels
    MeanMax peter_panning_gap;                // metres along the shadow ray to the true occluder, peter-panning pixels
    double peter_panning_gap_p95 = 0;         // its 95th percentile (nearest rank), metres
    MeanMax acne_depth;                       // metres the receiver lies behind its own stored surface, over the
                                              // acne pixels where the centre texel holds it behind (the lookups
                                              // record that texel alone; not reported with V only)
    std::uint64_t acne_depth_pixels = 0;      // those pixels; the other acne pixels were darkened by filter taps
                                              // whose depths are not recorded, so no depth is claimed for them
    MeanMax perceptual;                       // FLIP-style error in [0, 1] over surface pixels (see perceptual.h)
    std::optional<SoftScore> soft;            // area lights only
    std::optional<TemporalScore> temporal;    // a camera path's verdict only
    ClassificationEvidence evidence;          // what the classes rest on
    std::uint64_t count(PixelClass c) const;  // 0 for classes that are not errors
    double rate(PixelClass c) const;          // count / scored
    std::uint64_t count_visible(PixelClass c) const;
    double rate_visible(PixelClass c) const;  // count_visible / scored
};

struct LightErrorImage {
    std::vector<float> error;        // raster V - oracle V where scored, 0 elsewhere
    std::vector<std::uint8_t> cls;   // PixelClass per pixel
    std::vector<float> perceptual;   // per-pixel perceptual error
    float visible_threshold = 0.1f;  // the ScoringOptions' one: maps draw fainter errors paler
};

struct FrameScore {
    std::vector<LightScore> lights;
    std::vector<LightErrorImage> images;
};

// Scores every light of the two frames. `options` has one entry per light (or a single entry
// used for all). A light whose RasterLightImage has lookups is classified from them; one without
// from the oracle's geometry (docs/metrics.md). Throws std::invalid_argument when the frames do
// not describe the same image.
FrameScore score_frames(const OracleFrame& oracle, const RasterFrame& raster, std::span<const ScoringOptions> options);

// V only: the scales, from bands of flagged samples near distance 0 (docs/metrics.md,
// "Estimating the scales"). Both sort their samples first, so they are deterministic and do not
// depend on the samples' order. Both accept a band [0, D] only when it holds at least
// kMinBandFlagged flagged samples at no less than twice the flagged rate beyond it, and return
// D or nullopt.
struct DistanceSample {
    float distance_m;  // finite
    bool flagged;
};
inline constexpr std::uint64_t kMinBandFlagged = 16;
inline constexpr double kMinBandLogLikelihoodRatio = 12;  // a chance split of one rate: p ~ 1e-6

// The aliasing band, from (boundary_m, wrong) samples of scored pixels: D where the wrong rate
// has fallen to half its mean inside [0, D] (D maximises wrong - rate x pixels within D, rate
// half the band's own: a fixed point, iterated from the mean rate). The texel footprint is D /
// the filter's reach.
std::optional<float> estimate_aliasing_band_m(std::vector<DistanceSample> samples);

// The bias reach, from (occluder_m, lost) samples of scored pixels whose shadow ray meets a true
// occluder, outside the aliasing band; lost: the raster is wrongly brighter. D is the maximum-
// likelihood change point of the lost rate: the split into [0, D] (the higher rate) and beyond
// whose two rates explain the samples best, accepted also only when its log-likelihood ratio
// against one rate is at least kMinBandLogLikelihoodRatio.
std::optional<float> estimate_bias_reach_m(std::vector<DistanceSample> samples);

}  // namespace penumbra::metrics
