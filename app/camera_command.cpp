// `penumbra camera`: the capture kit. Prints, as JSON, what an engine needs to render exactly
// penumbra's view (docs/compare.md): view and projection matrices in the graphics API's
// conventions, the pixel-centre and row conventions, and every light in glTF terms.
#include <fmt/format.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>

#include "app/cli.h"
#include "common/camera.h"
#include "common/errors.h"
#include "common/json_reader.h"
#include "common/projection.h"

namespace penumbra::cli {
namespace {

using Convention = ClipConvention;

nlohmann::json vec(const glm::dvec3& v) {
    return {v.x, v.y, v.z};
}

nlohmann::json rows(const Mat4& m) {
    nlohmann::json j = nlohmann::json::array();
    for (const auto& r : m) j.push_back({r[0], r[1], r[2], r[3]});
    return j;
}

// The 16 numbers in memory order: column-major for GL/Vulkan (column vectors); D3D's row-major
// storage of the transpose (row vectors, v * M) is the same sequence.
nlohmann::json flat(const Mat4& m) {
    nlohmann::json j = nlohmann::json::array();
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) j.push_back(m[r][c]);
    return j;
}

nlohmann::json light_json(const Light& l, std::size_t index) {
    nlohmann::json j = {{"index", index}, {"type", to_string(l.type)}, {"origin", l.origin}};
    switch (l.type) {
        case LightType::directional:
            j["direction"] = vec(l.direction);
            j["gltf"] = {{"type", "directional"}};
            // The engine's sun size (Unreal's source angle), only for a sun with one.
            if (l.angular_diameter_rad > 0) j["angular_diameter_deg"] = l.angular_diameter_rad * 180 / M_PI;
            break;
        case LightType::spot:
            j["position"] = vec(l.position);
            j["direction"] = vec(l.direction);
            j["target"] = vec(l.position + l.direction);
            j["outer_cone_rad"] = l.outer_cone_rad;
            j["inner_cone_rad"] = l.inner_cone_rad;
            j["gltf"] = {{"type", "spot"},
                         {"spot", {{"innerConeAngle", l.inner_cone_rad}, {"outerConeAngle", l.outer_cone_rad}}}};
            break;
        case LightType::point:
            j["position"] = vec(l.position);
            j["gltf"] = {{"type", "point"}};
            break;
        case LightType::rect:
            j["center"] = vec(l.position);
            j["u"] = vec(l.u);
            j["v"] = vec(l.v);
            break;
        case LightType::disk:
            j["center"] = vec(l.position);
            j["normal"] = vec(l.normal);
            j["radius"] = l.radius;
            break;
        case LightType::sphere:
            j["center"] = vec(l.position);
            j["radius"] = l.radius;
            break;
    }
    return j;
}

int run_camera_command(const std::filesystem::path& scenario_file, bool allow_external, bool quiet, Convention conv) {
    Common c;
    c.quiet = quiet;  // the scene's warnings go to stderr, as every command's do
    c.allow_external_paths = allow_external;
    const Scenario sc = load_for_command(scenario_file, c);
    const Camera& cam = sc.camera;
    const CameraProjection projection(cam, sc.width, sc.height, sc.scene.bounds);
    const char* names[] = {"gl", "vulkan", "d3d"};
    const bool perspective = cam.type == ProjectionType::perspective;
    nlohmann::json camera = {{"type", perspective ? "perspective" : "orthographic"},
                             {"eye", vec(cam.eye)},
                             {"target", vec(cam.eye + cam.forward)},
                             {"up", vec(cam.up)},
                             {"forward", vec(cam.forward)},
                             {"right", vec(cam.right)},
                             {"znear", cam.znear},
                             {"aspect", double(sc.width) / double(sc.height)}};
    // JSON has no infinity: an infinite far plane is said so, and the matrices are its limit.
    if (std::isinf(projection.zfar()))
        camera["infinite_far"] = true;
    else
        camera["zfar"] = projection.zfar();
    if (projection.zfar_from_scene()) camera["zfar_from_scene"] = true;
    if (perspective) {
        camera["yfov_rad"] = cam.yfov_rad;
        camera["yfov_deg"] = cam.yfov_rad * 180.0 / M_PI;
    } else {
        const glm::dvec2 s = ndc_to_image_plane(cam, sc.width, sc.height);
        camera["xmag"] = s.x;
        camera["ymag"] = s.y;
    }
    nlohmann::json lights = nlohmann::json::array();
    for (std::size_t li = 0; li < sc.lights.size(); ++li) lights.push_back(light_json(sc.lights[li], li));
    const Mat4 view = projection.view(), proj = projection.matrix(conv);
    nlohmann::json j = {
        {"scenario", path_text(sc.file)},
        {"convention", names[static_cast<int>(conv)]},
        {"image", {{"width", sc.width}, {"height", sc.height}}},
        {"camera", camera},
        {"view", rows(view)},
        {"projection", rows(proj)},
        {"view_array", flat(view)},
        {"projection_array", flat(proj)},
        {"matrix_layout", conv == Convention::d3d
                              ? "view/projection: rows, clip = P * V * x (column vectors); *_array: the 16 numbers "
                                "row-major for row vectors (x * V^T * P^T, DirectXMath/HLSL row_major)"
                              : "view/projection: rows, clip = P * V * x (column vectors); *_array: column-major"},
        {"view_space", "right-handed, the camera looks down -Z, +Y up (glTF)"},
        {"ndc_depth_range", conv == Convention::gl ? nlohmann::json{-1, 1} : nlohmann::json{0, 1}},
        {"ndc_y", conv == Convention::vulkan ? "down" : "up"},
        {"pixel_center", {0.5, 0.5}},
        {"pixel_convention",
         "pixel (x, y) is sampled at (x + 0.5, y + 0.5); no jitter, no MSAA resolve across the silhouette"},
        {"image_row_0", "top"},
        {"readback", conv == Convention::gl
                         ? "glReadPixels returns the bottom row first: flip rows before writing the image"
                         : "row 0 of the framebuffer is the image's top row"},
        {"lights", lights},
        {"depth_for_compare",
         "--depth-space ndc: the depth buffer's value in [0, 1] (GL window depth, Vulkan/D3D NDC z); ndc-gl: GL NDC "
         "z in [-1, 1]; linear: view depth in metres"}};
    fmt::print("{}\n", j.dump(2));
    return kExitSuccess;
}

}  // namespace

Subcommand add_camera_command(CLI::App& parent) {
    struct Args {
        std::filesystem::path scenario;
        bool allow_external = false;
        bool quiet = false;
        Convention conv = Convention::gl;
    };
    auto a = std::make_shared<Args>();
    CLI::App* cmd = parent.add_subcommand(
        "camera", "Print the scenario's view, projection and lights as JSON, for an engine to render the same frame");
    add_scenario(cmd, a->scenario);
    const std::map<std::string, Convention> conventions = {
        {"gl", Convention::gl}, {"vulkan", Convention::vulkan}, {"d3d", Convention::d3d}};
    cmd->add_option("--convention", a->conv, "Matrices for gl (default), vulkan or d3d")
        ->transform(CLI::CheckedTransformer(conventions));
    cmd->add_flag("--allow-external-paths", a->allow_external, "Let glTF buffer URIs point outside the scene's folder");
    cmd->add_flag("-q,--quiet", a->quiet, "No warnings on stderr (the JSON is printed all the same)");
    describe_outputs(cmd,
                     "Outputs: JSON on stdout (view and projection matrices in the chosen convention, pixel-centre and "
                     "row\nconventions, the lights in glTF terms); nothing is written.",
                     "penumbra camera data/default/scenario.json --convention vulkan > camera.json");
    return {cmd, [a] { return run_camera_command(a->scenario, a->allow_external, a->quiet, a->conv); }};
}

}  // namespace penumbra::cli
