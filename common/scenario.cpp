#include "common/scenario.h"

#include <fmt/format.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <limits>

#include "common/camera.h"
#include "common/errors.h"
#include "common/gltf_loader.h"
#include "common/json_reader.h"

namespace penumbra {
namespace fs = std::filesystem;

namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kInf = std::numeric_limits<double>::infinity();

glm::dvec3 position(JsonObject& o, const std::string& key) {
    glm::dvec3 p = o.vec3(key);
    for (int c = 0; c < 3; ++c)
        if (std::abs(p[c]) > kMaxCoordinate)
            o.fail(key, fmt::format("coordinate {} exceeds the {:g} m limit", p[c], kMaxCoordinate));
    return p;
}

Camera read_camera(JsonObject cam, const Scene& scene) {
    Camera c;
    if (cam.has("gltf_camera")) {
        long long index = cam.integer("gltf_camera", 0, 1 << 30);
        cam.finish();
        if (index >= static_cast<long long>(scene.cameras.size()))
            cam.fail("gltf_camera", fmt::format("the scene has {} cameras", scene.cameras.size()));
        if (!scene.camera_placed[index])
            cam.fail("gltf_camera", fmt::format("camera {} is not used by any node of the scene", index));
        c = scene.cameras[index];
        validate_camera(c, fmt::format("{}: gltf camera {}", cam.path_of("gltf_camera"), index));
        return c;
    }
    std::string type = cam.string("type");
    glm::dvec3 eye = position(cam, "eye");
    glm::dvec3 target = position(cam, "target");
    glm::dvec3 up = cam.has("up") ? cam.nonzero_vec3("up") : glm::dvec3(0, 1, 0);
    if (glm::length(target - eye) == 0.0) cam.fail("target", "equals eye: the view direction is undefined");
    if (!look_at_basis(eye, target, up, c)) cam.fail("up", "parallel to the view direction");
    if (type == "perspective") {
        c.type = ProjectionType::perspective;
        c.yfov_rad = cam.number_in("yfov_deg", 1e-3, 179.0, "expected a field of view in [0.001, 179] degrees") * kDeg;
        c.znear = cam.number_in("znear", 0.1, 1e-12, 1e15, "expected znear > 0");
        c.zfar = cam.number_in("zfar", kInf, 0, kInf, "expected zfar > znear");
    } else if (type == "orthographic") {
        c.type = ProjectionType::orthographic;
        c.xmag = cam.number_in("xmag", 1e-12, 1e15, "expected a half-width > 0");
        c.ymag = cam.number_in("ymag", 1e-12, 1e15, "expected a half-height > 0");
        c.znear = cam.number_in("znear", 0.0, 0, 1e15, "expected znear >= 0");
        c.zfar = cam.number_in("zfar", kInf, 0, kInf, "expected zfar > znear");
    } else {
        cam.fail("type", fmt::format("expected \"perspective\" or \"orthographic\", got \"{}\"", type));
    }
    if (!(c.zfar > c.znear)) cam.fail("zfar", fmt::format("must exceed znear ({} <= {})", c.zfar, c.znear));
    cam.finish();
    return c;
}

Light read_light(JsonObject o) {
    Light l;
    std::string type = o.string("type");
    o.string("name", "");
    if (type == "directional") {
        l.type = LightType::directional;
        l.direction = glm::normalize(o.nonzero_vec3("direction"));
    } else if (type == "spot") {
        l.type = LightType::spot;
        l.position = position(o, "position");
        l.direction = glm::normalize(o.nonzero_vec3("direction"));
        l.outer_cone_rad =
            o.number_in("outer_cone_deg", 1e-3, 90.0, "expected a half-angle in [0.001, 90] degrees") * kDeg;
        l.inner_cone_rad = o.number_in("inner_cone_deg", 0.0, 0.0, l.outer_cone_rad / kDeg,
                                       "expected 0 <= inner_cone_deg <= outer_cone_deg") *
                           kDeg;
    } else if (type == "point") {
        l.type = LightType::point;
        l.position = position(o, "position");
    } else if (type == "rect") {
        l.type = LightType::rect;
        l.position = position(o, "center");
        l.u = o.nonzero_vec3("u");
        l.v = o.nonzero_vec3("v");
        glm::dvec3 n = glm::cross(l.u, l.v);
        if (!(glm::length(n) > 1e-9 * glm::length(l.u) * glm::length(l.v)))
            o.fail("v", "parallel to u: the rectangle has no area");
        l.normal = glm::normalize(n);
    } else if (type == "disk") {
        l.type = LightType::disk;
        l.position = position(o, "center");
        l.normal = glm::normalize(o.nonzero_vec3("normal"));
        l.radius = o.number_in("radius", 1e-12, 1e15, "expected a radius > 0");
    } else if (type == "sphere") {
        l.type = LightType::sphere;
        l.position = position(o, "center");
        l.radius = o.number_in("radius", 1e-12, 1e15, "expected a radius > 0");
    } else {
        o.fail("type", fmt::format("expected one of directional, spot, point, rect, disk, sphere; got \"{}\"", type));
    }
    o.finish();
    return l;
}

}  // namespace

void validate_camera(const Camera& c, const std::string& where) {
    auto bad = [&](const std::string& what) { throw InputError(fmt::format("{}: {}", where, what)); };
    if (c.type == ProjectionType::perspective) {
        if (!(c.yfov_rad > 1e-5 && c.yfov_rad < M_PI * 179.0 / 180.0))
            bad(fmt::format("yfov {} rad is outside (0, 179 degrees)", c.yfov_rad));
        if (!(c.znear > 0)) bad(fmt::format("znear {} must be > 0", c.znear));
    } else {
        if (!(c.xmag > 0 && c.ymag > 0 && std::isfinite(c.xmag) && std::isfinite(c.ymag)))
            bad(fmt::format("xmag {} and ymag {} must be finite and > 0", c.xmag, c.ymag));
        if (!(c.znear >= 0)) bad(fmt::format("znear {} must be >= 0", c.znear));
    }
    if (!(c.zfar > c.znear)) bad(fmt::format("zfar {} must exceed znear {}", c.zfar, c.znear));
}

void validate_light(const Light& l, const std::string& where) {
    auto finite3 = [](const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
    if (!finite3(l.position) || !finite3(l.direction))
        throw InputError(fmt::format("{}: light position or direction is not finite", where));
}

Scenario load_scenario(const fs::path& file, const ScenarioOptions& options) {
    Scenario s;
    s.file = file;
    s.label = file.filename().string();
    nlohmann::json root = read_json_file(file);
    JsonObject top(root, s.label, "");

    std::string scene_rel = top.string("scene");
    if (scene_rel.empty()) top.fail("scene", "empty path");
    s.scene_file = fs::absolute(file).parent_path() / scene_rel;
    std::error_code ec;
    if (!fs::is_regular_file(s.scene_file, ec))
        top.fail("scene", fmt::format("no such file: {}", s.scene_file.string()));

    JsonObject image = top.object("image");
    s.width = static_cast<int>(image.integer("width", 1, kMaxImageSide));
    s.height = static_cast<int>(image.integer("height", 1, kMaxImageSide));
    image.finish();
    if (static_cast<long long>(s.width) * s.height > kMaxImagePixels)
        top.fail("image", fmt::format("{}x{} exceeds the {} pixel limit", s.width, s.height, kMaxImagePixels));

    if (top.has("technique")) {
        s.technique = top.get("technique");
        if (!s.technique.is_object()) top.fail("technique", "expected an object");
    }
    if (top.has("gate")) {
        s.gate = top.get("gate");
        if (!s.gate.is_object()) top.fail("gate", "expected an object");
    }
    // Validate everything cheap before the (possibly large) scene is read.
    const nlohmann::json& lights = top.get("lights");
    if (!(lights.is_array() || (lights.is_string() && lights.get<std::string>() == "gltf")))
        top.fail("lights", "expected an array of lights or the string \"gltf\"");
    std::vector<Light> listed;
    if (lights.is_array()) {
        for (std::size_t i = 0; i < lights.size(); ++i) {
            Light l = read_light(JsonObject(lights[i], s.label, fmt::format("lights[{}]", i)));
            l.origin = fmt::format("lights[{}]", i);
            listed.push_back(l);
        }
    }
    top.get("camera");  // presence is checked before the scene is loaded
    top.finish();

    GltfLoadOptions gltf_options;
    gltf_options.allow_external_paths = options.allow_external_paths;
    s.scene = load_gltf(s.scene_file, gltf_options);

    s.camera = read_camera(top.object("camera"), s.scene);
    if (lights.is_array()) {
        s.lights = std::move(listed);
    } else {
        s.lights = s.scene.lights;
        for (const Light& l : s.lights) validate_light(l, fmt::format("{}: {}", s.label, l.origin));
    }
    return s;
}

}  // namespace penumbra
