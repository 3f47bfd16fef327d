// The one table of a light's metrics (docs/metrics.md, "The metrics table"): every number a
// light reports, with its dotted path, unit and meaning. Gates, report.json's light objects,
// report.html, JUnit and the CLI summary all read it, so adding a metric is one row here (plus
// computing it in LightScore).
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "metrics/classification.h"

namespace penumbra::metrics {

enum class Unit : std::uint8_t {
    pixels,      // a count of pixels
    fraction,    // of the light's scored pixels, in [0, 1]
    visibility,  // a difference of V (shadow factor, 1 lit), in [-1, 1]
    metres,      // world-space distance
    perceptual,  // the FLIP-style error, in [0, 1] (perceptual.h)
    relative,    // raster / oracle - 1
};
std::string_view to_string(Unit u);

// Which lights report a metric.
enum class MetricScope : std::uint8_t {
    every_light,
    area_lights,        // soft.*: lights scored with ScoringOptions::soft
    depth_map_lookups,  // needs the raster's lookup layer (Evidence::depth_map_lookups)
    camera_paths,       // temporal.*: a scenario with a camera_path (LightScore::temporal)
};
std::string_view to_string(MetricScope s);

struct Metric {
    std::string_view path;  // dotted path into a light's report.json object, e.g. "rates.acne"
    Unit unit;
    MetricScope scope;
    std::string_view meaning;           // one line
    double (*read)(const LightScore&);  // only where the scope applies: use value_of
};

// Every metric, in report order.
std::span<const Metric> metric_table();
// The row of `path`, or null.
const Metric* find_metric(std::string_view path);
// The metric's value for this light, or nullopt where its scope does not apply (soft.* for a
// punctual light, acne_depth without lookups).
std::optional<double> value_of(const Metric& m, const LightScore& s);

// The table as text: "path (unit): meaning" lines (scope added where not every light), each
// indented by `indent`, joined by newlines.
std::string metric_table_text(std::string_view indent = "  ");
// One row of docs/metrics.md's table: "| `path` | unit | scope | meaning |".
std::string metric_doc_row(const Metric& m);

// The light's numbers as report.json writes them (docs/design.md), less "index" and "type": every
// metric that applies at its dotted path (pixel counts as integers), and "evidence".
nlohmann::json to_json(const LightScore& s);

// The CLI's one line per light: "wrong 0.370% of 534728 scored px: acne 0.014%  ...", and the
// evidence when the classes rest on the oracle's geometry.
std::string summary_line(const LightScore& s);

// One line that reads a light's verdict for a person: the class with the most visible wrong
// pixels, its visible rate and what usually cures it ("acne 46.2% of scored pixels (visible):
// self-shadowing; add bias, or run `penumbra tune`"). nullopt when no class reaches
// kHintRate of the scored pixels visibly: nothing dominates enough to name.
inline constexpr double kHintRate = 0.01;

// What the run measured besides the classes, for the hint of missing shadows: its causes are
// named in order of what this run shows (docs/metrics.md, "Facing").
struct RunFacts {
    double seen_from_behind = 0;  // share of the frame whose ray met a single-sided back face first
    std::string culling;          // the shadow pass's culling where it culls casters ("back", "front", "material")
    std::string false_lit_cure;   // the family's own causes (raster::ScoringHints); empty: a shadow map's
};
inline constexpr double kFacingHintShare = 0.05;  // of the frame, seen from behind: named first
std::optional<std::string> reading_line(const LightScore& s, const RunFacts& facts = {});

}  // namespace penumbra::metrics
