// `penumbra units`: a shadow bias converted from one engine's parameters to another's (or to
// penumbra's technique keys) for one light's map of a scenario (docs/units.md).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include "app/cli.h"
#include "common/errors.h"
#include "engines/engine_units.h"
#include "raster/cascades.h"

namespace penumbra::cli {
namespace {

struct UnitsArgs {
    std::filesystem::path scenario;
    std::vector<std::string> assignments, assume;
    std::size_t light = 0;
    std::string from, to;
    std::optional<double> angle_deg;
    bool json = false;
    bool allow_external_paths = false;
    TechniqueArgs technique;
};

// The JSON path of the first number in `j` that is not finite ("" when all are): a conversion of
// huge inputs (1e308) overflows, and must be refused rather than printed as inf or null.
std::string non_finite_at(const nlohmann::json& j, const std::string& path) {
    if (j.is_number_float() && !std::isfinite(j.get<double>())) return path.empty() ? "(top level)" : path;
    if (j.is_object())
        for (auto it = j.begin(); it != j.end(); ++it)
            if (auto p = non_finite_at(*it, path.empty() ? it.key() : path + "." + it.key()); !p.empty()) return p;
    if (j.is_array())
        for (std::size_t i = 0; i < j.size(); ++i)
            if (auto p = non_finite_at(j[i], fmt::format("{}[{}]", path, i)); !p.empty()) return p;
    return {};
}

std::string describe_values(const nlohmann::json& values) {
    std::string s;
    for (auto it = values.begin(); it != values.end(); ++it)
        s += fmt::format("{}{} = {}", s.empty() ? "" : ", ", it.key(),
                         it->is_number() ? fmt::format("{:.9g}", it->get<double>()) : it->dump());
    return s;
}

int run_units_command(const UnitsArgs& a) {
    // Everything the user wrote is checked before the scene is read.
    engines::engine_info(a.from, "--from");
    engines::engine_info(a.to, "--to");
    engines::EngineBias from = engines::parse_engine_bias(a.from, a.assignments, "--from " + a.from);
    const nlohmann::json to_assumptions = engines::parse_engine_bias(a.to, a.assume, "--assume", true).assumptions;

    Common c;
    c.allow_external_paths = a.allow_external_paths;
    c.quiet = a.json;
    const Scenario s = load_for_command(a.scenario, c);
    const raster::Technique t = resolve_technique(s, a.technique);
    if (a.light >= s.lights.size())
        throw InputError(
            fmt::format("--light: {} is not a light of {} (it has {})", a.light, s.label, s.lights.size()));
    const Light& light = s.lights[a.light];
    // `--from penumbra` without values converts the technique's own bias for the light (what
    // `--technique tuned.json` means), not penumbra's zero defaults.
    const bool from_technique = a.from == "penumbra" && a.assignments.empty();
    if (from_technique) {
        const nlohmann::json tj = t.for_light(a.light).to_json();
        std::vector<std::string> values;
        if (tj.contains("bias"))
            for (auto it = tj["bias"].begin(); it != tj["bias"].end(); ++it) {
                if (it->is_object()) {
                    for (auto k = it->begin(); k != it->end(); ++k)
                        values.push_back(fmt::format("{}.{}={}", it.key(), k.key(),
                                                     k->is_string() ? k->get<std::string>() : k->dump()));
                } else {
                    values.push_back(
                        fmt::format("{}={}", it.key(), it->is_string() ? it->get<std::string>() : it->dump()));
                }
            }
        from = engines::parse_engine_bias(a.from, values, "the technique's bias");
    }
    const engines::ReferenceReceiver ref = engines::reference_receiver(s, light, a.angle_deg);
    const std::vector<engines::MapContext> maps = engines::map_contexts(s, t, a.light, ref);

    std::vector<std::string> notes;
    const bool all_zero = std::none_of(from.values.begin(), from.values.end(),
                                       [](const nlohmann::json& v) { return v.is_number() && v.get<double>() != 0.0; });
    if (all_zero)
        notes.push_back(
            fmt::format("every value converted is 0 ({}): give the --from engine's values as KEY=VALUE{}",
                        from_technique ? "the technique has no bias" : "the --from engine's defaults",
                        a.from == "penumbra" ? ", or a technique with a bias (--technique tuned.json)" : ""));
    if (maps.size() > 1)
        notes.push_back(fmt::format(
            "{} cascades, each with its own texel and depth range, so each gets its own values; the maps are the "
            "technique's ({}): a technique that draws other maps (another preset) gets other numbers",
            maps.size(), t.preset.empty() ? t.family : "preset " + t.preset));
    if (from.engine == "penumbra" &&
        (from.values.value("clamp", 0.0) != 0.0 || from.values.value("receiver_plane", false)))
        notes.push_back("bias.clamp and bias.receiver_plane are not part of the conversion");
    if (light.type != LightType::directional)
        notes.push_back(
            "a spot or point light: the engines' directional formulas are applied to penumbra's map (texel and depth "
            "at the reference receiver); their own spot/point factors are not modelled");
    if (const raster::Cascades* cascades = raster::cascades_of(t); cascades && cascades->sdsm)
        notes.push_back(
            "cascades.sdsm: the splits follow the visible samples, a GPU reduction; these cascades are the camera "
            "range's");
    if (engines::engine_info(a.from).unverified || engines::engine_info(a.to).unverified)
        notes.push_back("unreal: formulas from a third-party copy of the engine, defaults unverified");

    nlohmann::json out_maps = nlohmann::json::array();
    for (const engines::MapContext& m : maps) {
        const engines::EngineBias to = engines::convert(from, a.to, m, to_assumptions);
        const engines::Clearance cl = engines::clearance(from, m);
        nlohmann::json j = engines::to_json(m);
        j["clearance_m"] = {{"constant", cl.constant_m}, {"angular", cl.angular_m}, {"total", cl.total()}};
        j["values"] = a.to == "penumbra" ? engines::nested_bias(to.values) : to.values;
        j["assumptions"] = to.assumptions;
        if (const std::string at = non_finite_at(j, ""); !at.empty())
            throw InputError(fmt::format(
                "--from {} {}: the conversion overflows ({} is not a finite number); the values are far beyond any "
                "shadow bias",
                from.engine, describe_values(from.values), at));
        out_maps.push_back(j);
    }
    const double angle_deg = ref.angle_rad * 180.0 / 3.14159265358979323846;
    if (a.json) {
        nlohmann::json j = {
            {"scenario", s.label},
            {"light", a.light},
            {"light_type", to_string(light.type)},
            {"technique", t.preset.empty() ? t.family : t.preset},
            {"from",
             {{"engine", from.engine},
              {"values", from.values},
              {"assumptions", from.assumptions},
              {"source", from_technique ? "technique" : "arguments"}}},
            {"to", a.to},
            {"reference",
             {{"angle_deg", angle_deg},
              {"source", ref.source},
              {"normal", {ref.normal.x, ref.normal.y, ref.normal.z}},
              {"point", {ref.point.x, ref.point.y, ref.point.z}},
              {"plane_area_m2", ref.area_m2}}},
            {"exact", "at the reference angle; everywhere when both engines' offsets have the same angular factor"},
            {"maps", out_maps},
            {"notes", notes}};
        fmt::print("{}\n", j.dump(2));
        return kExitSuccess;
    }
    fmt::print("units: {} light {} ({}), {} -> {}\n", s.label, a.light, light.origin, from.engine, a.to);
    fmt::print("  from: {}{}", from_technique ? "the technique's bias: " : "", describe_values(from.values));
    if (!from.assumptions.empty()) fmt::print(" (assuming {})", describe_values(from.assumptions));
    fmt::print(
        "\n  reference receiver: {:.2f} deg between its normal and the light ({}; plane of {:.4g} m^2 at "
        "({:.3g}, {:.3g}, {:.3g}))\n",
        angle_deg, ref.source, ref.area_m2, ref.point.x, ref.point.y, ref.point.z);
    for (const nlohmann::json& m : out_maps) {
        const std::string where =
            m["cascade"].is_null() ? std::string("map") : fmt::format("cascade {}", m["cascade"].get<int>());
        fmt::print("  {}: texel {:.4g} m, depth range {:.4g} m, clearance {:.4g} m\n", where,
                   m["texel_m"].get<double>(), m["depth_range_m"].get<double>(),
                   m["clearance_m"]["total"].get<double>());
        if (a.to == "penumbra")
            fmt::print("    \"bias\": {}\n", m["values"].dump());
        else
            fmt::print(
                "    {}{}\n", describe_values(m["values"]),
                m["assumptions"].empty() ? "" : fmt::format(" (assuming {})", describe_values(m["assumptions"])));
    }
    for (const auto& n : notes) fmt::print("  note: {}\n", n);
    return kExitSuccess;
}

}  // namespace

Subcommand add_units_command(CLI::App& parent) {
    auto a = std::make_shared<UnitsArgs>();
    CLI::App* cmd = parent.add_subcommand(
        "units", "Convert a shadow bias between engines' parameters (and penumbra's keys) for a scenario's light");
    add_scenario(cmd, a->scenario);
    cmd->add_option("PARAMS", a->assignments,
                    "KEY=VALUE: the --from engine's parameters and assumptions (the rest keep that engine's defaults)")
        ->check(kUserName);
    cmd->add_option("--light", a->light, "The scenario's light (index, default 0)")->check(CLI::NonNegativeNumber);
    std::string engines;
    for (const auto& e : engines::engine_names()) engines += (engines.empty() ? "" : ", ") + e;
    cmd->add_option("--from", a->from, "Engine the values are in: " + engines)->required()->check(kUserName);
    cmd->add_option("--to", a->to, "Engine to convert to: " + engines)->required()->check(kUserName);
    cmd->add_option("--assume", a->assume, "An assumption of the --to engine, KEY=VALUE (repeatable)")
        ->check(kUserName);
    cmd->add_option("--angle-deg", a->angle_deg,
                    "Reference receiver angle to the light, degrees (default: the scene's largest plane's)")
        ->check(range(0.0, 89.0));
    cmd->add_flag("--json", a->json, "Print JSON");
    cmd->add_flag("--allow-external-paths", a->allow_external_paths,
                  "Let glTF buffer URIs point outside the scene's folder");
    add_technique(cmd, a->technique);
    describe_outputs(cmd,
                     "Outputs: none; prints the converted parameters for each map (each cascade) of the light, or "
                     "JSON with --json.",
                     "penumbra units data/default/scenario.json --light 0 --from bevy --to three "
                     "shadow_depth_bias=0.02 shadow_normal_bias=1.8");
    return {cmd, [a] { return run_units_command(*a); }};
}

}  // namespace penumbra::cli
