#include "tune/tune.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "common/errors.h"
#include "common/stopwatch.h"
#include "metrics/gpu_classification.h"
#include "metrics/metric_table.h"
#include "raster/technique_family.h"

namespace penumbra::tune {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

bool is_continuous(const raster::KnobDecl& k) {
    return k.scale == raster::KnobScale::log;
}
// A knob that cures acne by growing (not the clamp, not a switch).
bool adds_bias(const raster::KnobDecl& k) {
    return is_continuous(k) && !k.caps;
}

// A knob's place on its log scale, growing with the bias it adds: "off" is -inf for the
// additive knobs and +inf for a cap (the clamp: 0 = unclamped, the most bias).
double position(const raster::KnobDecl& k, double v) {
    if (v <= 0) return k.caps ? kInf : -kInf;
    return std::log10(v);
}
double value_at(const raster::KnobDecl& k, double pos) {
    if (k.caps) return pos >= std::log10(k.upper) + 1e-9 ? 0.0 : std::pow(10.0, std::max(pos, std::log10(k.lower)));
    if (pos < std::log10(k.lower) - 1e-9) return 0.0;
    return std::pow(10.0, std::min(pos, std::log10(k.upper)));
}

// How much bias a setting adds, for ties: each knob's position in [0, 1] of its range (off: 0;
// unclamped: 1), summed.
double bias_size(const Setting& s, const KnobSet& knobs) {
    double sum = 0;
    for (std::size_t i = 0; i < knobs.size(); ++i) {
        const raster::KnobDecl& k = knobs[i];
        if (!is_continuous(k)) continue;
        const double p = position(k, s[i]);
        if (std::isinf(p)) {
            sum += p > 0 ? 1.0 : 0.0;
            continue;
        }
        sum += 1e-3 + (p - std::log10(k.lower)) / (std::log10(k.upper) - std::log10(k.lower));
    }
    return sum;
}

const metrics::Metric& metric_named(const std::string& path, const char* option) {
    const metrics::Metric* m = metrics::find_metric(path);
    if (!m) throw InputError(fmt::format("{}: no metric \"{}\" (see docs/metrics.md for the paths)", option, path));
    return *m;
}

// The objective's value for one light: kVisibleBiasError, or a metric path.
double objective_value(const metrics::Metric* m, const metrics::LightScore& ls, const VisibleBiasError& visible) {
    return m ? metrics::value_of(*m, ls).value_or(0.0) : visible.sum();
}

// Pools an evaluation's light outcomes: worst acne, and the objective, its tie-break and the
// visible error weighted by scored pixels.
void pool(Evaluation& e, const Objective& objective) {
    double pooled_min = 0, pooled_then = 0, vis_acne = 0, vis_pp = 0, vis_lb = 0, scored_total = 0;
    e.worst_acne = 0;
    for (const LightOutcome& o : e.lights) {
        const double w = static_cast<double>(o.scored);
        e.worst_acne = std::max(e.worst_acne, o.acne);
        pooled_min += o.minimized * w;
        pooled_then += o.then * w;
        vis_acne += o.visible.acne * w;
        vis_pp += o.visible.peter_panning * w;
        vis_lb += o.visible.light_bleeding * w;
        scored_total += w;
    }
    if (scored_total > 0) {
        e.minimized = pooled_min / scored_total;
        e.then = pooled_then / scored_total;
        e.visible = {vis_acne / scored_total, vis_pp / scored_total, vis_lb / scored_total};
    }
    e.feasible = e.worst_acne <= objective.max_acne;
}

// An evaluation of every light seen as light `light`'s alone (its outcomes on every scenario).
Evaluation project(const Evaluation& all, std::size_t light, const Objective& objective) {
    Evaluation e;
    e.setting = all.setting;
    e.seconds = all.seconds;
    e.render_s = all.render_s;
    e.count_s = all.count_s;
    for (const LightOutcome& o : all.lights)
        if (o.light == light) e.lights.push_back(o);
    pool(e, objective);
    return e;
}

// Writes the tuned knobs of `b` into a light's override.
void set_override(raster::BiasOverride& o, const raster::Bias& b, const KnobSet& knobs) {
    for (const raster::KnobDecl& k : knobs)
        if (k.scope == raster::KnobScope::light) k.set_override(o, &b);  // a technique's knob is never a light's
}

void apply_to_bias(raster::Bias& b, const KnobSet& knobs, const Setting& s, double footprint_m) {
    for (std::size_t i = 0; i < knobs.size(); ++i)
        if (knobs[i].scope == raster::KnobScope::light) knobs[i].write_bias(b, s[i], footprint_m);
}

// The technique's knobs of `s` into `t` (its family's parameters).
void apply_to_technique(raster::Technique& t, const KnobSet& knobs, const Setting& s) {
    for (std::size_t i = 0; i < knobs.size(); ++i)
        if (knobs[i].scope == raster::KnobScope::technique) knobs[i].write(t, s[i]);
}

// An invariant, not input: a setting holds a value for each knob of its set.
void check_size(const Setting& s, const KnobSet& knobs) {
    if (s.value.size() != knobs.size())
        throw std::logic_error(fmt::format("tune: a setting of {} values for {} knobs", s.value.size(), knobs.size()));
}

// "a, b, c", or with `last` before the last name: "a, b or c".
std::string join(const std::vector<std::string>& names, const char* sep = ", ", const char* last = nullptr) {
    std::string text;
    for (std::size_t i = 0; i < names.size(); ++i)
        text += (i == 0 ? "" : i + 1 == names.size() && last ? last : sep) + names[i];
    return text;
}

// Every registered family's knob of each name, the first declared (they agree on what the
// name means: a range and whether it adds bias).
std::vector<const raster::KnobDecl*> known_knobs() {
    std::vector<const raster::KnobDecl*> known;
    for (const raster::FamilyEntry& f : raster::technique_families())
        for (const raster::KnobDecl& k : f.knobs)
            if (std::none_of(known.begin(), known.end(), [&](const raster::KnobDecl* x) { return x->name == k.name; }))
                known.push_back(&k);
    return known;
}

// The names of the knobs of `known` that `keep` keeps: the default family's, and the others'.
template <typename Keep>
std::pair<std::vector<std::string>, std::vector<std::string>> by_default_family(
    const std::vector<const raster::KnobDecl*>& known, Keep keep) {
    const raster::FamilyEntry* def = raster::find_technique_family(raster::kDefaultFamily);
    std::pair<std::vector<std::string>, std::vector<std::string>> names;
    for (const raster::KnobDecl* k : known) {
        if (!keep(*k)) continue;
        const bool own = def && std::any_of(def->knobs.begin(), def->knobs.end(),
                                            [&](const raster::KnobDecl& d) { return d.name == k->name; });
        (own ? names.first : names.second).push_back(k->name);
    }
    return names;
}

}  // namespace

std::optional<std::size_t> KnobSet::index(std::string_view name) const {
    for (std::size_t i = 0; i < knobs_.size(); ++i)
        if (knobs_[i].name == name) return i;
    return std::nullopt;
}

bool KnobSet::has_technique_knob() const {
    return std::any_of(knobs_.begin(), knobs_.end(),
                       [](const raster::KnobDecl& k) { return k.scope == raster::KnobScope::technique; });
}

KnobSet knob_set(const raster::Technique& technique, std::span<const std::string> names, const std::string& option) {
    const raster::FamilyEntry& family = raster::family_of(technique);
    std::vector<raster::KnobDecl> chosen;
    for (const std::string& name : names) {
        auto it = std::find_if(family.knobs.begin(), family.knobs.end(),
                               [&](const raster::KnobDecl& k) { return k.name == name; });
        if (it != family.knobs.end()) {
            chosen.push_back(*it);
            continue;
        }
        std::vector<std::string> keys;
        for (const raster::KnobDecl& k : family.knobs) keys.push_back(k.key);
        throw InputError(fmt::format("{}: {} is not a knob of technique family \"{}\" (its knobs: {})", option, name,
                                     family.name, keys.empty() ? "none" : join(keys)));
    }
    return KnobSet(std::move(chosen));
}

std::string default_knobs(const raster::Technique& technique) {
    auto defaults = [](const raster::FamilyEntry& family) {
        std::vector<std::string> names;
        for (const raster::KnobDecl& k : family.knobs)
            if (k.by_default) names.push_back(k.name);
        return names;
    };
    std::vector<std::string> names = defaults(raster::family_of(technique));
    if (names.empty()) names = defaults(*raster::find_technique_family(raster::kDefaultFamily));
    return join(names, ",");
}

std::string describe(const Setting& s, const KnobSet& knobs) {
    check_size(s, knobs);
    std::string text;
    for (std::size_t i = 0; i < knobs.size(); ++i) {
        if (!text.empty()) text += " ";
        text += is_continuous(knobs[i]) ? fmt::format("{}={:.4g}", knobs[i].name, s[i])
                                        : fmt::format("{}={}", knobs[i].name, s[i] != 0);
    }
    return text;
}

double median_at_surface(const std::vector<float>& v, const std::vector<float>& A, bool positive) {
    std::vector<float> x;
    for (std::size_t i = 0; i < v.size(); ++i)
        if (A[i] != 0 && std::isfinite(v[i]) && (!positive || v[i] > 0)) x.push_back(v[i]);
    if (x.empty()) return 0;
    std::nth_element(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(x.size() / 2), x.end());
    return x[x.size() / 2];
}

std::vector<std::string> parse_knobs(const std::string& list, const std::string& option) {
    const std::vector<const raster::KnobDecl*> known = known_knobs();
    std::vector<std::string> names;
    bool any_adds = false;
    std::size_t start = 0;
    while (start <= list.size()) {
        const std::size_t end = std::min(list.find(',', start), list.size());
        const std::string name = list.substr(start, end - start);
        auto it = std::find_if(known.begin(), known.end(), [&](const raster::KnobDecl* k) { return k->name == name; });
        if (it == known.end()) {
            const auto [own, others] = by_default_family(known, [](const raster::KnobDecl&) { return true; });
            throw InputError(fmt::format("{}: unknown knob \"{}\" (knobs: {}{}{})", option, name, join(own),
                                         others.empty() ? "" : "; other families': ", join(others)));
        }
        if (std::find(names.begin(), names.end(), name) != names.end())
            throw InputError(fmt::format("{}: knob \"{}\" is named twice", option, name));
        any_adds = any_adds || adds_bias(**it);
        names.push_back(name);
        start = end + 1;
    }
    if (!any_adds) {
        const auto [own, others] = by_default_family(known, adds_bias);
        throw InputError(fmt::format("{}: \"{}\" has no knob that adds bias ({}){}{}{}", option, list,
                                     join(own, ", ", " or "), others.empty() ? "" : " or another family's (",
                                     join(others), others.empty() ? "" : ")"));
    }
    return names;
}

raster::Technique apply_setting(const raster::Technique& base, const KnobSet& knobs, const Setting& s,
                                double footprint_m) {
    check_size(s, knobs);
    raster::Technique t = base;
    t.preset.clear();  // the tuned bias is no longer the preset's
    apply_to_bias(t.bias, knobs, s, footprint_m);
    apply_to_technique(t, knobs, s);
    // A light's own value of a tuned knob would win over the setting: the setting is for all.
    for (raster::LightOverride& l : t.lights)
        for (const raster::KnobDecl& k : knobs)
            if (k.scope == raster::KnobScope::light) k.set_override(l.bias, nullptr);
    return t;
}

raster::Technique apply_settings(const raster::Technique& base, const KnobSet& knobs,
                                 std::span<const Setting> per_light, double footprint_m) {
    raster::Technique t = base;
    t.preset.clear();
    if (t.lights.size() < per_light.size()) t.lights.resize(per_light.size());
    for (std::size_t li = 0; li < per_light.size(); ++li) {
        check_size(per_light[li], knobs);
        raster::Bias b = base.bias_for(li);
        apply_to_bias(b, knobs, per_light[li], footprint_m);
        set_override(t.lights[li].bias, b, knobs);
    }
    if (!per_light.empty()) apply_to_technique(t, knobs, per_light[0]);  // one value for all (tune() makes sure)
    return t;
}

Setting setting_of(const raster::Bias& b, const KnobSet& knobs, double footprint_m,
                   const raster::Technique* technique) {
    Setting s(knobs.size());
    for (std::size_t i = 0; i < knobs.size(); ++i) {
        const raster::KnobDecl& k = knobs[i];
        if (k.scope == raster::KnobScope::light)
            s[i] = k.read_bias(b, footprint_m);
        else
            s[i] = technique ? k.read(*technique) : 0.0;
    }
    return s;
}

VisibleBiasError visible_bias_error(const metrics::LightScore& ls) {
    return {ls.rate_visible(metrics::PixelClass::acne), ls.rate_visible(metrics::PixelClass::peter_panning),
            ls.rate_visible(metrics::PixelClass::light_bleeding)};
}

bool Objective::grows_with_bias() const {
    return minimize.starts_with("rates.peter_panning") || minimize.starts_with("counts.peter_panning") ||
           minimize.starts_with("peter_panning_gap");
}

std::string worse_than(const Evaluation& after, const Evaluation& before) {
    // Rates of the same scored pixels: a difference below one pixel in 10^9 is rounding.
    auto worse = [](double a, double b) { return a > b + 1e-12; };
    if (after.lights.empty() || before.lights.empty())
        return worse(after.visible.sum(), before.visible.sum())
                   ? fmt::format("visible acne + peter-panning + light bleeding {:.6f}, the start's {:.6f}",
                                 after.visible.sum(), before.visible.sum())
                   : "";
    for (const LightOutcome& a : after.lights)
        for (const LightOutcome& b : before.lights)
            if (a.scenario == b.scenario && a.light == b.light && worse(a.visible.sum(), b.visible.sum()))
                return fmt::format(
                    "scenario {} light {}: visible acne + peter-panning + light bleeding {:.6f} (acne {:.6f}, "
                    "peter-panning {:.6f}, light bleeding {:.6f}), the start's {:.6f} (acne {:.6f}, peter-panning "
                    "{:.6f}, light bleeding {:.6f})",
                    a.scenario, a.light, a.visible.sum(), a.visible.acne, a.visible.peter_panning,
                    a.visible.light_bleeding, b.visible.sum(), b.visible.acne, b.visible.peter_panning,
                    b.visible.light_bleeding);
    return "";
}

Evaluator::Evaluator(std::span<const Scenario> scenarios, const raster::Technique& base, const TuneOptions& options,
                     const raster::VulkanContext& ctx)
    : base_(base), options_(options), ctx_(&ctx), gpu_scoring_(metrics::preferred_scorer(ctx) == metrics::Scorer::gpu) {
    if (!options.objective.visible()) metric_named(options.objective.minimize, "--minimize");
    metric_named(options.objective.then, "--then");
    for (const Scenario& s : scenarios) {
        TuneScene scene;
        scene.scenario = &s;
        scene.oracle = std::make_shared<const OracleRun>(oracle_for(s, options.validate));
        scene.session = std::make_unique<raster::RasterSession>(s, ctx);
        scene.scoring = scoring_options(s, base, options.validate.tolerance, options.validate.visible_threshold);
        for (auto& o : scene.scoring) o.perceptual = false;
        if (!options.lookups) {
            // V only: each light's footprint from one lookup render of the starting technique;
            // every brighter pixel with a true occluder outside the aliasing band is counted as
            // peter-panning (no bias reach: the bias is what is being searched).
            const raster::RasterResult rr = scene.session->render(base);
            for (std::size_t li = 0; li < scene.scoring.size() && li < rr.frame.lights.size(); ++li) {
                const auto& lk = rr.frame.lights[li].lookups;
                const double f = lk ? median_at_surface(lk->footprint_m, rr.frame.A, true) : 0.0;
                scene.scoring[li].texel_footprint_m = static_cast<float>(f);
                scene.scoring[li].bias_reach_m = std::numeric_limits<float>::max();
                if (footprint_m_ == 0) footprint_m_ = f;
            }
        }
        scenes_.push_back(std::move(scene));
    }
}

std::size_t Evaluator::light_count() const {
    std::size_t n = 0;
    for (const TuneScene& s : scenes_) n = std::max(n, s.scenario->lights.size());
    return n;
}

Evaluation Evaluator::evaluate(const Setting& s) {
    return evaluate(apply_setting(base_, options_.knobs, s, footprint_m_), s);
}

Evaluation Evaluator::evaluate(const raster::Technique& technique, const Setting& s) {
    const auto t0 = SteadyClock::now();
    const metrics::Metric* minimize =
        options_.objective.visible() ? nullptr : &metric_named(options_.objective.minimize, "--minimize");
    const metrics::Metric& then = metric_named(options_.objective.then, "--then");
    Evaluation e;
    e.setting = s;
    raster::RenderOptions ro;
    ro.lookups = options_.lookups;
    for (std::size_t si = 0; si < scenes_.size(); ++si) {
        TuneScene& scene = scenes_[si];
        const auto tr = SteadyClock::now();
        // On the GPU the output stays where it lies and only the counts come back; the first
        // evaluation reads back when it still has to find the world knob's footprint.
        const bool on_gpu = gpu_scoring_ && footprint_m_ != 0 && !scene.cpu_only;
        ro.read_back = !on_gpu;
        // The camera images go to the scorer once (GpuScorer::knows_camera).
        ro.camera_images = !on_gpu || !scene.scorer;
        raster::RasterResult rr = scene.session->render(technique, ro);
        if (!ro.camera_images && !scene.scorer->knows_camera(rr.stats)) {
            ro.camera_images = true;
            rr = scene.session->render(technique, ro);
        }
        e.render_s += seconds_since(tr);
        const auto tc = SteadyClock::now();
        std::optional<metrics::FrameScore> gpu_score;
        if (on_gpu) {
            if (!scene.scorer)
                scene.scorer = std::make_shared<metrics::GpuScorer>(*ctx_, scene.oracle->frame, rr.frame);
            gpu_score = scene.scorer->score(rr, scene.scoring);
            if (!gpu_score) {
                // A family that reads back, or V only without given scales: the CPU from now on.
                scene.scorer.reset();
                scene.cpu_only = true;
                if (!rr.stats.on_device.empty() || rr.frame.prim.empty()) {
                    ro.read_back = true;
                    ro.camera_images = true;
                    rr = scene.session->render(technique, ro);
                }
            }
        }
        if (footprint_m_ == 0) {
            // The world knob's unit: the median texel footprint at the receivers, over every light
            // of the first scenario that has one.
            for (const auto& l : rr.frame.lights)
                if (l.lookups && footprint_m_ == 0)
                    footprint_m_ = median_at_surface(l.lookups->footprint_m, rr.frame.A, true);
        }
        const metrics::FrameScore score =
            gpu_score ? std::move(*gpu_score) : metrics::score_frames(scene.oracle->frame, rr.frame, scene.scoring);
        for (std::size_t li = 0; li < score.lights.size(); ++li) {
            const metrics::LightScore& ls = score.lights[li];
            LightOutcome o;
            o.scenario = si;
            o.light = li;
            o.scored = ls.pixels.scored;
            o.acne_rate = ls.rate(metrics::PixelClass::acne);
            o.visible = visible_bias_error(ls);
            o.acne = options_.objective.visible() ? o.visible.acne : o.acne_rate;
            o.minimized = objective_value(minimize, ls, o.visible);
            o.then = metrics::value_of(then, ls).value_or(0.0);
            e.lights.push_back(o);
        }
        e.count_s += seconds_since(tc);
    }
    pool(e, options_.objective);
    e.seconds = seconds_since(t0);
    return e;
}

bool better(const Evaluation& a, const Evaluation& b, const KnobSet& knobs, const Objective& objective) {
    if (a.feasible != b.feasible) return a.feasible;
    if (!a.feasible && a.worst_acne != b.worst_acne) return a.worst_acne < b.worst_acne;
    if (std::abs(a.minimized - b.minimized) > objective.tie * std::max(a.minimized, b.minimized))
        return a.minimized < b.minimized;
    if (a.then != b.then) return a.then < b.then;
    return bias_size(a.setting, knobs) < bias_size(b.setting, knobs);
}

void rank(TuneResult& r, const KnobSet& knobs, const Objective& objective) {
    r.winner.reset();
    r.front.clear();
    const auto& ev = r.evaluations;
    for (std::size_t i = 0; i < ev.size(); ++i) {
        if (ev[i].feasible && (!r.winner || better(ev[i], ev[*r.winner], knobs, objective))) r.winner = i;
        if (i == 0 || ev[i].worst_acne < ev[r.best_reachable].worst_acne ||
            (ev[i].worst_acne == ev[r.best_reachable].worst_acne &&
             better(ev[i], ev[r.best_reachable], knobs, objective)))
            r.best_reachable = i;
        // Pareto: no other evaluation is at least as good on both and better on one.
        bool dominated = false;
        for (std::size_t j = 0; j < ev.size() && !dominated; ++j) {
            if (j == i) continue;
            const bool no_worse = ev[j].worst_acne <= ev[i].worst_acne && ev[j].minimized <= ev[i].minimized;
            const bool strictly = ev[j].worst_acne < ev[i].worst_acne || ev[j].minimized < ev[i].minimized;
            // Equal points: the earlier one stands for both.
            dominated = no_worse && (strictly || j < i);
        }
        if (!dominated) r.front.push_back(i);
    }
    std::sort(r.front.begin(), r.front.end(), [&](std::size_t a, std::size_t b) {
        return ev[a].worst_acne != ev[b].worst_acne ? ev[a].worst_acne < ev[b].worst_acne : a < b;
    });
}

namespace {

// The search's bookkeeping: every evaluation once (a setting seen before is not evaluated
// again), within the budget.
class Search {
  public:
    // Evaluations are handed out by address: reserving the budget keeps them in place.
    // `start`, when given, is evaluation 0 (it counts towards the budget).
    Search(const EvaluateFn& ev, const TuneOptions& options, TuneResult& result, const Evaluation* start)
        : ev_(ev), opt_(options), r_(result) {
        r_.evaluations.reserve(static_cast<std::size_t>(options.budget));
        if (start) {
            r_.evaluations.push_back(*start);
            r_.start = 0;
            start_ = start->setting;
            if (opt_.progress) opt_.progress(r_.evaluations.back(), 0);
        }
    }

    // Whether `a` and `b` set the on/off knobs alike.
    bool same_switches(const Setting& a, const Setting& b) const {
        if (a.value.size() != b.value.size()) return false;
        for (std::size_t i = 0; i < opt_.knobs.size(); ++i)
            if (!is_continuous(opt_.knobs[i]) && a[i] != b[i]) return false;
        return true;
    }

    bool out_of_budget() const { return static_cast<int>(r_.evaluations.size()) >= opt_.budget; }

    // The evaluation of `s`, or none when the budget is spent.
    const Evaluation* eval(const Setting& s) {
        if (const Evaluation* e = seen(s)) return e;
        if (out_of_budget()) {
            r_.budget_exhausted = true;
            return nullptr;
        }
        r_.evaluations.push_back(ev_(s));
        if (opt_.progress) opt_.progress(r_.evaluations.back(), r_.evaluations.size() - 1);
        return &r_.evaluations.back();
    }

    bool is_better(const Evaluation& a, const Evaluation& b) const { return better(a, b, opt_.knobs, opt_.objective); }

    // The evaluation of `s` when it was made already; never evaluates.
    const Evaluation* seen(const Setting& s) const {
        for (const auto& e : r_.evaluations)
            if (e.setting == s) return &e;
        return nullptr;
    }

    // How far a setting is from the acne limit, on a log scale: <= 0 is feasible.
    std::optional<double> margin(const Evaluation* e) const {
        if (!e || !(opt_.objective.max_acne > 0)) return std::nullopt;
        return std::log10(std::max(e->worst_acne, 1e-9) / opt_.objective.max_acne);
    }

    // The least position of knob k in [lo, hi] at which `s` is feasible, to within `step`
    // decades; `hi` must be feasible and `lo` infeasible (or below the range: off). Acne falls
    // smoothly with the bias, so where both ends were evaluated near the limit, the next probe
    // goes half a step either side of where the line through their log acne margins crosses it
    // (two probes bracket a good estimate); otherwise, and when a probe did not halve the
    // bracket, the next one bisects it. Returns the feasible setting found.
    Setting bisect(Setting s, std::size_t k, double lo, double hi, double step) {
        const raster::KnobDecl& knob = opt_.knobs[k];
        auto margin_at = [&](double x) {
            Setting t = s;
            t[k] = value_at(knob, x);
            return margin(seen(t));
        };
        std::optional<double> m_lo = margin_at(lo), m_hi = margin_at(hi);
        bool above = true, halved = true;
        while (hi - lo > step) {
            const double width = hi - lo;
            double x = 0.5 * (lo + hi);
            // Only near the limit (both ends within a decade of it) is the line a good guide:
            // far above it acne saturates, and a feasible end with no acne says nothing of how far.
            if (halved && m_lo && m_hi && *m_lo > 0 && *m_lo < 1 && *m_hi <= 0 && *m_hi > -1 && width > 2 * step) {
                const double crossing = lo + width * *m_lo / (*m_lo - *m_hi);
                x = std::clamp(crossing + (above ? 0.5 : -0.5) * step, lo + 0.05 * width, hi - 0.05 * width);
                above = !above;
            }
            s[k] = value_at(knob, x);
            const Evaluation* e = eval(s);
            if (!e) break;
            if (e->feasible) {
                hi = x;
                m_hi = margin(e);
            } else {
                lo = x;
                m_lo = margin(e);
            }
            halved = hi - lo <= 0.5 * width + 1e-12;
        }
        s[k] = value_at(knob, hi);
        return s;
    }

    // The search from `zero`: every knob off but the on/off ones, set as one combination.
    void run(const Setting& zero) {
        const Evaluation* e0 = eval(zero);
        if (!e0) return;
        std::optional<Setting> at;
        if (!e0->feasible)
            at = boundary(zero);
        else if (opt_.objective.grows_with_bias())
            return;  // no bias needed: any bias only adds peter-panning
        else
            at = zero;
        if (opt_.objective.grows_with_bias()) return;
        // The start, when within the cap and better, is a better place to begin from.
        if (start_ && same_switches(*start_, zero)) {
            const Evaluation* es = seen(*start_);
            if (es && es->feasible && (!at || is_better(*es, *eval(*at)))) at = start_;
        }
        if (at) inside(*at);
    }

    // 4. When the objective counts acne too (the default), the best point can lie inside the
    // feasible set: more bias than the cap needs removes acne the cap allows, until the
    // peter-panning it adds costs more. Each knob's log position moves either way while that
    // helps; steps halve from one decade down to `precision`.
    void inside(Setting at) {
        const double fine = std::log10(1.0 + opt_.precision);
        for (double step = 1.0; step >= fine && !out_of_budget();) {
            bool moved = false;
            for (std::size_t k = 0; k < opt_.knobs.size(); ++k) {
                const raster::KnobDecl& knob = opt_.knobs[k];
                if (!adds_bias(knob) || moved) continue;
                const double pk = position(knob, at[k]);
                for (double dir : {1.0, -1.0}) {
                    if (std::isinf(pk) && dir < 0) continue;  // off: nothing to give up
                    Setting q = at;
                    q[k] = value_at(knob, std::isinf(pk) ? std::log10(knob.lower) : pk + dir * step);
                    if (q[k] == at[k]) continue;
                    const Evaluation* e = eval(q);
                    if (!e) return;
                    if (e->feasible && is_better(*e, *eval(at))) {
                        at = q;
                        moved = true;
                        break;
                    }
                }
            }
            if (!moved) step /= 2;
        }
    }

    // Steps 1-3 from `zero` (infeasible): the best point on the boundary of the feasible set.
    std::optional<Setting> boundary(const Setting& zero) {
        // Brackets are first narrowed to a fifth of a decade (a factor 1.58), the winner's knobs
        // then to `precision`: most evaluations go to where the optimum is.
        const double fine = std::log10(1.0 + opt_.precision);
        const double coarse = std::max(fine, 0.2);

        // 1. Each knob alone: its least feasible value (the boundary's intercept on its axis).
        std::vector<double> intercept(opt_.knobs.size(), kInf);
        std::optional<Setting> best;
        auto consider = [&](const Setting& s) {
            const Evaluation* e = eval(s);
            if (e && e->feasible && (!best || is_better(*e, *eval(*best)))) best = s;
        };
        for (std::size_t k = 0; k < opt_.knobs.size(); ++k) {
            const raster::KnobDecl& knob = opt_.knobs[k];
            if (!adds_bias(knob)) continue;
            Setting s = zero;
            s[k] = knob.upper;
            const Evaluation* top = eval(s);
            if (!top || !top->feasible) continue;  // this knob alone cannot cure the acne
            s = bisect(s, k, std::log10(knob.lower) - coarse, std::log10(knob.upper), coarse);
            intercept[k] = position(knob, s[k]);
            consider(s);
        }
        if (!best) return std::nullopt;

        // 2. With two knobs or more, trades along the boundary: give up a step of knob a (or
        // tighten the clamp) and take back only as much of knob b as feasibility needs. Steps
        // halve, from one decade, when no trade helps.
        Setting at = *best;
        const bool several = std::count_if(opt_.knobs.begin(), opt_.knobs.end(), is_continuous) >= 2;
        for (double step = 1.0; several && step >= coarse && !out_of_budget();) {
            bool moved = false;
            for (std::size_t a = 0; a < opt_.knobs.size(); ++a) {
                const raster::KnobDecl& ka = opt_.knobs[a];
                if (!is_continuous(ka) || out_of_budget()) continue;
                const double pa = position(ka, at[a]);
                if (!ka.caps && std::isinf(pa)) continue;  // off: nothing to give up
                Setting q = at;
                q[a] = value_at(ka, std::isinf(pa) ? std::log10(ka.upper) : pa - step);
                if (q[a] == at[a]) continue;
                const Evaluation* eq = eval(q);
                if (!eq) break;
                if (eq->feasible) {
                    if (is_better(*eq, *eval(at))) {
                        at = q;
                        moved = true;
                    }
                    continue;
                }
                for (std::size_t b = 0; b < opt_.knobs.size(); ++b) {
                    const raster::KnobDecl& kb = opt_.knobs[b];
                    if (b == a || !adds_bias(kb)) continue;
                    const double pb = position(kb, q[b]);
                    const double lo = std::isinf(pb) ? std::log10(kb.lower) - coarse : pb;
                    // b's own intercept is feasible with any a (acne only falls as a grows).
                    double hi = intercept[b];
                    if (std::isinf(hi)) {
                        hi = std::log10(kb.upper);
                        Setting top = q;
                        top[b] = kb.upper;
                        const Evaluation* et = eval(top);
                        if (!et || !et->feasible) continue;
                    }
                    if (!(hi > lo)) continue;
                    Setting s = bisect(q, b, lo, hi, std::max(coarse, step / 4));
                    const Evaluation* es = eval(s);
                    if (es && es->feasible && is_better(*es, *eval(at))) {
                        at = s;
                        moved = true;
                        break;
                    }
                }
            }
            if (!moved) step /= 2;
        }

        // 3. The best point's knobs, one at a time, down to `precision`.
        if (fine < coarse)
            for (std::size_t k = 0; k < opt_.knobs.size(); ++k) {
                if (!adds_bias(opt_.knobs[k]) || out_of_budget()) continue;
                const double pk = position(opt_.knobs[k], at[k]);
                if (std::isinf(pk)) continue;
                const Setting s = bisect(at, k, pk - coarse, pk, fine);
                const Evaluation* es = eval(s);
                if (es && es->feasible && is_better(*es, *eval(at))) at = s;
            }
        return at;
    }

  private:
    const EvaluateFn& ev_;
    const TuneOptions& opt_;
    TuneResult& r_;
    std::optional<Setting> start_;
};

// Where the searches start: every knob off, once for each combination of the on/off knobs'
// values (the first knob's changing slowest).
std::vector<Setting> zeros(const KnobSet& knobs) {
    std::vector<Setting> out = {Setting(knobs.size())};
    for (std::size_t i = 0; i < knobs.size(); ++i) {
        if (is_continuous(knobs[i])) continue;
        std::vector<Setting> next;
        for (const Setting& s : out)
            for (double v : {0.0, 1.0}) {
                next.push_back(s);
                next.back()[i] = v;
            }
        out = std::move(next);
    }
    return out;
}

void recommend(TuneResult& r, const Evaluator& ev, const TuneOptions& options) {
    r.footprint_m = ev.footprint_m();
    if (!r.evaluations.empty())
        r.recommended =
            r.start && r.chosen() == *r.start
                ? ev.base()
                : apply_setting(ev.base(), options.knobs, r.evaluations[r.chosen()].setting, ev.footprint_m());
}

// Never worse than the start: when the best found is worse on some light, the start stays.
void check_against_start(TuneResult& r) {
    if (!r.start || r.chosen() == *r.start) return;
    r.why = worse_than(r.evaluations[r.chosen()], r.evaluations[*r.start]);
    r.kept_start = !r.why.empty();
}

}  // namespace

TuneResult search(const EvaluateFn& evaluate, const TuneOptions& options, const Evaluation* start) {
    if (options.budget < 1) throw InputError(fmt::format("--budget: {} evaluations; at least 1", options.budget));
    TuneResult r;
    Search s(evaluate, options, r, start);
    for (const Setting& zero : zeros(options.knobs)) s.run(zero);
    rank(r, options.knobs, options.objective);
    check_against_start(r);
    return r;
}

TuneResult grid(const EvaluateFn& evaluate, const TuneOptions& options, int levels) {
    TuneResult r;
    std::vector<std::size_t> axes;
    for (std::size_t k = 0; k < options.knobs.size(); ++k)
        if (is_continuous(options.knobs[k])) axes.push_back(k);
    // Level 0 is off (unclamped for clamp); levels 1..n-1 span the range on a log scale.
    auto value = [&](std::size_t k, int level) {
        const raster::KnobDecl& knob = options.knobs[k];
        if (level == 0) return 0.0;
        const double t = levels > 2 ? static_cast<double>(level - 1) / (levels - 2) : 1.0;
        return std::pow(10.0, std::log10(knob.lower) + t * (std::log10(knob.upper) - std::log10(knob.lower)));
    };
    for (const Setting& zero : zeros(options.knobs)) {
        std::vector<int> level(axes.size(), 0);
        while (true) {
            Setting s = zero;
            for (std::size_t a = 0; a < axes.size(); ++a) s[axes[a]] = value(axes[a], level[a]);
            r.evaluations.push_back(evaluate(s));
            if (options.progress) options.progress(r.evaluations.back(), r.evaluations.size() - 1);
            std::size_t a = 0;
            while (a < axes.size() && ++level[a] == levels) level[a++] = 0;
            if (a == axes.size()) break;
        }
    }
    rank(r, options.knobs, options.objective);
    return r;
}

TuneResult tune(std::span<const Scenario> scenarios, const raster::Technique& base, const TuneOptions& options,
                const raster::VulkanContext& ctx) {
    if (options.budget < 1) throw InputError(fmt::format("--budget: {} evaluations; at least 1", options.budget));
    Evaluator ev(scenarios, base, options, ctx);
    return tune(ev, options);
}

TuneResult tune(Evaluator& ev, const TuneOptions& options) {
    if (options.budget < 1) throw InputError(fmt::format("--budget: {} evaluations; at least 1", options.budget));
    const raster::Technique& base = ev.base();
    // The start first: it fixes the reference footprint, and no light may end worse than it.
    Evaluation start = ev.evaluate(base, Setting{});
    const double footprint = ev.footprint_m();
    start.setting = setting_of(base.bias, options.knobs, footprint, &base);
    // A family knob is the technique's: one value for every light, as with a shared bias.
    if (options.shared_bias || options.knobs.has_technique_knob()) {
        TuneResult r = search([&](const Setting& s) { return ev.evaluate(s); }, options, &start);
        recommend(r, ev, options);
        return r;
    }

    // Each light's own search. A light's outcome depends on its own bias alone, so a render with
    // one setting for every light serves every light's search that asks for that setting: the
    // renders are shared, each made once.
    TuneResult r;
    r.footprint_m = footprint;
    r.evaluations.push_back(start);
    r.start = 0;
    if (options.progress) options.progress(start, 0);
    auto render = [&](const Setting& s) {
        for (std::size_t i = 1; i < r.evaluations.size(); ++i)
            if (r.evaluations[i].setting == s) return r.evaluations[i];
        r.evaluations.push_back(ev.evaluate(s));
        if (options.progress) options.progress(r.evaluations.back(), r.evaluations.size() - 1);
        return r.evaluations.back();
    };
    TuneOptions one = options;
    one.progress = nullptr;
    std::vector<Setting> chosen;
    for (std::size_t li = 0; li < ev.light_count(); ++li) {
        const raster::Bias own = base.bias_for(li);
        Evaluation own_start = project(start, li, options.objective);
        own_start.setting = setting_of(own, options.knobs, footprint);
        TuneResult rl =
            search([&](const Setting& s) { return project(render(s), li, options.objective); }, one, &own_start);
        rl.footprint_m = footprint;
        r.budget_exhausted = r.budget_exhausted || rl.budget_exhausted;
        chosen.push_back(rl.evaluations[rl.chosen()].setting);
        r.per_light.push_back(std::move(rl));
    }
    rank(r, options.knobs, options.objective);
    r.recommended = apply_settings(base, options.knobs, chosen, footprint);
    // A kept light gets the start's own bias exactly (not through the footprint's round trip).
    for (std::size_t li = 0; li < r.per_light.size(); ++li)
        if (r.per_light[li].chosen() == 0)
            set_override(r.recommended.lights[li].bias, base.bias_for(li), options.knobs);
    return r;
}

void keep_start(TuneResult& r, const raster::Technique& start, const TuneOptions& options,
                std::span<const std::pair<std::size_t, std::string>> worse) {
    if (worse.empty()) return;
    if (r.per_light.empty()) {
        r.kept_start = true;
        for (const auto& [li, why] : worse) r.why += (r.why.empty() ? "" : "; ") + why;
        r.recommended = start;
        return;
    }
    for (const auto& [li, why] : worse) {
        if (li >= r.per_light.size()) continue;
        r.per_light[li].kept_start = true;
        r.per_light[li].why = why;
        set_override(r.recommended.lights[li].bias, start.bias_for(li), options.knobs);
    }
}

TuneResult grid_search(std::span<const Scenario> scenarios, const raster::Technique& base, const TuneOptions& options,
                       const raster::VulkanContext& ctx, int levels) {
    Evaluator ev(scenarios, base, options, ctx);
    TuneResult r = grid([&](const Setting& s) { return ev.evaluate(s); }, options, levels);
    recommend(r, ev, options);  // no start: the grid is the benchmark's reference
    return r;
}

}  // namespace penumbra::tune
