#include "sweep/sweep.h"

#include <fmt/format.h>

#include <algorithm>
#include <map>

#include "common/errors.h"
#include "common/json_reader.h"
#include "common/stopwatch.h"
#include "metrics/metric_table.h"

namespace penumbra::sweep {
namespace {

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

Config parsed(const nlohmann::json& j, const std::string& label, const std::vector<Light>& lights) {
    Config c;
    c.technique = raster::parse_technique(j, label, lights);
    return c;
}

// The GPU milliseconds an engine pays for the shadow: the map, the lookup, the mask (averaged
// area lights). The camera pass is drawn once per session and is not part of a configuration.
double shadow_cost_ms(const raster::RasterStats& s) {
    return s.shadow_ms + s.lookup_ms + s.mask_ms;
}

}  // namespace

Axis parse_axis(const std::string& argument) {
    const std::size_t eq = argument.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == argument.size())
        throw InputError(fmt::format("--vary {}: expected KEY=V1,V2,...", argument));
    Axis a;
    a.key = argument.substr(0, eq);
    a.values = split(argument.substr(eq + 1), ',');
    for (const auto& v : a.values)
        if (v.empty()) throw InputError(fmt::format("--vary {}: an empty value", argument));
    return a;
}

std::vector<Config> expand(const nlohmann::json& base, std::span<const Axis> axes, const std::vector<Light>& lights) {
    std::vector<Config> out;
    std::vector<std::size_t> at(axes.size(), 0);
    while (true) {
        nlohmann::json j = base;
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

std::vector<Config> configs_from_file(const std::filesystem::path& file, const nlohmann::json& base,
                                      const std::vector<Light>& lights) {
    const nlohmann::json list = read_json_file(file);
    const std::string name = file.filename().string();
    if (!list.is_array() || list.empty())
        throw InputError(fmt::format("{}: expected a non-empty array of presets or techniques", name));
    std::vector<Config> out;
    for (std::size_t i = 0; i < list.size(); ++i) {
        const nlohmann::json& e = list[i];
        nlohmann::json j = base;
        std::string label;
        if (e.is_string()) {
            j = {{"preset", e.get<std::string>()}};
            label = e.get<std::string>();
        } else if (e.is_object()) {
            nlohmann::json t = e;
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
        throw InputError(fmt::format("--shard {}: expected K/N, e.g. 2/3", text));
    }
    if (s.n < 1 || s.k < 1 || s.k > s.n) throw InputError(fmt::format("--shard {}: needs 1 <= K <= N", text));
    return s;
}

std::vector<std::string> verdict_columns(const Scenario& scenario) {
    std::vector<std::string> c = {"wrong_fraction", "mae"};
    for (auto cls : metrics::kErrorClasses) c.push_back("rates." + std::string(metrics::to_string(cls)));
    c.push_back("perceptual.mean");
    if (std::any_of(scenario.lights.begin(), scenario.lights.end(),
                    [](const Light& l) { return is_area_light(l.type); })) {
        c.push_back("soft.penumbra_mae");
        c.push_back("soft.penumbra_width_error");
    }
    return c;
}

double median(std::vector<double> v) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}
double minimum(const std::vector<double>& v) {
    return v.empty() ? 0 : *std::min_element(v.begin(), v.end());
}

Table run_sweep(const Scenario& scenario, const std::string& scenario_name, std::span<const std::string> keys,
                std::span<const Config> configs, std::size_t total, Shard shard, const SweepOptions& options,
                const raster::VulkanContext& ctx) {
    Table t;
    t.scenario = scenario_name;
    t.keys.assign(keys.begin(), keys.end());
    t.columns = verdict_columns(scenario);
    t.total = total;
    t.repeat = options.repeat;
    t.device = {{"name", ctx.info().name}, {"driver", ctx.info().driver}};
    t.shard = shard;
    const auto t0 = SteadyClock::now();
    auto oracle = std::make_shared<const OracleRun>(oracle_for(scenario, options.validate));
    raster::RasterSession session(scenario, ctx);
    t.setup_s = seconds_since(t0);
    ValidateOptions diagnostic = options.validate;
    diagnostic.render.lookups = true;
    diagnostic.render.reuse_maps = false;  // a timing: every pass is drawn
    raster::RenderOptions production;
    production.lookups = false;
    production.reuse_maps = false;
    const metrics::Gate no_gate;
    std::vector<const metrics::Metric*> metrics;
    for (const auto& c : t.columns) metrics.push_back(metrics::find_metric(c));
    for (const Config& c : configs) {
        const auto tc = SteadyClock::now();
        Row row;
        row.index = c.index;
        row.values = c.values;
        row.technique = c.technique.to_json();
        // The verdict's render also builds (and, on lavapipe, compiles) the pipelines; it is not
        // timed, nor is a first production render for the same reason.
        const ValidateResult r = validate(scenario, c.technique, no_gate, diagnostic, &session, oracle);
        for (int k = 0; k < options.repeat; ++k)
            row.diagnostic_ms.push_back(shadow_cost_ms(session.render(c.technique, diagnostic.render).stats));
        session.render(c.technique, production);
        for (int k = 0; k < options.repeat; ++k)
            row.production_ms.push_back(shadow_cost_ms(session.render(c.technique, production).stats));
        row.lights = nlohmann::json::array();
        for (const auto& l : r.score.lights) row.lights.push_back(metrics::to_json(l));
        for (const metrics::Metric* m : metrics) {
            double sum = 0, weight = 0;
            for (const auto& l : r.score.lights)
                if (auto v = metrics::value_of(*m, l)) {
                    sum += *v * static_cast<double>(l.pixels.scored);
                    weight += static_cast<double>(l.pixels.scored);
                }
            row.verdict.push_back(weight > 0 ? sum / weight : 0.0);
        }
        row.seconds = seconds_since(tc);
        t.rows.push_back(std::move(row));
        if (options.progress) options.progress(t.rows.back(), t.rows.size(), configs.size());
    }
    return t;
}

nlohmann::json to_json(const Table& t) {
    nlohmann::json rows = nlohmann::json::array();
    for (const Row& r : t.rows) {
        nlohmann::json verdict = nlohmann::json::object();
        for (std::size_t c = 0; c < t.columns.size(); ++c) verdict[t.columns[c]] = r.verdict[c];
        rows.push_back({{"index", r.index},
                        {"values", r.values},
                        {"technique", r.technique},
                        {"verdict", verdict},
                        {"lights", r.lights},
                        {"production_ms", r.production_ms},
                        {"diagnostic_ms", r.diagnostic_ms},
                        {"seconds", r.seconds}});
    }
    nlohmann::json j = {{"scenario", t.scenario}, {"keys", t.keys},     {"columns", t.columns},  {"total", t.total},
                        {"repeat", t.repeat},     {"device", t.device}, {"configurations", rows}};
    if (t.shard.n > 1) j["shard"] = {{"k", t.shard.k}, {"n", t.shard.n}};
    return j;
}

Table table_from_json(const nlohmann::json& j, const std::string& label) {
    Table t;
    try {
        t.scenario = j.at("scenario").get<std::string>();
        t.keys = j.at("keys").get<std::vector<std::string>>();
        t.columns = j.at("columns").get<std::vector<std::string>>();
        t.total = j.at("total").get<std::size_t>();
        t.repeat = j.at("repeat").get<int>();
        t.device = j.at("device");
        t.setup_s = j.value("setup_s", 0.0);
        if (j.contains("shard")) t.shard = {j["shard"].at("k").get<int>(), j["shard"].at("n").get<int>()};
        for (const auto& r : j.at("configurations")) {
            Row row;
            row.index = r.at("index").get<std::size_t>();
            row.values = r.at("values").get<std::vector<std::string>>();
            row.technique = r.at("technique");
            for (const auto& c : t.columns) row.verdict.push_back(r.at("verdict").at(c).get<double>());
            row.lights = r.at("lights");
            row.production_ms = r.at("production_ms").get<std::vector<double>>();
            row.diagnostic_ms = r.at("diagnostic_ms").get<std::vector<double>>();
            row.seconds = r.value("seconds", 0.0);
            t.rows.push_back(std::move(row));
        }
    } catch (const nlohmann::json::exception& e) {
        throw InputError(fmt::format("{}: not a sweep.json: {}", label, e.what()));
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
            return InputError(fmt::format("{}: its {} differs from {}'s", name, what, labels[0]));
        };
        if (t.scenario != out.scenario) throw differs("scenario");
        if (t.keys != out.keys) throw differs("varied keys");
        if (t.columns != out.columns) throw differs("columns");
        if (t.total != out.total) throw differs("number of configurations");
        if (t.repeat != out.repeat) throw differs("--repeat");
        if (t.device != out.device) throw differs("device");
        for (const Row& r : t.rows) {
            if (r.index >= t.total)
                throw InputError(fmt::format("{}: configuration {} is beyond the sweep's {}", name, r.index, t.total));
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
        if (s.find_first_of(",\"\n") == std::string::npos) return s;
        std::string q = "\"";
        for (char ch : s) q += ch == '"' ? std::string("\"\"") : std::string(1, ch);
        return q + "\"";
    };
    std::string s;
    for (const auto& k : t.keys) s += quoted(k) + ",";
    for (const auto& c : t.columns) s += c + ",";
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
