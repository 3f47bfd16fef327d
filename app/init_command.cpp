// `penumbra init`: a scenario for a model penumbra has never seen (docs/quickstart.md). Reads the
// model with the loader's checks, says what it found (triangles, bounds, size, a unit that looks
// wrong), frames a camera on it, lights it and, with --ground, puts a receiver plane under it.
// The scenario it writes runs with `validate` as it is: init loads it back before it commits.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <glm/vector_relational.hpp>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>
#include <stdexcept>

#include "app/cli.h"
#include "common/errors.h"
#include "common/framing.h"
#include "common/gltf_loader.h"
#include "common/json_reader.h"
#include "common/memory_estimate.h"
#include "common/model_placement.h"
#include "common/output_files.h"

namespace penumbra::cli {
namespace {
namespace fs = std::filesystem;
using ordered_json = nlohmann::ordered_json;

struct InitArgs {
    std::vector<fs::path> models;
    std::string up = "auto";  // auto, y or z: which axis of each model is up
    fs::path out;
    bool ground = false;
    std::string sun;  // "ELEV,AZIM" in degrees; empty: the default sun
    double scale = 1.0;
    int width = 1280, height = 720;
    bool force = false;
    bool allow_external_paths = false;
    bool quiet = false;
};

struct SunAngles {
    double elevation = kInitSunElevationDeg, azimuth = kInitSunAzimuthDeg;
};

// --sun ELEV,AZIM: "" when fine, else what is wrong (a CLI11 check, exit 2 before any work).
std::optional<SunAngles> parse_sun(const std::string& text, std::string& problem) {
    const auto comma = text.find(',');
    double v[2] = {0, 0};
    const std::string parts[2] = {text.substr(0, comma), comma == std::string::npos ? "" : text.substr(comma + 1)};
    for (int i = 0; i < 2; ++i) {
        std::size_t used = 0;
        try {
            v[i] = std::stod(parts[i], &used);
        } catch (const std::exception&) {
            used = 0;
        }
        if (comma == std::string::npos || used == 0 || used != parts[i].size() || !std::isfinite(v[i])) {
            problem = fmt::format("\"{}\": expected ELEV,AZIM in degrees, e.g. 45,-30", escape_non_utf8(text));
            return std::nullopt;
        }
    }
    if (!(v[0] > 0 && v[0] <= 90)) {
        problem = fmt::format("elevation {:g} is not in (0, 90] degrees", v[0]);
        return std::nullopt;
    }
    if (!(v[1] >= -360 && v[1] <= 360)) {
        problem = fmt::format("azimuth {:g} is not in [-360, 360] degrees", v[1]);
        return std::nullopt;
    }
    return SunAngles{v[0], v[1]};
}

std::string sun_problem(const std::string& text) {
    std::string problem;
    parse_sun(text, problem);
    return problem;
}

// Coordinates rounded to a quantum (a power of ten) so that the file reads well: a millionth of
// the model's size keeps the view as framed. Dividing by an exact power of ten rounds correctly,
// so the number prints as its short decimal.
double rounded(double x, double quantum_exp10) {
    const double q = std::pow(10.0, std::abs(quantum_exp10));
    return quantum_exp10 < 0 ? std::round(x * q) / q : std::round(x / q) * q;
}

ordered_json vec(const glm::dvec3& v, double quantum_exp10 = -6) {
    return ordered_json::array({rounded(v.x, quantum_exp10), rounded(v.y, quantum_exp10), rounded(v.z, quantum_exp10)});
}

// JSON on one line, with spaces after separators.
std::string compact(const ordered_json& j) {
    std::string out;
    if (j.is_object()) {
        for (const auto& [key, value] : j.items())
            out += (out.empty() ? "{" : ", ") + ordered_json(key).dump() + ": " + compact(value);
        return out.empty() ? "{}" : out + "}";
    }
    if (j.is_array()) {
        for (const auto& value : j) out += (out.empty() ? "[" : ", ") + compact(value);
        return out.empty() ? "[]" : out + "]";
    }
    return j.dump();
}

// The scenario as a person would write it: a key per line, a light or receiver per line.
std::string scenario_text(const ordered_json& doc) {
    std::string out = "{\n";
    std::size_t i = 0;
    for (const auto& [key, value] : doc.items()) {
        out += "  " + ordered_json(key).dump() + ": ";
        if (value.is_array() && !value.empty() && value[0].is_object()) {
            out += "[\n";
            for (std::size_t e = 0; e < value.size(); ++e)
                out += "    " + compact(value[e]) + (e + 1 < value.size() ? ",\n" : "\n");
            out += "  ]";
        } else {
            out += compact(value);
        }
        out += ++i < doc.size() ? ",\n" : "\n";
    }
    return out + "}\n";
}

// Rounded up to two significant digits: a far plane that reads well and still lies beyond.
double rounded_up(double x) {
    if (!(x > 0)) return x;
    const double q = std::pow(10.0, std::floor(std::log10(x)) - 1);
    return std::ceil(x / q) * q;
}
// The far plane's margin past the farthest corner the camera looks at.
constexpr double kInitFarMargin = 1.05;

std::string vec_text(const glm::dvec3& v) {
    return fmt::format("[{:.4g}, {:.4g}, {:.4g}]", v.x, v.y, v.z);
}

// The first glTF camera a node places, when it passes the scenario's camera checks.
std::optional<std::size_t> usable_gltf_camera(const Scene& scene, const std::string& model_label, bool quiet) {
    for (std::size_t i = 0; i < scene.cameras.size(); ++i) {
        if (!scene.camera_placed[i]) continue;
        try {
            validate_camera(scene.cameras[i], fmt::format("{}: cameras[{}]", model_label, i));
            return i;
        } catch (const InputError& e) {
            if (!quiet) fmt::print(stderr, "warning: {}; framing a camera instead\n", e.what());
            return std::nullopt;
        }
    }
    return std::nullopt;
}

bool gltf_lights_usable(const Scene& scene, const std::string& model_label, bool quiet) {
    if (scene.lights.empty()) return false;
    try {
        for (const Light& l : scene.lights) validate_light(l, fmt::format("{}: {}", model_label, l.origin));
    } catch (const InputError& e) {
        if (!quiet) fmt::print(stderr, "warning: {}; adding a sun instead\n", e.what());
        return false;
    }
    return true;
}

int run_init_command(const InitArgs& a) {
    const std::string out_text = path_text(a.out);
    std::error_code ec;
    if (fs::is_directory(a.out, ec))
        throw InputError(fmt::format("--out {}: is a folder; expected the scenario file to write", out_text));
    if (fs::exists(a.out, ec) && !a.force)
        throw InputError(fmt::format("--out {}: exists; pass --force to overwrite it", out_text));
    // --force replaces a regular file only, never a FIFO, a device or a link (#50): refused now,
    // before the model is read.
    if (std::string why = replaceable_target_problem(a.out); !why.empty())
        throw InputError(fmt::format("--out {}", why));
    for (const fs::path& model : a.models)
        if (fs::equivalent(a.out, model, ec))  // --force would replace the model with its scenario
            throw InputError(fmt::format("--out {}: is the model itself", out_text));
    const fs::path out_parent = fs::absolute(a.out).parent_path();
    if (std::string p = output_folder_problem(out_parent.string()); !p.empty())
        throw InputError(fmt::format("--out {}: {}", out_text, p));
    if (static_cast<long long>(a.width) * a.height > kMaxImagePixels)
        throw InputError(
            fmt::format("--width {} --height {}: more than the {} pixel limit", a.width, a.height, kMaxImagePixels));
    for (const fs::path& model : a.models) {
        std::string ext = model.extension().string();
        std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return std::tolower(ch); });
        if (ext != ".gltf" && ext != ".glb")
            throw InputError(fmt::format("{}: expected a glTF 2.0 file (.gltf or .glb)", path_text(model)));
    }

    GltfLoadOptions options;
    options.allow_external_paths = a.allow_external_paths;
    options.max_memory_bytes = default_memory_budget();
    // The scenario's "scene" is relative to the scenario's folder (both resolved, as the
    // loader resolves them, so that symbolic links do not change what ".." means).
    const fs::path out_dir = fs::weakly_canonical(fs::absolute(a.out).parent_path());
    const bool several = a.models.size() > 1;
    Scene scene;
    ordered_json scene_entries = ordered_json::array();
    bool any_z_up = false;
    for (std::size_t i = 0; i < a.models.size(); ++i) {
        const fs::path& model = a.models[i];
        Scene part = load_gltf(model, options);
        const std::string model_label = path_text(model.filename());
        if (part.triangle_count() == 0)
            throw InputError(
                fmt::format("{}: no triangles in the default scene: nothing to frame or shadow", model_label));
        const fs::path model_abs = fs::weakly_canonical(fs::absolute(model));
        fs::path scene_rel = model_abs.lexically_relative(out_dir);
        if (scene_rel.empty()) scene_rel = model_abs;
        const std::string scene_text = scene_rel.generic_string();
        if (!is_valid_utf8(scene_text))
            throw InputError(
                fmt::format("{}: the path to the model from the scenario's folder is not UTF-8, which JSON "
                            "cannot hold; move or rename it",
                            path_text(scene_rel)));
        const std::string where = several ? fmt::format("{} (scene[{}])", model_label, i) : model_label;
        ModelPlacement placement;
        placement.scale = a.scale;
        if (a.up == "auto") {
            if (auto why = z_up_evidence(part)) {
                placement.z_up = true;
                if (!a.quiet)
                    fmt::print(stderr,
                               "warning: {} looks modelled with +Z up (a guess: {}); wrote \"up\": \"z\" to stand it "
                               "upright (init --up y keeps it as it is)\n",
                               where, *why);
            }
        } else {
            placement.z_up = a.up == "z";
        }
        any_z_up |= placement.z_up;
        const glm::dvec3 size = part.bounds.hi - part.bounds.lo;
        const double largest = std::max({size.x, size.y, size.z});
        if (!a.quiet) {
            fmt::print("{}: {} triangles\n", where, part.triangle_count());
            const bool site = looks_like_site(part);
            if (auto hint = unit_hint(size * a.scale, site)) {
                const std::string line =
                    several ? fmt::format("\"scale\": {:g} to scene[{}] of {}", hint->scale, i, out_text)
                            : fmt::format("\"scale\": {:g} to {} (or run init with --scale {:g})", hint->scale * a.scale,
                                          out_text, hint->scale * a.scale);
                fmt::print(stderr,
                           "warning: {} is {:.4g} m across{}, which suggests {} (a guess from its size): if so, add {}; "
                           "it is then {:.4g} m across\n",
                           where, largest * a.scale, site ? " and a terrain or site" : "", hint->unit, line,
                           largest * a.scale * hint->scale);
            } else if (site && largest * a.scale > kUnitHintAboveM) {
                fmt::print("{}: {:.4g} m across and flat or one open sheet: read as a terrain or site in metres "
                           "(glTF's unit, a guess); "
                           "\"scale\" sets other units\n",
                           where, largest * a.scale);
            }
        }
        place_model(part, placement);
        if (several) {
            ordered_json entry = scene_text;
            if (placement.z_up) entry = {{"model", scene_text}, {"up", "z"}};
            scene_entries.push_back(entry);
        } else {
            scene_entries = scene_text;
        }
        append_model(scene, std::move(part), several ? fmt::format("scene[{}]: {}", i, model_label) : "");
    }
    const std::string model_label =
        several ? fmt::format("{} models", a.models.size()) : path_text(a.models[0].filename());
    if (!a.quiet)
        for (const auto& w : scene.warnings) fmt::print(stderr, "warning: {}\n", w);

    const Bounds& b = scene.bounds;
    const glm::dvec3 size = b.hi - b.lo;
    const double largest = std::max({size.x, size.y, size.z});
    const double quantum = std::floor(std::log10(b.radius())) - 6;  // a millionth of the model, as a power of ten
    if (!a.quiet) {
        if (several) fmt::print("{}: {} triangles\n", model_label, scene.triangle_count());
        fmt::print("bounds: {} to {} m{}\n", vec_text(b.lo), vec_text(b.hi),
                   a.scale != 1.0 ? fmt::format(" (scaled by {:g})", a.scale) : "");
        fmt::print("size: {:.4g} x {:.4g} x {:.4g} m (bounding sphere radius {:.4g} m)\n", size.x, size.y, size.z,
                   b.radius());
    }
    const ModelView framed = frame_bounds(b, a.width, a.height);
    const Receiver ground = ground_plane(b);

    ordered_json doc;
    doc["scene"] = scene_entries;
    if (a.scale != 1.0) doc["scale"] = a.scale;
    if (!several && any_z_up) doc["up"] = "z";
    doc["image"] = {{"width", a.width}, {"height", a.height}};
    std::string camera_line, lights_line;
    // A far plane past everything the camera can see (cascades and engine presets split the view
    // up to it): the farthest corner of the scene's box and of the ground along the view.
    std::vector<glm::dvec3> corners;
    for (int k = 0; k < 8; ++k) corners.push_back({k & 1 ? b.hi.x : b.lo.x, k & 2 ? b.hi.y : b.lo.y, k & 4 ? b.hi.z : b.lo.z});
    if (a.ground)
        for (int k = 0; k < 4; ++k)
            corners.push_back(ground.center + 0.5 * glm::dvec3(k & 1 ? ground.size.x : -ground.size.x, 0,
                                                               k & 2 ? ground.size.y : -ground.size.y));
    const auto far_plane = [&](const glm::dvec3& eye, const glm::dvec3& forward) {
        double depth = 0;
        for (const glm::dvec3& c : corners) depth = std::max(depth, glm::dot(c - eye, forward));
        return rounded_up(kInitFarMargin * depth);
    };
    std::string far_line;
    if (auto index = usable_gltf_camera(scene, model_label, a.quiet)) {
        doc["camera"] = {{"gltf_camera", *index}};
        camera_line = fmt::format("the model's own, cameras[{}]", *index);
        const Camera& c = scene.cameras[*index];
        if (std::isinf(c.zfar)) {
            const double zfar = far_plane(c.eye, c.forward);
            if (zfar > c.znear) {
                doc["camera"]["zfar"] = zfar;
                far_line = fmt::format(", zfar {:g} m (the model's camera has none)", zfar);
            }
        }
    } else {
        const ModelView& v = framed;
        const double zfar = far_plane(v.eye, glm::normalize(v.target - v.eye));
        doc["camera"] = {{"type", "perspective"}, {"eye", vec(v.eye, quantum)}, {"target", vec(v.target, quantum)},
                         {"up", vec({0, 1, 0})},  {"yfov_deg", v.yfov_deg},     {"znear", rounded(v.znear, quantum)}};
        if (zfar > rounded(v.znear, quantum)) {
            doc["camera"]["zfar"] = zfar;
            far_line = fmt::format(", zfar {:g} m", zfar);
        }
        camera_line =
            fmt::format("a 3/4 view from above, {:.4g} m from the centre, yfov {:g} deg", v.distance, v.yfov_deg);
    }
    camera_line += far_line;
    if (a.sun.empty() && gltf_lights_usable(scene, model_label, a.quiet)) {
        doc["lights"] = "gltf";
        lights_line = fmt::format("the model's {} KHR_lights_punctual lights", scene.lights.size());
    } else {
        std::string unused;
        const SunAngles sun = a.sun.empty() ? SunAngles{} : *parse_sun(a.sun, unused);
        // The light travels from the sun's direction towards the model.
        doc["lights"] = ordered_json::array({{{"type", "directional"},
                                              {"name", "sun"},
                                              {"direction", vec(-direction_from_angles(sun.elevation, sun.azimuth))}}});
        lights_line =
            fmt::format("a sun at elevation {:g} deg, azimuth {:g} deg (--sun ELEV,AZIM)", sun.elevation, sun.azimuth);
    }
    if (a.ground) {
        const Receiver& g = ground;
        doc["receivers"] = ordered_json::array({{{"type", "plane"},
                                                 {"center", vec(g.center, quantum)},
                                                 {"normal", vec(g.normal)},
                                                 {"size", {rounded(g.size.x, quantum), rounded(g.size.y, quantum)}}}});
    }

    // A camera or ground around a model too small or too far out would leave the scenario's
    // limits (znear, sizes, coordinates): refused, pointing at --scale.
    const bool framed_camera = !doc["camera"].contains("gltf_camera");
    const glm::dvec3 ground_reach = glm::abs(ground.center) + 0.5 * glm::dvec3(ground.size.x, 0, ground.size.y);
    const bool too_small = b.radius() < 1e-9 && (framed_camera || a.ground);
    const bool too_far =
        (framed_camera && glm::any(glm::greaterThan(glm::abs(framed.eye), glm::dvec3(kMaxCoordinate)))) ||
        (a.ground &&
         (glm::any(glm::greaterThan(ground_reach, glm::dvec3(kMaxCoordinate))) || ground.size.x > kMaxExtent));
    if (too_small || too_far)
        throw InputError(
            fmt::format("{}: {:.4g} m across, {:.4g} m from the origin: a camera or ground around it "
                        "would leave the scenario's limits; --scale brings its units to metres",
                        model_label, largest, glm::length(b.center())));

    OutputTransaction tx(out_dir);
    const std::string name = a.out.filename().string();
    tx.write_text(name, scenario_text(doc));
    // The promise is that validate runs it as it is: load what was staged (it lies in the same
    // folder, so "scene" resolves the same) before it takes the name. A refusal here is init's bug.
    try {
        ScenarioOptions so;
        so.allow_external_paths = a.allow_external_paths;
        so.max_memory_bytes = options.max_memory_bytes;
        load_scenario(tx.stage(name), so);
    } catch (const InputError& e) {
        throw std::logic_error(fmt::format("the scenario init wrote does not load: {}", e.what()));
    }
    tx.commit();
    if (!a.quiet) {
        fmt::print("camera: {}\n", camera_line);
        fmt::print("lights: {}\n", lights_line);
        if (a.ground) fmt::print("ground: a {:.4g} m square plane at y = {:.4g} m\n", ground.size.x, ground.center.y);
        fmt::print("wrote {}\n", out_text);
        fmt::print("next: penumbra validate {} --out run --preset d3d12-textbook\n", out_text);
    }
    return kExitSuccess;
}

}  // namespace

Subcommand add_init_command(CLI::App& parent) {
    auto a = std::make_shared<InitArgs>();
    CLI::App* cmd =
        parent.add_subcommand("init", "Write a scenario for a glTF model: camera framed on it, a sun, a ground plane");
    cmd->add_option("MODEL", a->models, "glTF 2.0 models (.gltf or .glb), placed as they are authored")
        ->required()
        ->check(kUserPath);
    cmd->add_option("--out", a->out, "Scenario file to write (refused if it exists, unless --force)")
        ->required()
        ->check(kUserPath);
    cmd->add_flag("--ground", a->ground, "Add a receiver plane under the model");
    cmd->add_option("--up", a->up,
                    "Which axis of the models is up: y (glTF's), z (stood upright), or auto (default: a guess per "
                    "model, said when it is z)")
        ->check(CLI::IsMember({"auto", "y", "z"}));
    cmd->add_option("--sun", a->sun,
                    fmt::format("Sun elevation and azimuth in degrees, azimuth from +Z towards +X (default {:g},{:g}; "
                                "replaces the model's own lights)",
                                kInitSunElevationDeg, kInitSunAzimuthDeg))
        ->check(kUserName)
        ->check(sun_problem);
    cmd->add_option("--scale", a->scale, "Model units to metres, written as the scenario's \"scale\" (e.g. 0.001)")
        ->check(range(kMinScale, kMaxScale));
    cmd->add_option("--width", a->width, "Image width in pixels (default 1280)")->check(CLI::Range(1, kMaxImageSide));
    cmd->add_option("--height", a->height, "Image height in pixels (default 720)")->check(CLI::Range(1, kMaxImageSide));
    cmd->add_flag("--force", a->force, "Overwrite an existing scenario file");
    cmd->add_flag("--allow-external-paths", a->allow_external_paths,
                  "Let glTF buffer URIs point outside the model's folder");
    cmd->add_flag("-q,--quiet", a->quiet, "Print nothing but errors");
    cmd->footer(
        "Output: the scenario file (--out), written whole or not at all; its \"scene\" is the model's path\n"
        "relative to it. Prints the model's triangles, bounds and size, and warns when the size suggests\n"
        "other units than metres.\n"
        "Example:\n"
        "  penumbra init model.glb --out shadows/scenario.json --ground\n"
        "  penumbra validate shadows/scenario.json --out shadows/run --preset d3d12-textbook\n");
    return {cmd, [a] { return run_init_command(*a); }};
}

}  // namespace penumbra::cli
