#include "metrics/classification.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "metrics/perceptual.h"
#include "metrics/score_sums.h"

namespace penumbra::metrics {

std::string_view to_string(PixelClass c) {
    static constexpr std::string_view kNames[kPixelClassCount] = {
        "background", "back_facing",   "uncertain",    "coverage_mismatch", "correct",       "aliasing",
        "acne",       "peter_panning", "false_shadow", "false_lit",         "light_bleeding"};
    return kNames[static_cast<int>(c)];
}

std::string_view to_string(Evidence e) {
    return e == Evidence::depth_map_lookups ? "depth_map_lookups" : "oracle_geometry";
}

std::string_view to_string(ScaleSource s) {
    switch (s) {
        case ScaleSource::given: return "given";
        case ScaleSource::estimated: return "estimated";
        case ScaleSource::not_found: return "not_found";
    }
    return "?";
}

std::uint64_t LightScore::count(PixelClass c) const {
    const std::size_t k = error_class_index(c);
    return k < counts.size() ? counts[k] : 0;
}

double LightScore::rate(PixelClass c) const {
    return pixels.scored ? static_cast<double>(count(c)) / static_cast<double>(pixels.scored) : 0.0;
}

std::uint64_t LightScore::count_visible(PixelClass c) const {
    const std::size_t k = error_class_index(c);
    return k < counts_visible.size() ? counts_visible[k] : 0;
}

double LightScore::rate_visible(PixelClass c) const {
    return pixels.scored ? static_cast<double>(count_visible(c)) / static_cast<double>(pixels.scored) : 0.0;
}

namespace {

// estimate_aliasing_band_m's fixed point is met in a few iterations on real profiles; the cap
// only bounds a pathological one.
constexpr int kMaxBandIterations = 32;

constexpr float kWidthBand = kPenumbraWidthBand;

// The wrong pixel's class, in docs/metrics.md's order: aliasing, acne, peter-panning, the rest.
PixelClass classify_from_lookups(float error, const OracleLightImage& o, std::uint32_t oracle_prim,
                                 const DepthMapLookups& r, std::size_t i, const ScoringOptions& opt) {
    const float footprint = r.footprint_m[i];
    // 1. Within the filter's reach of a true boundary: finite resolution, not a bias problem.
    if (footprint > 0 && o.boundary_m[i] <= opt.filter_reach_texels * footprint) return PixelClass::aliasing;
    if (error < 0) {
        // 2. The texel that shadowed the receiver holds its own surface: the same triangle, or
        // a depth no further in front of the (biased) receiver than the receiver plane moves
        // across the texel.
        const bool in_map = (r.flags[i] & kRasterOutsideMap) == 0;
        const float gap = r.ref_depth[i] - r.stored_depth[i];
        if (in_map && (r.stored_prim[i] == oracle_prim || gap <= r.texel_slope[i] + opt.depth_quantum))
            return PixelClass::acne;
        return PixelClass::false_shadow;
    }
    // 3. The true occluder is nearer than the bias plus one texel: the shadow was biased away.
    if (o.occluder_m[i] <= r.bias_m[i] + footprint) return PixelClass::peter_panning;
    return PixelClass::false_lit;
}

// V only (docs/metrics.md, "What each class rests on"): the same order, with one footprint and
// one bias reach for the light and the oracle's occluder distance standing in for the stored
// depth.
struct GeometryScales {
    float footprint_m = 0;      // 0: no aliasing band
    float aliasing_band_m = 0;  // filter reach x footprint
    float bias_reach_m = 0;     // peter-panning: occluder_m <= bias_reach_m + footprint_m
};

PixelClass classify_from_geometry(float error, const OracleLightImage& o, std::size_t i, const GeometryScales& g) {
    // 1. Within the filter's reach of a true boundary.
    if (g.aliasing_band_m > 0 && o.boundary_m[i] <= g.aliasing_band_m) return PixelClass::aliasing;
    // 2. Darker where nothing at all lies between the receiver and the light: far from every
    // boundary, the only surface the map can have put in front of the receiver is its own.
    if (error < 0) return std::isinf(o.occluder_m[i]) ? PixelClass::acne : PixelClass::false_shadow;
    // 3. Brighter with the true occluder within the bias reach plus one texel.
    if (o.occluder_m[i] <= g.bias_reach_m + g.footprint_m) return PixelClass::peter_panning;
    return PixelClass::false_lit;
}

// The bucket of a surface pixel of the oracle (docs/metrics.md, "Which pixels are scored"):
// coverage_mismatch, back_facing, uncertain, or correct for a scored pixel.
PixelClass bucket_of(const OracleFrame& of, const RasterFrame& rf, const OracleLightImage& o, std::size_t i) {
    if (rf.A[i] == 0 || rf.prim[i] != of.prim[i]) return PixelClass::coverage_mismatch;
    if (o.lightable[i] == 0) return PixelClass::back_facing;
    if (o.U[i] != 0) return PixelClass::uncertain;
    return PixelClass::correct;
}

ClassificationEvidence geometry_evidence(const OracleFrame& of, const RasterFrame& rf, std::size_t li,
                                         const ScoringOptions& opt) {
    const OracleLightImage& o = of.lights[li];
    const RasterLightImage& r = rf.lights[li];
    const std::size_t n = of.pixel_count();
    const float reach = opt.filter_reach_texels > 0 ? opt.filter_reach_texels : 1.0f;
    auto scored_error = [&](std::size_t i) -> std::optional<float> {
        if (of.A[i] == 0 || bucket_of(of, rf, o, i) != PixelClass::correct) return std::nullopt;
        return r.V[i] - o.V[i];
    };
    auto is_wrong = [&](std::size_t i, float e) { return std::abs(e) > opt.tolerance + o.E[i]; };

    ClassificationEvidence ev;
    ev.source = Evidence::oracle_geometry;
    if (opt.texel_footprint_m) {
        ev.texel_footprint_m = *opt.texel_footprint_m;
        ev.texel_footprint_source = ScaleSource::given;
    } else {
        // The aliasing band: wrong pixels against the distance to the nearest true boundary.
        std::vector<DistanceSample> samples;
        for (std::size_t i = 0; i < n; ++i)
            if (auto e = scored_error(i); e && std::isfinite(o.boundary_m[i]))
                samples.push_back({o.boundary_m[i], is_wrong(i, *e)});
        const std::optional<float> band = estimate_aliasing_band_m(std::move(samples));
        ev.texel_footprint_m = band ? *band / reach : 0.0f;
        ev.texel_footprint_source = band ? ScaleSource::estimated : ScaleSource::not_found;
    }
    if (opt.bias_reach_m) {
        ev.bias_reach_m = *opt.bias_reach_m;
        ev.bias_reach_source = ScaleSource::given;
    } else {
        // Lost shadows (wrongly brighter) against the distance to the true occluder, outside the
        // aliasing band.
        const float aliasing_band = reach * ev.texel_footprint_m;
        std::vector<DistanceSample> samples;
        for (std::size_t i = 0; i < n; ++i)
            if (auto e = scored_error(i);
                e && std::isfinite(o.occluder_m[i]) && !(aliasing_band > 0 && o.boundary_m[i] <= aliasing_band))
                samples.push_back({o.occluder_m[i], is_wrong(i, *e) && *e > 0});
        const std::optional<float> reach_m = estimate_bias_reach_m(std::move(samples));
        ev.bias_reach_m = reach_m.value_or(0.0f);
        ev.bias_reach_source = reach_m ? ScaleSource::estimated : ScaleSource::not_found;
    }
    return ev;
}

LightScore score_light(const OracleFrame& of, const RasterFrame& rf, std::size_t li, const ScoringOptions& opt,
                       LightErrorImage& img) {
    const OracleLightImage& o = of.lights[li];
    const RasterLightImage& r = rf.lights[li];
    // With lookups, `lk` is the layer; without, it is never read.
    static const DepthMapLookups kNoLookups;
    const DepthMapLookups& lk = r.lookups ? *r.lookups : kNoLookups;
    const ClassificationEvidence evidence = r.lookups ? ClassificationEvidence{} : geometry_evidence(of, rf, li, opt);
    GeometryScales scales;
    scales.footprint_m = evidence.texel_footprint_m;
    scales.aliasing_band_m = (opt.filter_reach_texels > 0 ? opt.filter_reach_texels : 1.0f) * scales.footprint_m;
    scales.bias_reach_m = evidence.bias_reach_m;
    const std::size_t n = of.pixel_count();
    const int W = of.width;
    img.error.assign(n, 0.0f);
    img.visible_threshold = opt.visible_threshold;
    img.cls.assign(n, static_cast<std::uint8_t>(PixelClass::background));
    std::vector<detail::RowSums> rows(static_cast<std::size_t>(of.height));

    tbb::parallel_for(0, of.height, [&](int y) {
        detail::RowSums& s = rows[static_cast<std::size_t>(y)];
        for (int x = 0; x < W; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * W + x;
            PixelClass c = PixelClass::background;
            if (of.A[i] != 0) {
                ++s.pixels.surface;
                c = bucket_of(of, rf, o, i);
                if (c == PixelClass::coverage_mismatch) {
                    ++s.pixels.coverage_mismatch;
                } else if (c == PixelClass::back_facing) {
                    ++s.pixels.back_facing;
                } else if (c == PixelClass::uncertain) {
                    ++s.pixels.uncertain;
                } else {
                    ++s.pixels.scored;
                    const float e = r.V[i] - o.V[i];
                    img.error[i] = e;
                    s.abs_sum += std::abs(e);
                    s.sq_sum += static_cast<double>(e) * e;
                    s.signed_sum += e;
                    c = PixelClass::correct;
                    if (opt.soft) {
                        // The oracle's region, with its own uncertainty: umbra and lit are V
                        // within tau + E of 0 and 1.
                        const float margin = opt.tolerance + o.E[i];
                        const std::size_t region = o.V[i] <= margin ? 0 : o.V[i] >= 1 - margin ? 2 : 1;
                        ++s.region_pixels[region];
                        s.region_abs[region] += std::abs(e);
                        if (region == 1) s.penumbra_excess += std::max(0.0f, std::abs(e) - o.E[i]);
                        auto in_band = [](float v) { return v > kWidthBand && v < 1 - kWidthBand; };
                        s.band_oracle += in_band(o.V[i]);
                        s.band_raster += in_band(r.V[i]);
                    }
                    if (std::abs(e) > opt.tolerance + o.E[i]) {
                        c = r.lookups ? classify_from_lookups(e, o, of.prim[i], lk, i, opt)
                                      : classify_from_geometry(e, o, i, scales);
                        // 4. A moment map's Chebyshev bound leaking light into a true umbra,
                        // beyond every other reach: light bleeding (docs/metrics.md).
                        if (c == PixelClass::false_lit && opt.light_bleeding && o.V[i] <= opt.tolerance + o.E[i])
                            c = PixelClass::light_bleeding;
                        ++s.counts[error_class_index(c)];
                        if (std::abs(e) >= opt.visible_threshold) ++s.counts_visible[error_class_index(c)];
                        if (c == PixelClass::peter_panning) {
                            s.gap_sum += o.occluder_m[i];
                            s.gap_max = std::max(s.gap_max, static_cast<double>(o.occluder_m[i]));
                            s.gaps.push_back(o.occluder_m[i]);
                        } else if (c == PixelClass::acne && r.lookups && lk.ref_depth[i] > lk.stored_depth[i]) {
                            // Only where the centre texel itself holds the receiver behind: elsewhere
                            // filter taps darkened it, at depths the lookups do not record, and a
                            // depth of 0 would read as "no more bias needed".
                            const double depth = (lk.ref_depth[i] - lk.stored_depth[i]) * lk.depth_to_m[i];
                            s.acne_sum += depth;
                            s.acne_max = std::max(s.acne_max, depth);
                            ++s.acne_measured;
                        }
                    }
                }
            } else if (rf.A[i] != 0) {
                c = PixelClass::coverage_mismatch;  // the raster path saw a surface where there is none
            }
            img.cls[i] = static_cast<std::uint8_t>(c);
        }
    });

    detail::RowSums t;
    for (const detail::RowSums& row : rows) t.add(row);
    LightScore s;
    s.evidence = evidence;
    detail::fill_score(t, opt, s);
    if (!t.gaps.empty()) {
        // Nearest rank: the smallest gap with at least 95% of them at or below it.
        const std::size_t rank = (t.gaps.size() * 95 + 99) / 100 - 1;
        std::nth_element(t.gaps.begin(), t.gaps.begin() + static_cast<std::ptrdiff_t>(rank), t.gaps.end());
        s.peter_panning_gap_p95 = t.gaps[rank];
    }

    if (!opt.perceptual) return s;
    // Both pictures agree wherever the pixel is not scored, so only scored differences show.
    std::vector<float> truth(n), shown(n);
    for (std::size_t i = 0; i < n; ++i) {
        const bool scored = img.cls[i] >= static_cast<std::uint8_t>(PixelClass::correct);
        truth[i] = of.A[i] != 0 ? o.V[i] : 0.0f;
        shown[i] = scored ? r.V[i] : truth[i];
    }
    img.perceptual = perceptual_error(truth, shown, of.width, of.height, opt.pixels_per_degree);
    double sum = 0, mx = 0;
    for (std::size_t i = 0; i < n; ++i)
        if (of.A[i] != 0) {
            sum += img.perceptual[i];
            mx = std::max(mx, static_cast<double>(img.perceptual[i]));
        }
    s.perceptual = {t.pixels.surface ? sum / static_cast<double>(t.pixels.surface) : 0.0, mx};
    return s;
}

void require_same_image(const OracleFrame& o, const RasterFrame& r) {
    const std::size_t n = o.pixel_count();
    if (o.width != r.width || o.height != r.height)
        throw std::invalid_argument("score_frames: oracle and raster images differ in size");
    if (o.lights.size() != r.lights.size())
        throw std::invalid_argument("score_frames: oracle and raster frames differ in light count");
    if (o.A.size() != n || o.prim.size() != n || r.A.size() != n || r.prim.size() != n)
        throw std::invalid_argument("score_frames: a per-pixel image has the wrong size");
    for (std::size_t li = 0; li < o.lights.size(); ++li) {
        const auto& a = o.lights[li];
        const auto& b = r.lights[li];
        for (std::size_t size : {a.V.size(), a.E.size(), a.U.size(), a.lightable.size(), a.occluder_m.size(),
                                 a.boundary_m.size(), b.V.size()})
            if (size != n) throw std::invalid_argument("score_frames: a light image has the wrong size");
        if (!b.lookups) continue;
        const DepthMapLookups& l = *b.lookups;
        for (std::size_t size : {l.ref_depth.size(), l.stored_depth.size(), l.stored_prim.size(), l.footprint_m.size(),
                                 l.texel_slope.size(), l.bias_m.size(), l.depth_to_m.size(), l.flags.size()})
            if (size != n) throw std::invalid_argument("score_frames: a lookup image has the wrong size");
    }
}

}  // namespace

namespace {

// Samples by distance; counts of flagged ones.
struct SortedSamples {
    std::vector<DistanceSample> samples;
    std::uint64_t flagged = 0;
    explicit SortedSamples(std::vector<DistanceSample> s) : samples(std::move(s)) {
        std::sort(samples.begin(), samples.end(), [](const DistanceSample& a, const DistanceSample& b) {
            return a.distance_m != b.distance_m ? a.distance_m < b.distance_m : a.flagged < b.flagged;
        });
        for (const auto& x : samples) flagged += x.flagged;
    }
    // A band [0, D] may end after sample k only where the next distance differs.
    bool can_end_after(std::size_t k) const {
        return k + 1 == samples.size() || samples[k + 1].distance_m != samples[k].distance_m;
    }
};

struct Band {
    std::size_t samples = 0;  // the first `samples` sorted samples
    std::uint64_t flagged = 0;
};

double rate_of(std::uint64_t flagged, std::size_t count) {
    return count ? static_cast<double>(flagged) / static_cast<double>(count) : 0.0;
}

// The acceptance common to both estimators: enough flagged samples, concentrated in the band.
std::optional<float> accepted_band(const SortedSamples& s, const Band& band) {
    const std::size_t n = s.samples.size();
    if (band.samples == 0 || band.samples == n || band.flagged < kMinBandFlagged) return std::nullopt;
    if (rate_of(band.flagged, band.samples) < 2 * rate_of(s.flagged - band.flagged, n - band.samples))
        return std::nullopt;
    return s.samples[band.samples - 1].distance_m;
}

}  // namespace

std::optional<float> estimate_aliasing_band_m(std::vector<DistanceSample> samples) {
    const SortedSamples s(std::move(samples));
    const std::size_t n = s.samples.size();
    if (s.flagged == 0) return std::nullopt;
    // The band that gains most from holding its samples at a rate above `rate`: it ends where
    // the profile's rate falls through `rate`.
    auto band_for = [&](double rate) {
        Band best, at;
        double best_gain = 0;
        for (std::size_t k = 0; k < n; ++k) {
            at.flagged += s.samples[k].flagged;
            at.samples = k + 1;
            if (!s.can_end_after(k)) continue;
            const double gain = static_cast<double>(at.flagged) - rate * static_cast<double>(at.samples);
            if (gain > best_gain) {
                best_gain = gain;
                best = at;
            }
        }
        return best;
    };
    // From the mean rate, the threshold becomes half the band's own rate until that holds.
    Band band = band_for(rate_of(s.flagged, n));
    for (int iteration = 0; iteration < kMaxBandIterations && band.samples > 0; ++iteration) {
        const Band next = band_for(0.5 * rate_of(band.flagged, band.samples));
        if (next.samples == band.samples) break;
        band = next;
    }
    return accepted_band(s, band);
}

std::optional<float> estimate_bias_reach_m(std::vector<DistanceSample> samples) {
    const SortedSamples s(std::move(samples));
    const std::size_t n = s.samples.size();
    // Log-likelihood of `flagged` of `count` Bernoulli samples at their own rate.
    auto log_likelihood = [](double flagged, double count) {
        auto term = [](double k, double p) { return k > 0 ? k * std::log(p) : 0.0; };
        return count > 0 ? term(flagged, flagged / count) + term(count - flagged, 1 - flagged / count) : 0.0;
    };
    const double one_rate = log_likelihood(static_cast<double>(s.flagged), static_cast<double>(n));
    double best_ratio = 0;
    Band best, at;
    for (std::size_t k = 0; k + 1 < n; ++k) {
        at.flagged += s.samples[k].flagged;
        at.samples = k + 1;
        if (!s.can_end_after(k)) continue;
        const double in = static_cast<double>(at.flagged), in_count = static_cast<double>(at.samples);
        const double out = static_cast<double>(s.flagged - at.flagged), out_count = static_cast<double>(n - at.samples);
        if (in * out_count <= out * in_count) continue;  // the band must hold the higher rate
        const double ratio = log_likelihood(in, in_count) + log_likelihood(out, out_count) - one_rate;
        if (ratio > best_ratio) {
            best_ratio = ratio;
            best = at;
        }
    }
    if (best_ratio < kMinBandLogLikelihoodRatio) return std::nullopt;
    return accepted_band(s, best);
}

FrameScore score_frames(const OracleFrame& oracle, const RasterFrame& raster, std::span<const ScoringOptions> options) {
    require_same_image(oracle, raster);
    if (oracle.lights.empty()) return {};
    if (options.empty() || (options.size() != 1 && options.size() != oracle.lights.size()))
        throw std::invalid_argument("score_frames: need one ScoringOptions, or one per light");
    for (const ScoringOptions& o : options)
        for (const std::optional<float>& scale : {o.texel_footprint_m, o.bias_reach_m})
            if (scale && !(*scale >= 0 && std::isfinite(*scale)))
                throw std::invalid_argument(
                    "score_frames: a given footprint or bias reach is not a finite length >= 0");
    FrameScore out;
    out.images.resize(oracle.lights.size());
    for (std::size_t li = 0; li < oracle.lights.size(); ++li)
        out.lights.push_back(
            score_light(oracle, raster, li, options.size() == 1 ? options[0] : options[li], out.images[li]));
    return out;
}

namespace detail {

void RowSums::add(const RowSums& r) {
    for (std::size_t k = 0; k < 3; ++k) {
        region_pixels[k] += r.region_pixels[k];
        region_abs[k] += r.region_abs[k];
    }
    penumbra_excess += r.penumbra_excess;
    band_oracle += r.band_oracle;
    band_raster += r.band_raster;
    pixels.surface += r.pixels.surface;
    pixels.scored += r.pixels.scored;
    pixels.back_facing += r.pixels.back_facing;
    pixels.uncertain += r.pixels.uncertain;
    pixels.coverage_mismatch += r.pixels.coverage_mismatch;
    for (std::size_t k = 0; k < counts.size(); ++k) {
        counts[k] += r.counts[k];
        counts_visible[k] += r.counts_visible[k];
    }
    acne_measured += r.acne_measured;
    abs_sum += r.abs_sum;
    sq_sum += r.sq_sum;
    signed_sum += r.signed_sum;
    gap_sum += r.gap_sum;
    gap_max = std::max(gap_max, r.gap_max);
    gaps.insert(gaps.end(), r.gaps.begin(), r.gaps.end());
    acne_sum += r.acne_sum;
    acne_max = std::max(acne_max, r.acne_max);
}

void fill_score(const RowSums& t, const ScoringOptions& opt, LightScore& s) {
    s.pixels = t.pixels;
    s.counts = t.counts;
    s.counts_visible = t.counts_visible;
    for (auto c : t.counts) s.wrong += c;
    for (auto c : t.counts_visible) s.wrong_visible += c;
    if (t.pixels.scored > 0) {
        const double scored = static_cast<double>(t.pixels.scored);
        s.mae = t.abs_sum / scored;
        s.rmse = std::sqrt(t.sq_sum / scored);
        s.bias = t.signed_sum / scored;
        s.wrong_fraction = static_cast<double>(s.wrong) / scored;
    }
    const auto pp = s.count(PixelClass::peter_panning);
    s.peter_panning_gap = {pp ? t.gap_sum / pp : 0.0, t.gap_max};
    s.acne_depth = {t.acne_measured ? t.acne_sum / static_cast<double>(t.acne_measured) : 0.0, t.acne_max};
    s.acne_depth_pixels = t.acne_measured;
    if (opt.soft) {
        SoftScore& soft = s.soft.emplace();
        auto mean = [&](std::size_t k) {
            return t.region_pixels[k] ? t.region_abs[k] / static_cast<double>(t.region_pixels[k]) : 0.0;
        };
        soft.umbra_pixels = t.region_pixels[0];
        soft.penumbra_pixels = t.region_pixels[1];
        soft.lit_pixels = t.region_pixels[2];
        soft.umbra_mae = mean(0);
        soft.penumbra_mae = mean(1);
        soft.lit_mae = mean(2);
        soft.penumbra_mae_beyond_e =
            t.region_pixels[1] ? t.penumbra_excess / static_cast<double>(t.region_pixels[1]) : 0.0;
        soft.width_pixels_oracle = t.band_oracle;
        soft.width_pixels_raster = t.band_raster;
        soft.penumbra_width_error =
            t.band_oracle ? static_cast<double>(t.band_raster) / static_cast<double>(t.band_oracle) - 1.0 : 0.0;
    }
}

}  // namespace detail

}  // namespace penumbra::metrics
