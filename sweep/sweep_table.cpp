#include "sweep/sweep_table.h"

#include <fmt/format.h>

#include <algorithm>
#include <cfloat>
#include <limits>
#include <map>
#include <set>

#include "common/errors.h"
#include "common/json_reader.h"
#include "common/memory_estimate.h"
#include "common/output_files.h"

namespace penumbra::sweep {
namespace {

using nlohmann::json;

std::vector<std::string> split(const std::string& text, char sep) {
    std::vector<std::string> parts;
    std::size_t start = 0;
    while (true) {
        const std::size_t end = text.find(sep, start);
        parts.push_back(text.substr(start, end == std::string::npos ? std::string::npos : end - start));
        if (end == std::string::npos) return parts;
        start = end + 1;
    }
}

Config parsed(const json& j, const std::string& label, const std::vector<Light>& lights) {
    Config c;
    c.technique = raster::parse_technique(j, label, lights);
    return c;
}

// `inner` is `outer` or lies inside it: bias.slope in bias.
bool within(const std::string& inner, const std::string& outer) {
    return inner == outer ||
           (inner.size() > outer.size() && inner.compare(0, outer.size(), outer) == 0 && inner[outer.size()] == '.');
}

// A verdict column that is a fraction of the scored pixels.
bool is_fraction(const std::string& column) {
    return column == "wrong_fraction" || column.rfind("rates.", 0) == 0 || column.rfind("rates_visible.", 0) == 0;
}

// The array at `key` of `o`.
const json& array_at(JsonObject& o, const std::string& key) {
    const json& v = o.get(key);
    if (!v.is_array()) o.fail(key, fmt::format("expected an array, got {}", v.type_name()));
    return v;
}

std::vector<std::string> strings_at(JsonObject& o, const std::string& key, std::size_t expected_size) {
    const json& v = array_at(o, key);
    if (expected_size && v.size() != expected_size)
        o.fail(key, fmt::format("expected {} elements, got {}", expected_size, v.size()));
    std::vector<std::string> out;
    for (std::size_t i = 0; i < v.size(); ++i) {
        if (!v[i].is_string())
            o.fail(fmt::format("{}[{}]", key, i), fmt::format("expected a string, got {}", v[i].type_name()));
        out.push_back(v[i].get<std::string>());
    }
    return out;
}

// Times: `count` finite milliseconds >= 0.
std::vector<double> times_at(JsonObject& o, const std::string& key, std::size_t count) {
    const json& v = array_at(o, key);
    if (v.size() != count) o.fail(key, fmt::format("expected {} timings (one per repeat), got {}", count, v.size()));
    std::vector<double> out;
    for (std::size_t i = 0; i < v.size(); ++i) {
        const double d = v[i].is_number() ? v[i].get<double>() : -1;
        if (!v[i].is_number() || !(d >= 0 && d <= DBL_MAX))
            o.fail(fmt::format("{}[{}]", key, i),
                   fmt::format("expected a finite time >= 0, got {}", json_excerpt(v[i])));
        out.push_back(d);
    }
    return out;
}

}  // namespace

Axis parse_axis(const std::string& argument) {
    // KEY=V1,V2 is checked as --set KEY=VALUE is: UTF-8 (a value lands in JSON and in
    // messages), a key path no deeper than a technique may nest.
    if (const std::string problem = set_assignment_problem(argument); !problem.empty())
        throw InputError(fmt::format("--vary {}: {}", escape_non_utf8(argument), problem));
    const std::size_t eq = argument.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == argument.size())
        throw InputError(fmt::format("--vary {}: expected KEY=V1,V2,...", argument));
    Axis a;
    a.key = argument.substr(0, eq);
    a.values = split(argument.substr(eq + 1), ',');
    for (const auto& v : a.values)
        if (v.empty()) throw InputError(fmt::format("--vary {}: an empty value", argument));
    if (a.values.size() > kMaxConfigurations)
        throw InputError(fmt::format("--vary {}: {} values, more than a sweep's {} configurations", a.key,
                                     a.values.size(), kMaxConfigurations));
    return a;
}

void check_axes(std::span<const Axis> axes) {
    for (std::size_t i = 0; i < axes.size(); ++i)
        for (std::size_t j = 0; j < i; ++j) {
            const std::string &a = axes[j].key, &b = axes[i].key;
            if (a == b) throw InputError(fmt::format("--vary {}: the key is varied twice", a));
            if (within(a, b) || within(b, a))
                throw InputError(
                    fmt::format("--vary {} and --vary {}: overlapping keys ({} holds {}); each "
                                "configuration would set one over the other",
                                a, b, within(a, b) ? b : a, within(a, b) ? a : b));
        }
}

std::size_t product_size(std::span<const Axis> axes) {
    std::size_t n = 1;
    for (const Axis& a : axes) {
        if (a.values.empty()) return 0;
        if (n > std::numeric_limits<std::size_t>::max() / a.values.size())
            return std::numeric_limits<std::size_t>::max();
        n *= a.values.size();
    }
    return n;
}

void check_configuration_count(std::size_t count, const std::string& what) {
    if (count > kMaxConfigurations)
        throw InputError(fmt::format(
            "sweep: {} gives {} configurations, more than the {} a sweep may hold "
            "(docs/sweep.md, \"Limits\"); vary fewer values, or split the values into "
            "several sweeps",
            what, count == std::numeric_limits<std::size_t>::max() ? std::string("over 10^19") : std::to_string(count),
            kMaxConfigurations));
}

std::vector<Config> expand(const json& base, std::span<const Axis> axes, const std::vector<Light>& lights) {
    check_axes(axes);
    std::string product;
    for (const Axis& a : axes)
        product += fmt::format("{}{} ({} values)", product.empty() ? "" : " x ", a.key, a.values.size());
    check_configuration_count(product_size(axes), "--vary " + product);
    std::vector<Config> out;
    std::vector<std::size_t> at(axes.size(), 0);
    while (true) {
        json j = base;
        std::vector<std::string> values, pairs;
        for (std::size_t a = 0; a < axes.size(); ++a) {
            const std::string& v = axes[a].values[at[a]];
            raster::apply_override(j, axes[a].key + "=" + v);
            values.push_back(v);
            pairs.push_back(axes[a].key + "=" + v);
        }
        std::string label = "--vary";
        for (const auto& p : pairs) label += " " + p;
        Config c = parsed(j, label + ": technique", lights);
        c.index = out.size();
        c.values = values;
        out.push_back(std::move(c));
        // Odometer, last axis fastest.
        std::size_t a = axes.size();
        while (a > 0 && ++at[a - 1] == axes[a - 1].values.size()) at[--a] = 0;
        if (a == 0) break;
    }
    return out;
}

std::vector<Config> configs_from_json(const json& list, const std::string& name, const json& base,
                                      const std::vector<Light>& lights) {
    if (!list.is_array() || list.empty())
        throw InputError(fmt::format("{}: expected a non-empty array of presets or techniques", name));
    check_configuration_count(list.size(), fmt::format("--configs {} ({} entries)", name, list.size()));
    std::vector<Config> out;
    for (std::size_t i = 0; i < list.size(); ++i) {
        const json& e = list[i];
        json j = base;
        std::string label;
        if (e.is_string()) {
            // As --preset NAME over the starting technique: the preset supplies the keys the
            // starting technique leaves out.
            if (!j.is_object()) j = json::object();
            j["preset"] = e;
            label = e.get<std::string>();
        } else if (e.is_object()) {
            json t = e;
            label = t.contains("name") && t["name"].is_string() ? t["name"].get<std::string>() : fmt::format("#{}", i);
            t.erase("name");
            j.merge_patch(t);
        } else {
            throw InputError(fmt::format("{}: [{}]: expected a preset name or a technique object", name, i));
        }
        Config c = parsed(j, fmt::format("{}: [{}]", name, i), lights);
        c.index = i;
        c.values = {label};
        out.push_back(std::move(c));
    }
    return out;
}

std::vector<Config> configs_from_file(const std::filesystem::path& file, const json& base,
                                      const std::vector<Light>& lights) {
    return configs_from_json(read_json_file(file, kSweepConfigsJson), escape_non_utf8(file.filename().string()), base,
                             lights);
}

Shard parse_shard(const std::string& text) {
    Shard s;
    const auto parts = split(text, '/');
    try {
        if (parts.size() != 2) throw std::invalid_argument("");
        std::size_t used = 0;
        s.k = std::stoi(parts[0], &used);
        if (used != parts[0].size()) throw std::invalid_argument("");
        s.n = std::stoi(parts[1], &used);
        if (used != parts[1].size()) throw std::invalid_argument("");
    } catch (const std::exception&) {
        throw InputError(fmt::format("--shard {}: expected K/N, e.g. 2/3", escape_non_utf8(text)));
    }
    if (s.n < 1 || s.k < 1 || s.k > s.n) throw InputError(fmt::format("--shard {}: needs 1 <= K <= N", text));
    return s;
}

std::size_t shard_size(std::size_t total, Shard s) {
    const auto n = static_cast<std::size_t>(s.n), k = static_cast<std::size_t>(s.k);
    return total / n + (k - 1 < total % n ? 1 : 0);
}

WorkEstimate estimate_work(std::size_t total, std::size_t in_run, int repeat, std::size_t lights) {
    WorkEstimate w;
    const double renders_per_config = 1.0 + 2.0 * repeat;
    w.seconds = static_cast<double>(in_run) * (kVerdictSeconds + renders_per_config * kRenderSeconds);
    w.bytes = total * kConfigBytes + in_run * (kRowBytes + lights * kRowLightBytes);
    return w;
}

void check_work(std::size_t total, std::size_t in_run, int repeat, std::size_t lights, std::uint64_t memory_budget,
                const std::string& what) {
    auto fits = [&](const WorkEstimate& w) {
        return w.seconds <= kMaxRunSeconds && (!memory_budget || w.bytes <= memory_budget);
    };
    const WorkEstimate w = estimate_work(total, in_run, repeat, lights);
    if (fits(w)) return;
    // The smallest N whose every shard fits (the first shard is the largest).
    std::string split = "no --shard fits: the list of configurations alone is beyond the memory budget";
    for (std::size_t n = 2; n <= total; ++n)
        if (fits(estimate_work(total, shard_size(total, {1, static_cast<int>(n)}), repeat, lights))) {
            split = fmt::format("split it across machines with --shard K/N, N >= {}", n);
            break;
        }
    const bool slow = w.seconds > kMaxRunSeconds;
    throw InputError(fmt::format(
        "sweep: {}: {} of {} configurations in this run x (1 + 2 x {} repeats) renders: about {:.1f} h at ~{} s a "
        "verdict and ~{} s a render, and {} of memory; beyond {} (docs/sweep.md, \"Limits\"); {}",
        what, in_run, total, repeat, w.seconds / 3600, kVerdictSeconds, kRenderSeconds, format_bytes(w.bytes),
        slow ? fmt::format("{:.0f} h a run", kMaxRunSeconds / 3600) : "--max-memory " + format_bytes(memory_budget),
        split));
}

std::string definition_fingerprint(const std::string& oracle_key, const json& base, std::span<const std::string> keys,
                                   std::span<const Config> all, double tolerance, int repeat, const json& device) {
    json configs = json::array();
    for (const Config& c : all) configs.push_back({c.index, c.values, c.technique.to_json()});
    const json definition = {{"oracle", oracle_key},
                             {"base", base},
                             {"keys", keys},
                             {"configurations", configs},
                             {"tolerance", fmt::format("{:.17g}", tolerance)},
                             {"repeat", repeat},
                             {"device", device}};
    return content_fingerprint(definition.dump(-1, ' ', false, json::error_handler_t::replace));
}

double median(std::vector<double> v) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}
double minimum(const std::vector<double>& v) {
    return v.empty() ? 0 : *std::min_element(v.begin(), v.end());
}

double maximum(const std::vector<double>& v) {
    return v.empty() ? 0 : *std::max_element(v.begin(), v.end());
}

double spread(const std::vector<double>& v) {
    const double m = median(v);
    return v.size() < 2 || m <= 0 ? 0 : (maximum(v) - minimum(v)) / m;
}

bool repeats_disagree(const Row& r) {
    return spread(r.production_ms) > kRepeatSpreadMargin || spread(r.diagnostic_ms) > kRepeatSpreadMargin;
}

json to_json(const Table& t) {
    auto spread_json = [](const std::vector<double>& v) {
        return json{{"min", minimum(v)}, {"median", median(v)}, {"max", maximum(v)}, {"spread", spread(v)}};
    };
    json rows = json::array();
    for (const Row& r : t.rows) {
        json verdict = json::object();
        for (std::size_t c = 0; c < t.columns.size(); ++c) verdict[t.columns[c]] = r.verdict[c];
        rows.push_back({{"index", r.index},
                        {"values", r.values},
                        {"technique", r.technique},
                        {"verdict", verdict},
                        {"lights", r.lights},
                        {"production_ms", r.production_ms},
                        {"diagnostic_ms", r.diagnostic_ms},
                        {"production_spread", spread_json(r.production_ms)},
                        {"diagnostic_spread", spread_json(r.diagnostic_ms)},
                        {"repeats_disagree", repeats_disagree(r)},
                        {"seconds", r.seconds}});
    }
    json j = {{"scenario", t.scenario}, {"keys", t.keys},     {"columns", t.columns},  {"total", t.total},
              {"repeat", t.repeat},     {"device", t.device}, {"configurations", rows}};
    j["fingerprint"] = t.fingerprint;
    j["setup_s"] = t.setup_s;
    // What the figures include and how they were taken (constants of this version: a merged
    // table says what each shard's run did).
    j["timings"] = {{"production_ms", kProductionMsIncludes},
                    {"diagnostic_ms", kDiagnosticMsIncludes},
                    {"warm_up_renders", kWarmUpRenders},
                    {"spread", "(max - min) / median of the repeats"},
                    {"spread_margin", kRepeatSpreadMargin}};
    if (t.shard.n > 1) j["shard"] = {{"k", t.shard.k}, {"n", t.shard.n}};
    return j;
}

Table table_from_json(const json& j, const std::string& label) {
    Table t;
    JsonObject top(j, label, "");
    t.scenario = top.string("scenario");
    t.keys = strings_at(top, "keys", 0);
    if (t.keys.empty()) top.fail("keys", "expected at least one varied key");
    for (std::size_t i = 0; i < t.keys.size(); ++i) {
        if (t.keys[i].empty()) top.fail(fmt::format("keys[{}]", i), "an empty key");
        for (std::size_t k = 0; k < i; ++k)
            if (t.keys[k] == t.keys[i]) top.fail(fmt::format("keys[{}]", i), "the key appears twice");
    }
    t.columns = strings_at(top, "columns", 0);
    if (t.columns.empty() || t.columns[0] != "wrong_fraction")
        top.fail("columns", "expected the verdict columns, wrong_fraction first");
    for (std::size_t i = 0; i < t.columns.size(); ++i)
        for (std::size_t k = 0; k < i; ++k)
            if (t.columns[k] == t.columns[i]) top.fail(fmt::format("columns[{}]", i), "the column appears twice");
    t.total = static_cast<std::size_t>(top.integer("total", 1, static_cast<long long>(kMaxConfigurations)));
    t.repeat = static_cast<int>(top.integer("repeat", 1, kMaxRepeat));
    JsonObject device = top.object("device");
    device.string("name");
    device.string("driver");
    t.device = top.get("device");
    t.fingerprint = top.string("fingerprint");
    if (t.fingerprint.size() != 32 || t.fingerprint.find_first_not_of("0123456789abcdef") != std::string::npos)
        top.fail("fingerprint", "expected 32 hex digits (shards written by this version of penumbra sweep)");
    t.setup_s = top.number_in("setup_s", 0, DBL_MAX, "expected a time >= 0");
    if (top.has("shard")) {
        JsonObject s = top.object("shard");
        t.shard.n = static_cast<int>(s.integer("n", 2, std::numeric_limits<int>::max()));
        t.shard.k = static_cast<int>(s.integer("k", 1, t.shard.n));
    }
    const json& rows = array_at(top, "configurations");
    std::set<std::size_t> seen;
    for (std::size_t i = 0; i < rows.size(); ++i) {
        JsonObject r(rows[i], label, fmt::format("configurations[{}]", i));
        Row row;
        row.index = static_cast<std::size_t>(r.integer("index", 0, static_cast<long long>(t.total) - 1));
        if (static_cast<int>(row.index % static_cast<std::size_t>(t.shard.n)) != t.shard.k - 1)
            r.fail("index", fmt::format("configuration {} is not in shard {}/{}", row.index, t.shard.k, t.shard.n));
        if (!seen.insert(row.index).second) r.fail("index", fmt::format("configuration {} appears twice", row.index));
        row.values = strings_at(r, "values", t.keys.size());
        r.object("technique");
        row.technique = r.get("technique");
        JsonObject verdict = r.object("verdict");
        for (const auto& c : t.columns)
            row.verdict.push_back(is_fraction(c) ? verdict.number_in(c, 0, 1, "expected a fraction in [0, 1]")
                                                 : verdict.number(c));
        row.lights = array_at(r, "lights");
        for (std::size_t l = 0; l < row.lights.size(); ++l)
            if (!row.lights[l].is_object()) r.fail(fmt::format("lights[{}]", l), "expected an object");
        row.production_ms = times_at(r, "production_ms", static_cast<std::size_t>(t.repeat));
        row.diagnostic_ms = times_at(r, "diagnostic_ms", static_cast<std::size_t>(t.repeat));
        row.seconds = r.number_in("seconds", 0, DBL_MAX, "expected a time >= 0");
        t.rows.push_back(std::move(row));
    }
    return t;
}

Table read_shard(const std::string& json_text, const std::optional<std::string>& csv_text, const std::string& folder) {
    const std::string json_label = folder + "/sweep.json";
    Table t = table_from_json(parse_json_strict(json_text, json_label), json_label);
    if (csv_text) {
        // sweep.csv is written from the same table: any other text means one of the two files
        // was edited or comes from another run, and merge cannot tell which to trust.
        const std::vector<std::string> expected = split(sweep_csv(t), '\n'), got = split(*csv_text, '\n');
        for (std::size_t i = 0; i < std::max(expected.size(), got.size()); ++i) {
            const std::string* e = i < expected.size() ? &expected[i] : nullptr;
            const std::string* g = i < got.size() ? &got[i] : nullptr;
            if (e && g && *e == *g) continue;
            const std::string what = i == 0                  ? "the header"
                                     : i - 1 < t.rows.size() ? fmt::format("configuration {}", t.rows[i - 1].index)
                                                             : std::string("no configuration");
            throw InputError(
                fmt::format("{}/sweep.csv: {} does not match sweep.json ({}{}); the shard's files were "
                            "edited or come from different runs",
                            folder, fmt::format("line {}", i + 1), what, g ? "" : ": the line is missing"));
        }
    }
    return t;
}

Table merge(std::vector<Table> shards, std::span<const std::string> labels) {
    if (shards.empty()) throw InputError("merge: no shard folders given");
    Table out = shards.front();
    out.rows.clear();
    out.shard = {};
    std::map<std::size_t, std::string> from;
    for (std::size_t s = 0; s < shards.size(); ++s) {
        const Table& t = shards[s];
        const std::string& name = labels[s];
        auto differs = [&](const char* what) {
            return InputError(
                fmt::format("{} and {}: shards of different sweeps: their {} differ", labels[0], name, what));
        };
        if (t.keys != out.keys) throw differs("varied keys");
        if (t.columns != out.columns) throw differs("columns");
        if (t.total != out.total) throw differs("numbers of configurations");
        if (t.repeat != out.repeat) throw differs("--repeat");
        if (t.device != out.device) throw differs("devices");
        if (t.fingerprint != out.fingerprint)
            throw differs("definitions (fingerprints: scenario content, starting technique, values, tolerance)");
        for (const Row& r : t.rows) {
            if (r.index >= t.total || r.values.size() != t.keys.size() || r.verdict.size() != t.columns.size())
                throw InputError(fmt::format("{}: configuration {} does not fit the sweep's shape", name, r.index));
            if (auto it = from.find(r.index); it != from.end())
                throw InputError(fmt::format("{}: configuration {} is also in {}", name, r.index, it->second));
            from[r.index] = name;
            out.rows.push_back(r);
        }
    }
    if (from.size() != out.total) {
        std::size_t missing = 0;
        while (from.count(missing)) ++missing;
        throw InputError(fmt::format("merge: {} of {} configurations; configuration {} is in no shard given",
                                     from.size(), out.total, missing));
    }
    std::sort(out.rows.begin(), out.rows.end(), [](const Row& a, const Row& b) { return a.index < b.index; });
    return out;
}

std::string sweep_csv(const Table& t) {
    auto quoted = [](const std::string& s) {
        if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
        std::string q = "\"";
        for (char ch : s) q += ch == '"' ? std::string("\"\"") : std::string(1, ch);
        return q + "\"";
    };
    std::string s;
    for (const auto& k : t.keys) s += quoted(k) + ",";
    for (const auto& c : t.columns) s += quoted(c) + ",";
    s += "production_ms,diagnostic_ms,production_ms_min,diagnostic_ms_min\n";
    for (const Row& r : t.rows) {
        for (const auto& v : r.values) s += quoted(v) + ",";
        for (double v : r.verdict) s += fmt::format("{:.9g},", v);
        s += fmt::format("{:.4f},{:.4f},{:.4f},{:.4f}\n", median(r.production_ms), median(r.diagnostic_ms),
                         minimum(r.production_ms), minimum(r.diagnostic_ms));
    }
    return s;
}

}  // namespace penumbra::sweep
