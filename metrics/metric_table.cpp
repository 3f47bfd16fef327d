#include "metrics/metric_table.h"

#include <fmt/format.h>

#include <array>

namespace penumbra::metrics {

namespace {

using enum Unit;
using enum MetricScope;

double count_of(const LightScore& s, PixelClass c) {
    return static_cast<double>(s.count(c));
}

double visible_count_of(const LightScore& s, PixelClass c) {
    return static_cast<double>(s.count_visible(c));
}

// Soft metrics read s.soft, which value_of guarantees for their scope.
constexpr std::array kMetrics = {
    Metric{"pixels.surface", pixels, every_light, "the oracle's surface pixels (every bucket but background)",
           [](const LightScore& s) { return static_cast<double>(s.pixels.surface); }},
    Metric{"pixels.scored", pixels, every_light, "surface pixels that are scored: the denominator of every rate",
           [](const LightScore& s) { return static_cast<double>(s.pixels.scored); }},
    Metric{"pixels.back_facing", pixels, every_light,
           "surface pixels the light cannot reach (N.L <= 0, outside a spot cone): not scored",
           [](const LightScore& s) { return static_cast<double>(s.pixels.back_facing); }},
    Metric{"pixels.uncertain", pixels, every_light,
           "surface pixels whose truth is within float error of a boundary (U = 1): not scored",
           [](const LightScore& s) { return static_cast<double>(s.pixels.uncertain); }},
    Metric{"pixels.coverage_mismatch", pixels, every_light,
           "surface pixels where the raster camera saw another triangle or none: not scored",
           [](const LightScore& s) { return static_cast<double>(s.pixels.coverage_mismatch); }},
    Metric{"counts.acne", pixels, every_light, "wrong pixels classed acne",
           [](const LightScore& s) { return count_of(s, PixelClass::acne); }},
    Metric{"counts.peter_panning", pixels, every_light, "wrong pixels classed peter_panning",
           [](const LightScore& s) { return count_of(s, PixelClass::peter_panning); }},
    Metric{"counts.aliasing", pixels, every_light, "wrong pixels classed aliasing",
           [](const LightScore& s) { return count_of(s, PixelClass::aliasing); }},
    Metric{"counts.false_shadow", pixels, every_light, "wrong pixels classed false_shadow",
           [](const LightScore& s) { return count_of(s, PixelClass::false_shadow); }},
    Metric{"counts.false_lit", pixels, every_light, "wrong pixels classed false_lit",
           [](const LightScore& s) { return count_of(s, PixelClass::false_lit); }},
    Metric{"counts.light_bleeding", pixels, every_light, "wrong pixels classed light_bleeding",
           [](const LightScore& s) { return count_of(s, PixelClass::light_bleeding); }},
    Metric{"rates.acne", fraction, every_light, "acne pixels / scored pixels",
           [](const LightScore& s) { return s.rate(PixelClass::acne); }},
    Metric{"rates.peter_panning", fraction, every_light, "peter_panning pixels / scored pixels",
           [](const LightScore& s) { return s.rate(PixelClass::peter_panning); }},
    Metric{"rates.aliasing", fraction, every_light, "aliasing pixels / scored pixels",
           [](const LightScore& s) { return s.rate(PixelClass::aliasing); }},
    Metric{"rates.false_shadow", fraction, every_light, "false_shadow pixels / scored pixels",
           [](const LightScore& s) { return s.rate(PixelClass::false_shadow); }},
    Metric{"rates.false_lit", fraction, every_light, "false_lit pixels / scored pixels",
           [](const LightScore& s) { return s.rate(PixelClass::false_lit); }},
    Metric{"rates.light_bleeding", fraction, every_light, "light_bleeding pixels / scored pixels",
           [](const LightScore& s) { return s.rate(PixelClass::light_bleeding); }},
    Metric{"counts_visible.acne", pixels, every_light, "acne pixels whose |error| reaches the visible threshold",
           [](const LightScore& s) { return visible_count_of(s, PixelClass::acne); }},
    Metric{"counts_visible.peter_panning", pixels, every_light,
           "peter_panning pixels whose |error| reaches the visible threshold",
           [](const LightScore& s) { return visible_count_of(s, PixelClass::peter_panning); }},
    Metric{"counts_visible.aliasing", pixels, every_light,
           "aliasing pixels whose |error| reaches the visible threshold",
           [](const LightScore& s) { return visible_count_of(s, PixelClass::aliasing); }},
    Metric{"counts_visible.false_shadow", pixels, every_light,
           "false_shadow pixels whose |error| reaches the visible threshold",
           [](const LightScore& s) { return visible_count_of(s, PixelClass::false_shadow); }},
    Metric{"counts_visible.false_lit", pixels, every_light,
           "false_lit pixels whose |error| reaches the visible threshold",
           [](const LightScore& s) { return visible_count_of(s, PixelClass::false_lit); }},
    Metric{"counts_visible.light_bleeding", pixels, every_light,
           "light_bleeding pixels whose |error| reaches the visible threshold",
           [](const LightScore& s) { return visible_count_of(s, PixelClass::light_bleeding); }},
    Metric{"rates_visible.acne", fraction, every_light, "visible acne pixels / scored pixels",
           [](const LightScore& s) { return s.rate_visible(PixelClass::acne); }},
    Metric{"rates_visible.peter_panning", fraction, every_light, "visible peter_panning pixels / scored pixels",
           [](const LightScore& s) { return s.rate_visible(PixelClass::peter_panning); }},
    Metric{"rates_visible.aliasing", fraction, every_light, "visible aliasing pixels / scored pixels",
           [](const LightScore& s) { return s.rate_visible(PixelClass::aliasing); }},
    Metric{"rates_visible.false_shadow", fraction, every_light, "visible false_shadow pixels / scored pixels",
           [](const LightScore& s) { return s.rate_visible(PixelClass::false_shadow); }},
    Metric{"rates_visible.false_lit", fraction, every_light, "visible false_lit pixels / scored pixels",
           [](const LightScore& s) { return s.rate_visible(PixelClass::false_lit); }},
    Metric{"rates_visible.light_bleeding", fraction, every_light, "visible light_bleeding pixels / scored pixels",
           [](const LightScore& s) { return s.rate_visible(PixelClass::light_bleeding); }},
    Metric{"wrong", pixels, every_light, "wrong pixels: |V_raster - V_oracle| > tolerance + E",
           [](const LightScore& s) { return static_cast<double>(s.wrong); }},
    Metric{"wrong_visible", pixels, every_light, "wrong pixels whose |error| reaches the visible threshold",
           [](const LightScore& s) { return static_cast<double>(s.wrong_visible); }},
    Metric{"mae", visibility, every_light, "mean |V_raster - V_oracle| over scored pixels",
           [](const LightScore& s) { return s.mae; }},
    Metric{"rmse", visibility, every_light, "root-mean-square V_raster - V_oracle over scored pixels",
           [](const LightScore& s) { return s.rmse; }},
    Metric{"wrong_fraction", fraction, every_light, "wrong pixels / scored pixels",
           [](const LightScore& s) { return s.wrong_fraction; }},
    Metric{"bias", visibility, every_light, "mean V_raster - V_oracle over scored pixels (negative: too dark)",
           [](const LightScore& s) { return s.bias; }},
    Metric{"peter_panning_gap.mean", metres, every_light,
           "mean occluder_m of peter_panning pixels: how far their true occluder is",
           [](const LightScore& s) { return s.peter_panning_gap.mean; }},
    Metric{"peter_panning_gap.max", metres, every_light,
           "largest occluder_m of a peter_panning pixel (about the bias, for a pure world bias)",
           [](const LightScore& s) { return s.peter_panning_gap.max; }},
    Metric{"peter_panning_gap.p95", metres, every_light,
           "95th percentile of that distance over peter-panning pixels (nearest rank)",
           [](const LightScore& s) { return s.peter_panning_gap_p95; }},
    Metric{"acne_depth.mean", metres, depth_map_lookups,
           "mean depth an acne pixel's biased receiver lies behind its own surface in the centre texel, over "
           "acne_depth.pixels",
           [](const LightScore& s) { return s.acne_depth.mean; }},
    Metric{"acne_depth.max", metres, depth_map_lookups,
           "largest such depth: the extra bias the centre texels need (filter taps may need more)",
           [](const LightScore& s) { return s.acne_depth.max; }},
    Metric{"acne_depth.pixels", pixels, depth_map_lookups,
           "acne pixels whose centre texel holds the receiver behind; the rest were darkened by filter taps "
           "whose depths are not recorded",
           [](const LightScore& s) { return static_cast<double>(s.acne_depth_pixels); }},
    Metric{"perceptual.mean", perceptual, every_light, "mean FLIP-style error over surface pixels",
           [](const LightScore& s) { return s.perceptual.mean; }},
    Metric{"perceptual.max", perceptual, every_light, "largest FLIP-style error of a surface pixel",
           [](const LightScore& s) { return s.perceptual.max; }},
    Metric{"soft.pixels.umbra", pixels, area_lights, "scored pixels in the oracle's umbra (V <= tolerance + E)",
           [](const LightScore& s) { return static_cast<double>(s.soft->umbra_pixels); }},
    Metric{"soft.pixels.penumbra", pixels, area_lights, "scored pixels in the oracle's penumbra (between)",
           [](const LightScore& s) { return static_cast<double>(s.soft->penumbra_pixels); }},
    Metric{"soft.pixels.lit", pixels, area_lights, "scored pixels in the oracle's lit region (V >= 1 - tolerance - E)",
           [](const LightScore& s) { return static_cast<double>(s.soft->lit_pixels); }},
    Metric{"soft.penumbra_mae", visibility, area_lights, "mean |error| over the true penumbra",
           [](const LightScore& s) { return s.soft->penumbra_mae; }},
    Metric{"soft.penumbra_mae_beyond_E", visibility, area_lights,
           "mean max(0, |error| - E) over the true penumbra: what the oracle's noise cannot cause",
           [](const LightScore& s) { return s.soft->penumbra_mae_beyond_e; }},
    Metric{"soft.umbra_mae", visibility, area_lights, "mean |error| over the true umbra",
           [](const LightScore& s) { return s.soft->umbra_mae; }},
    Metric{"soft.lit_mae", visibility, area_lights, "mean |error| over the truly lit region",
           [](const LightScore& s) { return s.soft->lit_mae; }},
    Metric{"soft.penumbra_width_error", relative, area_lights,
           "penumbra width, raster / oracle - 1 (pixels with V in (0.05, 0.95)); -1: hard shadows",
           [](const LightScore& s) { return s.soft->penumbra_width_error; }},
    Metric{"soft.width_band_pixels.oracle", pixels, area_lights, "the oracle's pixels with V in (0.05, 0.95)",
           [](const LightScore& s) { return static_cast<double>(s.soft->width_pixels_oracle); }},
    Metric{"soft.width_band_pixels.raster", pixels, area_lights, "the raster's pixels with V in (0.05, 0.95)",
           [](const LightScore& s) { return static_cast<double>(s.soft->width_pixels_raster); }},
    Metric{"temporal.flicker_rate", fraction, camera_paths,
           "flickering points / points seen in two consecutive frames, over the whole path (not of scored pixels)",
           [](const LightScore& s) { return s.temporal->flicker_rate; }},
    Metric{"temporal.flicker_pixels", pixels, camera_paths,
           "points whose raster V changed between two frames while the truth did not, summed over the pairs",
           [](const LightScore& s) { return static_cast<double>(s.temporal->flicker_pixels); }},
    Metric{"temporal.points", pixels, camera_paths,
           "surface points seen in both frames of a pair, summed over the pairs",
           [](const LightScore& s) { return static_cast<double>(s.temporal->points); }},
};

}  // namespace

std::string_view to_string(Unit u) {
    switch (u) {
        case pixels: return "pixels";
        case fraction: return "fraction";
        case visibility: return "visibility";
        case metres: return "metres";
        case perceptual: return "perceptual";
        case relative: return "relative";
    }
    return "?";
}

std::string_view to_string(MetricScope s) {
    switch (s) {
        case every_light: return "every light";
        case area_lights: return "area lights";
        case depth_map_lookups: return "depth-map lookups";
        case camera_paths: return "camera paths";
    }
    return "?";
}

std::span<const Metric> metric_table() {
    return kMetrics;
}

const Metric* find_metric(std::string_view path) {
    for (const Metric& m : kMetrics)
        if (m.path == path) return &m;
    return nullptr;
}

std::optional<double> value_of(const Metric& m, const LightScore& s) {
    switch (m.scope) {
        case every_light: break;
        case area_lights:
            if (!s.soft) return std::nullopt;
            break;
        case depth_map_lookups:
            if (s.evidence.source != Evidence::depth_map_lookups) return std::nullopt;
            break;
        case camera_paths:
            if (!s.temporal) return std::nullopt;
            break;
    }
    return m.read(s);
}

std::string metric_table_text(std::string_view indent) {
    std::string text;
    for (const Metric& m : kMetrics) {
        text += fmt::format("{}{} ({}", indent, m.path, to_string(m.unit));
        if (m.scope != every_light) text += fmt::format(", {} only", to_string(m.scope));
        text += fmt::format("): {}", m.meaning);
        if (&m != &kMetrics.back()) text += '\n';
    }
    return text;
}

std::string metric_doc_row(const Metric& m) {
    return fmt::format("| `{}` | {} | {} | {} |", m.path, to_string(m.unit), to_string(m.scope), m.meaning);
}

nlohmann::json to_json(const LightScore& s) {
    nlohmann::json j = nlohmann::json::object();
    for (const Metric& m : kMetrics) {
        const std::optional<double> v = value_of(m, s);
        if (!v) continue;
        std::string pointer(1, '/');
        for (char c : m.path) pointer.push_back(c == '.' ? '/' : c);
        j[nlohmann::json::json_pointer(pointer)] =
            m.unit == pixels ? nlohmann::json(static_cast<std::uint64_t>(*v)) : nlohmann::json(*v);
    }
    nlohmann::json evidence = {{"source", to_string(s.evidence.source)}};
    if (s.evidence.source == Evidence::oracle_geometry) {
        evidence["texel_footprint_m"] = s.evidence.texel_footprint_m;
        evidence["texel_footprint"] = to_string(s.evidence.texel_footprint_source);
        evidence["bias_reach_m"] = s.evidence.bias_reach_m;
        evidence["bias_reach"] = to_string(s.evidence.bias_reach_source);
    }
    j["evidence"] = std::move(evidence);
    return j;
}

std::optional<std::string> reading_line(const LightScore& s, const RunFacts& facts) {
    PixelClass top = PixelClass::correct;
    std::uint64_t most = 0;
    for (PixelClass c : kErrorClasses)
        if (s.count_visible(c) > most) {
            most = s.count_visible(c);
            top = c;
        }
    if (most == 0 || s.rate_visible(top) < kHintRate) return std::nullopt;
    std::string cure;
    switch (top) {
        case PixelClass::acne: cure = "self-shadowing; add bias, or run `penumbra tune`"; break;
        case PixelClass::peter_panning:
            cure = "shadows pulled off their casters by too much bias; lower it, or run `penumbra tune`";
            break;
        case PixelClass::aliasing:
            cure = "along shadow edges; raise the resolution, fit the map tighter or filter";
            break;
        case PixelClass::false_shadow:
            cure = "shadow where nothing occludes (outside the map, clipped or culled receivers); check the fit";
            break;
        case PixelClass::light_bleeding:
            cure = "light leaking through stacked occluders in the moment map; raise the light-bleed reduction";
            break;
        default:
            if (facts.seen_from_behind < kFacingHintShare) {
                cure = !facts.false_lit_cure.empty()
                           ? "shadows missing: " + facts.false_lit_cure
                           : "shadows missing (casters clipped, culled or outside the map); check the fit and culling";
                break;
            }
            // What this run measured comes first: geometry seen from behind (which a culling
            // shadow pass may drop as casters), then culling, then the fit.
            cure = fmt::format(
                "shadows missing; the likely causes, in order: {:.0f}% of the frame meets the back of single-sided "
                "triangles (inverted winding or open meshes, named in the warnings){}; {}",
                100.0 * facts.seen_from_behind,
                facts.culling.empty()
                    ? ""
                    : fmt::format(", which a shadow pass culling {} drops as casters",
                                  facts.culling == "material" ? "by material" : facts.culling + " faces"),
                facts.false_lit_cure.empty() ? "culling; casters clipped or outside the map (check the fit)"
                                             : facts.false_lit_cure);
            break;
    }
    return fmt::format("{} {:.1f}% of scored pixels (visible): {}", to_string(top), 100.0 * s.rate_visible(top), cure);
}

std::string summary_line(const LightScore& s) {
    // The visible rates first, as gates, hints and tune read them (issue #53), every wrong pixel
    // beside them; light_bleeding only where it occurs (a depth-map family never has it).
    std::string classes;
    for (PixelClass c : kErrorClasses)
        if (c != PixelClass::light_bleeding || s.count(c))
            classes +=
                fmt::format("{} {:.3f}% ({:.3f}%)  ", to_string(c), 100.0 * s.rate_visible(c), 100.0 * s.rate(c));
    const double scored = std::max<double>(1.0, static_cast<double>(s.pixels.scored));
    std::string line = fmt::format("wrong {:.3f}% visible ({:.3f}% in all) of {} scored px: {}",
                                   100.0 * static_cast<double>(s.wrong_visible) / scored, 100.0 * s.wrong_fraction,
                                   s.pixels.scored, classes);
    if (s.evidence.source == Evidence::oracle_geometry)
        line += fmt::format("(V only: footprint {:.4g} m {}, bias reach {:.4g} m {})", s.evidence.texel_footprint_m,
                            to_string(s.evidence.texel_footprint_source), s.evidence.bias_reach_m,
                            to_string(s.evidence.bias_reach_source));
    return line;
}

}  // namespace penumbra::metrics
