// penumbra tune: the bias that removes acne with the least peter-panning, found against the
// oracle (docs/tune.md). The search uses the structure of the problem: each bias knob trades
// acne (falling as the knob grows) for peter-panning (growing), so the least feasible value of a
// knob is found by bisection, and a mix of knobs by trading one for another along the boundary
// of the feasible set.
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/scenario.h"
#include "metrics/classification.h"
#include "pipeline/validate.h"
#include "raster/knobs.h"
#include "raster/raster.h"
#include "raster/technique.h"
#include "raster/vulkan_context.h"

namespace penumbra::metrics {
class GpuScorer;  // metrics/gpu_classification.h
}

namespace penumbra::tune {

// The knobs tune searches: the declarations (raster/knobs.h) of the technique family's knobs that
// --knobs names, in the order it names them. tune reads a knob's range, unit, scale and value
// through its declaration alone (docs/tune.md, "Knobs").
class KnobSet {
  public:
    KnobSet() = default;
    explicit KnobSet(std::vector<raster::KnobDecl> knobs) : knobs_(std::move(knobs)) {}
    std::size_t size() const { return knobs_.size(); }
    bool empty() const { return knobs_.empty(); }
    const raster::KnobDecl& operator[](std::size_t i) const { return knobs_[i]; }
    auto begin() const { return knobs_.begin(); }
    auto end() const { return knobs_.end(); }
    // The position of the knob called `name`, if the set has it.
    std::optional<std::size_t> index(std::string_view name) const;
    // Whether some knob is the technique's rather than a light's (a moment family's): then one
    // value is searched for every light.
    bool has_technique_knob() const;

  private:
    std::vector<raster::KnobDecl> knobs_;
};

// "constant,slope": the names, checked against every registered family's knobs. An unknown or
// repeated name, or a list with no knob that adds bias (or a moment family's), is InputError
// naming `option` and the name.
std::vector<std::string> parse_knobs(const std::string& list, const std::string& option);
// The knobs of the technique's family that `names` name, in that order: a knob the family does
// not declare is InputError naming `option` ("constant is not a knob of technique family \"vsm\"
// (its knobs: vsm.min_variance, vsm.light_bleed)"): a family without depth-map biases has nothing
// for it to move.
KnobSet knob_set(const raster::Technique& technique, std::span<const std::string> names,
                 const std::string& option = "--knobs");
// The knobs tune searches when --knobs is not given, as parse_knobs reads them: those the family
// declares by_default ("constant,slope" for the depth map's biases, a moment family's own), or
// the default family's when it declares none.
std::string default_knobs(const raster::Technique& technique);

// One point of the search: a value per knob of the KnobSet, in its order and in the knob's unit
// (an on/off knob's 0 or 1): constant in the format's r, slope as Vulkan's factor, clamp in depth
// units, world in texel footprints (the reference footprint), normal_offset in texels, …
struct Setting {
    std::vector<double> value;
    Setting() = default;
    explicit Setting(std::size_t knobs) : value(knobs, 0.0) {}
    double& operator[](std::size_t i) { return value[i]; }
    double operator[](std::size_t i) const { return value[i]; }
    bool operator==(const Setting&) const = default;
};

// "constant=1.55e+04 slope=3.05 receiver_plane=true": the tuned knobs' values, for people.
std::string describe(const Setting& s, const KnobSet& knobs);

// The technique `base` with the tuned knobs of `s` in place for every light (the others are
// base's own; per-light overrides of the tuned knobs are dropped).
raster::Technique apply_setting(const raster::Technique& base, const KnobSet& knobs, const Setting& s,
                                double footprint_m);
// The technique `base` with light i's tuned knobs set to `per_light[i]` in its override.
raster::Technique apply_settings(const raster::Technique& base, const KnobSet& knobs,
                                 std::span<const Setting> per_light, double footprint_m);
// The tuned knobs of a bias, as a setting (a knob in footprints counted in `footprint_m`); the
// knobs of the technique are `technique`'s (0 without it).
Setting setting_of(const raster::Bias& bias, const KnobSet& knobs, double footprint_m,
                   const raster::Technique* technique = nullptr);

// The default objective: visible acne plus visible peter-panning per scored pixel, the error the
// bias controls (docs/tune.md, "Objective"). Under it the acne cap is on visible acne.
inline constexpr const char* kVisibleBiasError = "visible_bias_error";
// Visible acne and visible peter-panning of one light, per scored pixel: pixels of the class
// whose |error| reaches the scoring's visible threshold (--visible-threshold, docs/metrics.md).
// A moment family's knobs trade acne for light bleeding instead: it counts too (0 for the others).
struct VisibleBiasError {
    double acne = 0, peter_panning = 0, light_bleeding = 0;
    double sum() const { return acne + peter_panning + light_bleeding; }
    // "visible acne + peter-panning", and " + light bleeding" when either counted some.
    static std::string label(const VisibleBiasError& a, const VisibleBiasError& b) {
        return a.light_bleeding > 0 || b.light_bleeding > 0 ? "visible acne + peter-panning + light bleeding"
                                                            : "visible acne + peter-panning";
    }
};
VisibleBiasError visible_bias_error(const metrics::LightScore& ls);

// What is minimised, subject to acne <= max_acne on every scenario and light (docs/tune.md,
// "Objective"). Metric paths are rows of metrics/metric_table.h; both are pooled over every
// scenario and light, weighted by scored pixels.
struct Objective {
    double max_acne = 0.001;                   // a cap: the acne rate no light may exceed (visible acne by default)
    std::string minimize = kVisibleBiasError;  // kVisibleBiasError or a metric path
    std::string then = "peter_panning_gap.p95";
    double tie = 0.01;  // relative: values of `minimize` within 1% are a tie; then `then`, then the smaller bias
    bool visible() const { return minimize == kVisibleBiasError; }
    // Whether the objective only grows with the bias (peter-panning metrics): then the least
    // feasible bias is the optimum and the search need not look past it.
    bool grows_with_bias() const;
};

struct LightOutcome {
    std::size_t scenario = 0, light = 0;
    double acne = 0;  // what the cap applies to: visible acne under kVisibleBiasError, else rates.acne
    double minimized = 0, then = 0;
    double acne_rate = 0;  // rates.acne
    VisibleBiasError visible;
    std::uint64_t scored = 0;
};

struct Evaluation {
    Setting setting;
    std::vector<LightOutcome> lights;
    double worst_acne = 0;  // the largest acne rate over scenarios and lights
    double minimized = 0, then = 0;
    bool feasible = false;
    VisibleBiasError visible;          // pooled over scenarios and lights, weighted by scored pixels
    double seconds = 0;                // wall clock: renders and counts
    double render_s = 0, count_s = 0;  // of which the renders (with read-back) and the counts
};

struct TuneOptions {
    KnobSet knobs = knob_set(raster::Technique{}, std::vector<std::string>{"constant", "slope"});
    Objective objective;
    int budget = 80;          // most evaluations
    double precision = 0.05;  // bisection stops when the bracket's ratio is below 1 + precision
    // What an evaluation reads back (docs/tune.md, "Evidence"): the depth-map lookups the classes
    // rest on (true), or V alone, classified from the oracle's geometry with each light's texel
    // footprint from one lookup render at the start (false: several times faster on GPUs, where
    // reading back the lookups is most of a render).
    bool lookups = true;
    // One bias for every light (true), or each light's own (false: searched light by light,
    // each light's outcome depending only on its own bias).
    bool shared_bias = false;
    ValidateOptions validate;  // the oracle's settings and cache, tau, device
    // Called after each evaluation with its index (progress on a terminal).
    std::function<void(const Evaluation&, std::size_t)> progress;
};

// One scenario ready to be evaluated: its oracle (cache) and warm raster session, made once.
struct TuneScene {
    const Scenario* scenario = nullptr;
    std::shared_ptr<const OracleRun> oracle;
    std::unique_ptr<raster::RasterSession> session;
    std::vector<metrics::ScoringOptions> scoring;  // perceptual off: the objective needs counts only
    // The counts on the GPU (metrics/gpu_classification.h), where they win on this device;
    // made on the first evaluation that can use it, dropped when a render cannot.
    std::shared_ptr<metrics::GpuScorer> scorer;
    bool cpu_only = false;
};

// Evaluates settings on every scene: a warm render with lookups and the objective's counts; no
// images, no report.
class Evaluator {
  public:
    Evaluator(std::span<const Scenario> scenarios, const raster::Technique& base, const TuneOptions& options,
              const raster::VulkanContext& ctx);
    Evaluation evaluate(const Setting& s);
    // The same for a whole technique (the start), labelled with `s`.
    Evaluation evaluate(const raster::Technique& technique, const Setting& s);
    // The most lights any scenario has.
    std::size_t light_count() const;
    double footprint_m() const { return footprint_m_; }  // the reference footprint (world knob's unit)
    const raster::Technique& base() const { return base_; }
    const KnobSet& knobs() const { return options_.knobs; }
    // The scenes with their oracle and warm session, for re-validating on the same ones.
    std::span<TuneScene> scenes() { return scenes_; }

  private:
    raster::Technique base_;
    const TuneOptions& options_;
    std::vector<TuneScene> scenes_;
    double footprint_m_ = 0;
    const raster::VulkanContext* ctx_ = nullptr;
    bool gpu_scoring_ = false;  // metrics::preferred_scorer
};

// Lexicographic: feasible first; then `minimize` (ties within objective.tie), `then`, and the
// smaller bias. True when a is better than b.
bool better(const Evaluation& a, const Evaluation& b, const KnobSet& knobs, const Objective& objective);

struct TuneResult {
    std::vector<Evaluation> evaluations;  // in the order they were made
    std::optional<std::size_t> winner;    // the best feasible evaluation; none when nothing was feasible
    std::size_t best_reachable = 0;       // the least worst_acne (when nothing was feasible)
    std::vector<std::size_t> front;       // Pareto front of (worst_acne, minimized), by worst_acne
    std::optional<std::size_t> start;     // the starting technique's evaluation, when it was given
    // The start is kept (for this light, or for all with a shared bias): the search's best was
    // worse than it (docs/tune.md, "Never worse than the start"); `why` says how.
    bool kept_start = false;
    std::string why;
    raster::Technique recommended;  // the chosen technique
    double footprint_m = 0;
    bool budget_exhausted = false;
    // Per-light mode: one search per light (light i: per_light[i], its evaluations that light's
    // outcomes); `evaluations` are then the renders they shared.
    std::vector<TuneResult> per_light;

    // The chosen evaluation: the start when kept, else the winner, else the best reachable.
    std::size_t chosen() const { return kept_start && start ? *start : winner ? *winner : best_reachable; }
};

// Keeps the start for the lights `worse` names (light index, why), found worse at re-validation:
// their bias becomes the start's in r.recommended (all of it with a shared bias).
void keep_start(TuneResult& r, const raster::Technique& start, const TuneOptions& options,
                std::span<const std::pair<std::size_t, std::string>> worse);

// Why `after` is worse than `before` on some light (visible acne + peter-panning, per light);
// empty when it is not.
std::string worse_than(const Evaluation& after, const Evaluation& before);

// What the search evaluates a setting with: Evaluator::evaluate, or a function in the tests.
using EvaluateFn = std::function<Evaluation(const Setting&)>;

// The search (docs/tune.md, "Search") over `evaluate`, within options.budget, once for each
// combination of the on/off knobs' values. Deterministic: the same inputs give the same
// evaluations in the same order. Fills evaluations, winner, front; not recommended. `start`, when
// given, is the starting technique's evaluation: it goes first, and the result keeps it
// (kept_start) when the best found is worse on some light.
TuneResult search(const EvaluateFn& evaluate, const TuneOptions& options, const Evaluation* start = nullptr);

// The same objective over an exhaustive grid of `levels` values per knob on a log scale (off,
// then levels - 1 log-spaced over the range), for the benchmark.
TuneResult grid(const EvaluateFn& evaluate, const TuneOptions& options, int levels);

// The search on real scenarios: search() over the evaluator, and the recommended technique.
TuneResult tune(Evaluator& ev, const TuneOptions& options);
// The same with an evaluator made for the call.
TuneResult tune(std::span<const Scenario> scenarios, const raster::Technique& base, const TuneOptions& options,
                const raster::VulkanContext& ctx);
TuneResult grid_search(std::span<const Scenario> scenarios, const raster::Technique& base, const TuneOptions& options,
                       const raster::VulkanContext& ctx, int levels);

// The median of `v` over surface pixels (A != 0), finite values only (and positive ones only
// when asked); 0 when there are none.
double median_at_surface(const std::vector<float>& v, const std::vector<float>& A, bool positive);

// Pareto front and winner of a list of evaluations.
void rank(TuneResult& r, const KnobSet& knobs, const Objective& objective);

}  // namespace penumbra::tune
