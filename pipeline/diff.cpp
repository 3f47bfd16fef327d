#include "pipeline/diff.h"

#include <fmt/format.h>

#include <algorithm>
#include <limits>

#include "common/errors.h"
#include "common/json_reader.h"
#include "common/version.h"

namespace penumbra::diff {

namespace fs = std::filesystem;

namespace {

constexpr long long kMaxCount = std::numeric_limits<long long>::max();

std::string join(const std::vector<std::string>& parts, std::string_view sep) {
    std::string out;
    for (const auto& p : parts) out += (out.empty() ? "" : std::string(sep)) + p;
    return out;
}

LightNumbers parse_light(const nlohmann::json& value, const std::string& file, const std::string& path,
                         const std::string& case_name, const fs::path& dir) {
    JsonObject l(value, file, path);
    LightNumbers n;
    n.case_name = case_name;
    n.index = static_cast<int>(l.integer("index", 0, 1 << 20));
    n.type = l.string("type");
    n.scored = static_cast<std::uint64_t>(l.object("pixels").integer("scored", 0, kMaxCount));
    JsonObject counts = l.object("counts"), rates = l.object("rates");
    n.has_visible = l.has("counts_visible") && l.has("rates_visible");
    // Runs written before light_bleeding existed have no such key: 0 there.
    auto absent = [](JsonObject& o, std::size_t k) {
        return std::string_view(kClasses[k]) == "light_bleeding" && !o.has(kClasses[k]);
    };
    for (std::size_t k = 0; k < kClasses.size(); ++k) {
        if (absent(counts, k) && absent(rates, k)) continue;
        n.counts[k] = static_cast<std::uint64_t>(counts.integer(kClasses[k], 0, kMaxCount));
        n.rates[k] = rates.number_in(kClasses[k], 0.0, 1.0, "a fraction in [0, 1]");
    }
    if (n.has_visible) {
        JsonObject cv = l.object("counts_visible"), rv = l.object("rates_visible");
        for (std::size_t k = 0; k < kClasses.size(); ++k) {
            if (absent(cv, k) && absent(rv, k)) continue;
            n.counts_visible[k] = static_cast<std::uint64_t>(cv.integer(kClasses[k], 0, kMaxCount));
            n.rates_visible[k] = rv.number_in(kClasses[k], 0.0, 1.0, "a fraction in [0, 1]");
        }
    }
    n.wrong_fraction = l.number_in("wrong_fraction", 0.0, 1.0, "a fraction in [0, 1]");
    if (l.has("perceptual")) {
        JsonObject p = l.object("perceptual");
        n.perceptual_mean = p.number("mean");
        n.perceptual_max = p.number("max");
    }
    n.object = value;
    n.class_map = dir / (case_name.empty() ? fmt::format("light{}.classes.png", n.index)
                                           : fmt::format("{}.light{}.classes.png", case_name, n.index));
    return n;
}

std::vector<LightNumbers> parse_lights(JsonObject& owner, const std::string& file, const std::string& path,
                                       const std::string& case_name, const fs::path& dir) {
    const nlohmann::json& lights = owner.get("lights");
    if (!lights.is_array()) owner.fail("lights", "expected an array of lights");
    std::vector<LightNumbers> out;
    for (std::size_t i = 0; i < lights.size(); ++i) {
        const std::string at = fmt::format("{}lights[{}]", path, i);
        out.push_back(parse_light(lights[i], file, at, case_name, dir));
        // Lights are paired across the two runs by index: a run that lists one twice, or out of
        // order, would pair a spot light with a directional one (#50).
        if (out.back().index != static_cast<int>(i))
            throw InputError(
                fmt::format("{}: {}.index: {} where {} was expected (report.json lists light i as "
                            "lights[i]; an index twice or out of order cannot be paired)",
                            file, at, out.back().index, i));
    }
    return out;
}

nlohmann::json parse_image(JsonObject& top) {
    JsonObject image = top.object("image");
    return {{"width", image.integer("width", 1, 1 << 20)}, {"height", image.integer("height", 1, 1 << 20)}};
}

std::string types_of(const std::vector<LightNumbers>& lights) {
    std::vector<std::string> types;
    for (const auto& l : lights) types.push_back(l.type);
    return fmt::format("{} ({})", lights.size(), join(types, ", "));
}

std::string image_text(const nlohmann::json& image) {
    return fmt::format("{}x{}", image.at("width").get<long long>(), image.at("height").get<long long>());
}

std::string percent(double fraction) {
    return fmt::format("{:.4f}%", 100.0 * fraction);
}

// What differs when a fingerprint's part does.
std::string fingerprint_part_differs(const std::string& key) {
    if (key == "scene") return "the scene (its geometry) differs";
    if (key == "camera") return "the camera differs";
    return "the lights (their types or placement) differ";
}

// Why two runs are not of one scenario; empty when they are. Adds a warning when the runs do
// not record enough to be sure.
std::vector<std::string> scenario_differences(const Run& a, const Run& b, std::vector<std::string>& warnings) {
    std::vector<std::string> why;
    if (a.image != b.image) why.push_back(fmt::format("image {} against {}", image_text(a.image), image_text(b.image)));
    if (a.kind == "stress") {
        if (a.fingerprint != b.fingerprint)
            why.push_back(fmt::format("seed {} against {}", a.fingerprint.value("seed", nlohmann::json()).dump(),
                                      b.fingerprint.value("seed", nlohmann::json()).dump()));
        std::vector<std::string> only_a, only_b, changed;
        for (const auto& [name, c] : a.cases.items()) {
            if (!b.cases.contains(name))
                only_a.push_back(name);
            else if (b.cases.at(name) != c)
                changed.push_back(name);
        }
        for (const auto& [name, c] : b.cases.items())
            if (!a.cases.contains(name)) only_b.push_back(name);
        if (!only_a.empty()) why.push_back("cases only in A: " + join(only_a, ", "));
        if (!only_b.empty()) why.push_back("cases only in B: " + join(only_b, ", "));
        if (!changed.empty()) why.push_back("cases whose geometry or lights differ: " + join(changed, ", "));
        return why;
    }
    if (a.fingerprint.is_object() && b.fingerprint.is_object()) {
        for (const char* key : {"scene", "camera", "lights"})
            if (a.fingerprint.value(key, "") != b.fingerprint.value(key, ""))
                why.push_back(fingerprint_part_differs(key));
    } else {
        warnings.push_back(fmt::format(
            "{} has no scenario fingerprint (written before penumbra recorded one): the runs were matched by scenario "
            "file, image size and lights' types only",
            path_text(a.fingerprint.is_object() ? b.file : a.file)));
        if (a.scenario != b.scenario) why.push_back(fmt::format("scenario file {} against {}", a.scenario, b.scenario));
    }
    if (types_of(a.lights) != types_of(b.lights))
        why.push_back(fmt::format("lights {} against {}", types_of(a.lights), types_of(b.lights)));
    return why;
}

const LightNumbers* find_light(const Run& run, const LightNumbers& like) {
    for (const auto& l : run.lights)
        if (l.case_name == like.case_name && l.index == like.index) return &l;
    return nullptr;
}

nlohmann::json side(const LightNumbers& l) {
    nlohmann::json counts, rates, counts_visible, rates_visible;
    for (std::size_t k = 0; k < kClasses.size(); ++k) {
        counts[kClasses[k]] = l.counts[k];
        rates[kClasses[k]] = l.rates[k];
        counts_visible[kClasses[k]] = l.counts_visible[k];
        rates_visible[kClasses[k]] = l.rates_visible[k];
    }
    nlohmann::json j = {
        {"scored", l.scored}, {"counts", counts}, {"rates", rates}, {"wrong_fraction", l.wrong_fraction}};
    if (l.has_visible) {
        j["counts_visible"] = counts_visible;
        j["rates_visible"] = rates_visible;
    }
    if (l.perceptual_mean) j["perceptual"] = {{"mean", *l.perceptual_mean}, {"max", *l.perceptual_max}};
    return j;
}

nlohmann::json run_json(const Run& r) {
    return {{"file", path_text(r.file)}, {"kind", r.kind},           {"scenario", r.scenario},
            {"image", r.image},          {"technique", r.technique}, {"scoring", r.scoring}};
}

}  // namespace

std::string LightNumbers::label() const {
    return fmt::format("{}light {} ({})", case_name.empty() ? "" : case_name + " ", index, type);
}

bool LightChange::worse() const {
    return std::any_of(classes.begin(), classes.end(), [](const ClassChange& c) { return c.worse; });
}

bool DiffResult::identical() const {
    return std::all_of(lights.begin(), lights.end(), [](const LightChange& l) { return l.identical; });
}

Run read_run(const fs::path& path) {
    std::error_code ec;
    fs::path file = path;
    if (fs::is_directory(path, ec)) {
        file = path / "report.json";
        if (!fs::exists(file, ec)) file = path / "stress.json";
        if (!fs::exists(file, ec))
            throw InputError(fmt::format(
                "{}: holds neither report.json nor stress.json; expected the output folder of validate, compare or "
                "stress, or the file itself",
                path_text(path)));
    } else if (!fs::exists(path, ec)) {
        throw InputError(
            fmt::format("{}: no such file or folder; expected a report.json or stress.json, or the output "
                        "folder of validate, compare or stress",
                        path_text(path)));
    }
    // Labelled with the whole path: both runs' files are usually called report.json.
    return parse_run(
        parse_json_strict(read_regular_file(file, kReportJson.max_bytes, kReportJson.name), path_text(file)), file);
}

Run parse_run(const nlohmann::json& doc, const fs::path& file) {
    const std::string label = path_text(file);
    const fs::path dir = file.parent_path();
    JsonObject top(doc, label, "");
    Run r;
    r.file = file;
    r.image = parse_image(top);
    r.technique = top.get("technique");
    if (top.has("cases")) {
        r.kind = "stress";
        r.scenario = "the stress suite";
        r.fingerprint = {{"seed", top.get("seed")}};
        r.cases = nlohmann::json::object();
        const nlohmann::json& cases = top.get("cases");
        if (!cases.is_array()) top.fail("cases", "expected an array of cases");
        for (std::size_t k = 0; k < cases.size(); ++k) {
            const std::string path = fmt::format("cases[{}]", k);
            JsonObject c(cases[k], label, path);
            const std::string name = c.string("name");
            if (r.cases.contains(name)) c.fail("name", fmt::format("\"{}\" appears twice", name));
            std::vector<LightNumbers> lights = parse_lights(c, label, path + ".", name, dir);
            nlohmann::json types = nlohmann::json::array();
            for (const auto& l : lights) types.push_back(l.type);
            r.cases[name] = {{"triangles", c.integer("triangles", 0, kMaxCount)}, {"lights", types}};
            r.lights.insert(r.lights.end(), lights.begin(), lights.end());
        }
        return r;
    }
    if (!top.has("lights") || !top.has("version"))
        top.fail_here("expected penumbra's report.json (validate, compare) or stress.json (stress)");
    r.kind = top.has("engine") ? "compare" : "validate";
    r.scenario = top.string("scenario");
    if (top.has("fingerprint")) {
        JsonObject fp = top.object("fingerprint");
        r.fingerprint = {
            {"scene", fp.string("scene")}, {"camera", fp.string("camera")}, {"lights", fp.string("lights")}};
    }
    if (top.has("scoring") && top.get("scoring").is_array() && !top.get("scoring").empty()) {
        JsonObject s(top.get("scoring")[0], label, "scoring[0]");
        r.scoring = {{"tolerance", s.number("tolerance")}, {"visible_threshold", s.number("visible_threshold", 0.1)}};
    }
    r.lights = parse_lights(top, label, "", "", dir);
    return r;
}

DiffResult diff_runs(const Run& a, const Run& b, double tolerance) {
    DiffResult d;
    d.tolerance = tolerance;
    if ((a.kind == "stress") != (b.kind == "stress"))
        throw InputError(fmt::format("{} is a {} run and {} a {} run: diff compares two runs of one scenario",
                                     path_text(a.file), a.kind, path_text(b.file), b.kind));
    const std::vector<std::string> why = scenario_differences(a, b, d.warnings);
    if (!why.empty())
        throw InputError(
            fmt::format("{} and {} are runs of different scenarios: {}; diff compares two runs of one "
                        "scenario",
                        path_text(a.file), path_text(b.file), join(why, "; ")));
    if (a.kind != b.kind) d.warnings.push_back(fmt::format("A is a {} run, B a {} run", a.kind, b.kind));
    if (a.scoring != b.scoring)
        d.warnings.push_back(fmt::format("the runs were scored differently (A {}, B {}): rates move with the tolerance",
                                         a.scoring.dump(), b.scoring.dump()));
    for (const LightNumbers& la : a.lights) {
        const LightNumbers* lb = find_light(b, la);
        if (!lb)  // the checks above make the lights match; a run naming one index twice does not
            throw InputError(
                fmt::format("{}: {} has no counterpart in {}", path_text(a.file), la.label(), path_text(b.file)));
        if (la.type != lb->type)
            throw InputError(fmt::format("{} is a {} light in {} and a {} light in {}: diff compares like with like",
                                         la.label(), la.type, path_text(a.file), lb->type, path_text(b.file)));
        LightChange c;
        c.a = la;
        c.b = *lb;
        c.identical = la.object == lb->object;
        c.visible_basis = la.has_visible && lb->has_visible;
        for (std::size_t k = 0; k < kClasses.size(); ++k) {
            ClassChange& cc = c.classes[k];
            cc.count_a = c.visible_basis ? la.counts_visible[k] : la.counts[k];
            cc.count_b = c.visible_basis ? lb->counts_visible[k] : lb->counts[k];
            cc.rate_a = c.visible_basis ? la.rates_visible[k] : la.rates[k];
            cc.rate_b = c.visible_basis ? lb->rates_visible[k] : lb->rates[k];
            cc.change = cc.rate_b - cc.rate_a;
            cc.worse = cc.change > tolerance;
            if (cc.worse)
                d.worse_lines.push_back(fmt::format("{}: {} {} {} -> {} (+{:.4f} points, more than {:.4f})", la.label(),
                                                    kClasses[k], c.visible_basis ? "visible rate" : "rate",
                                                    percent(cc.rate_a), percent(cc.rate_b), 100.0 * cc.change,
                                                    100.0 * tolerance));
        }
        d.lights.push_back(std::move(c));
    }
    return d;
}

nlohmann::json diff_json(const Run& a, const Run& b, const DiffResult& d) {
    nlohmann::json lights = nlohmann::json::array();
    for (const LightChange& c : d.lights) {
        nlohmann::json classes = nlohmann::json::object();
        for (std::size_t k = 0; k < kClasses.size(); ++k)
            classes[kClasses[k]] = {{"a", c.classes[k].rate_a},
                                    {"b", c.classes[k].rate_b},
                                    {"change", c.classes[k].change},
                                    {"worse", c.classes[k].worse}};
        nlohmann::json l = {{"light", c.a.index},
                            {"type", c.a.type},
                            {"basis", c.visible_basis ? "rates_visible" : "rates"},
                            {"classes", classes},
                            {"identical", c.identical},
                            {"worse", c.worse()},
                            {"a", side(c.a)},
                            {"b", side(c.b)},
                            {"class_maps", {{"a", path_text(c.a.class_map)}, {"b", path_text(c.b.class_map)}}}};
        if (!c.a.case_name.empty()) l["case"] = c.a.case_name;
        lights.push_back(std::move(l));
    }
    return {{"version", version_string()},  {"a", run_json(a)},           {"b", run_json(b)},
            {"tolerance", d.tolerance},     {"identical", d.identical()}, {"worse", d.worse()},
            {"worse_lines", d.worse_lines}, {"warnings", d.warnings},     {"lights", lights}};
}

std::string diff_table(const Run& a, const Run& b, const DiffResult& d) {
    std::string t = fmt::format("A: {} ({})\nB: {} ({})\n", path_text(a.file), a.kind, path_text(b.file), b.kind);
    for (const LightChange& c : d.lights) {
        t += fmt::format("{}: scored {} -> {}; wrong {} -> {}{}\n", c.a.label(), c.a.scored, c.b.scored,
                         percent(c.a.wrong_fraction), percent(c.b.wrong_fraction), c.identical ? " (identical)" : "");
        // The visible rates first (what gates and the worse rule read), every wrong pixel's after.
        t += fmt::format("  {:<14}{:>14}{:>14}{:>14}{:>14}{:>10}{:>10}{:>11}{:>11}{:>14}\n", "class", "vis. rate A",
                         "vis. rate B", "vis. count A", "vis. count B", "count A", "count B", "rate A", "rate B",
                         "change");
        for (std::size_t k = 0; k < kClasses.size(); ++k) {
            const bool v = c.visible_basis;
            t += fmt::format(
                "  {:<14}{:>14}{:>14}{:>14}{:>14}{:>10}{:>10}{:>11}{:>11}{:>14}{}\n", kClasses[k],
                v ? percent(c.a.rates_visible[k]) : "-", v ? percent(c.b.rates_visible[k]) : "-",
                v ? std::to_string(c.a.counts_visible[k]) : "-", v ? std::to_string(c.b.counts_visible[k]) : "-",
                c.a.counts[k], c.b.counts[k], percent(c.a.rates[k]), percent(c.b.rates[k]),
                fmt::format("{:+.4f} pts", 100.0 * c.classes[k].change), c.classes[k].worse ? "  WORSE" : "");
        }
        if (c.a.perceptual_mean && c.b.perceptual_mean)
            t += fmt::format("  perceptual error: mean {:.5f} -> {:.5f}, max {:.5f} -> {:.5f}\n", *c.a.perceptual_mean,
                             *c.b.perceptual_mean, *c.a.perceptual_max, *c.b.perceptual_max);
    }
    return t;
}

}  // namespace penumbra::diff
