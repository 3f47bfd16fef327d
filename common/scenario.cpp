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

// `target`, when given, receives the look-at target (a glTF camera's: one metre ahead).
Camera read_camera(JsonObject cam, const Scene& scene, const std::string& scene_label,
                   glm::dvec3* target_out = nullptr) {
    Camera c;
    if (cam.has("gltf_camera")) {
        long long index = cam.integer("gltf_camera", 0, 1 << 30);
        cam.finish();
        if (index >= static_cast<long long>(scene.cameras.size()))
            cam.fail("gltf_camera", fmt::format("the scene has {} cameras", scene.cameras.size()));
        if (!scene.camera_placed[index])
            cam.fail("gltf_camera", fmt::format("camera {} is not used by any node of the scene", index));
        c = scene.cameras[index];
        validate_camera(
            c, fmt::format("{}: cameras[{}] (the scenario's {})", scene_label, index, cam.path_of("gltf_camera")));
        if (target_out) *target_out = c.eye + c.forward;
        return c;
    }
    std::string type = cam.string("type");
    if (type == "perspective")
        cam.only_keys({"type", "eye", "target", "up", "yfov_deg", "znear", "zfar"});
    else if (type == "orthographic")
        cam.only_keys({"type", "eye", "target", "up", "xmag", "ymag", "znear", "zfar"});
    glm::dvec3 eye = position(cam, "eye");
    glm::dvec3 target = position(cam, "target");
    glm::dvec3 up = cam.has("up") ? cam.nonzero_vec3("up") : glm::dvec3(0, 1, 0);
    if (glm::length(target - eye) == 0.0) cam.fail("target", "equals eye: the view direction is undefined");
    if (!look_at_basis(eye, target, up, c)) cam.fail("up", "parallel to the view direction");
    if (type == "perspective") {
        c.type = ProjectionType::perspective;
        c.yfov_rad =
            cam.number_in("yfov_deg", kMinFovDeg, kMaxFovDeg, "expected a field of view in [0.001, 179] degrees") *
            kDeg;
        c.znear = cam.number_in("znear", 0.1, kMinExtent, kMaxExtent, "expected znear in [1e-12, 1e15] m");
        c.zfar = cam.number_in("zfar", kInf, 0, kInf, "expected zfar > znear");
    } else if (type == "orthographic") {
        c.type = ProjectionType::orthographic;
        c.xmag = cam.number_in("xmag", kMinExtent, kMaxExtent, "expected a half-width in [1e-12, 1e15] m");
        c.ymag = cam.number_in("ymag", kMinExtent, kMaxExtent, "expected a half-height in [1e-12, 1e15] m");
        c.znear = cam.number_in("znear", 0.0, 0, kMaxExtent, "expected znear in [0, 1e15] m");
        c.zfar = cam.number_in("zfar", kInf, 0, kInf, "expected zfar > znear");
    } else {
        cam.fail("type", fmt::format("expected \"perspective\" or \"orthographic\", got \"{}\"", type));
    }
    if (!(c.zfar > c.znear)) cam.fail("zfar", fmt::format("must exceed znear ({} <= {})", c.zfar, c.znear));
    if (auto p = camera_problem(c)) cam.fail(p->key, p->what);  // the checks glTF cameras get
    cam.finish();
    if (target_out) *target_out = target;
    return c;
}

// "camera_path": every key read as a camera, and every frame between them checked, so that a
// path that turns degenerate half-way is refused before any work starts.
CameraPath read_camera_path(JsonObject o, const Scene& scene, const std::string& scene_label) {
    o.only_keys({"frames", "keys"});
    CameraPath path;
    path.frames = static_cast<int>(o.integer("frames", 2, kMaxPathFrames));
    const nlohmann::json& keys = o.get("keys");
    if (!keys.is_array() || keys.empty()) o.fail("keys", "expected an array of at least one camera");
    if (keys.size() > static_cast<std::size_t>(path.frames))
        o.fail("keys", fmt::format("{} keys for {} frames: every key must be a frame", keys.size(), path.frames));
    for (std::size_t i = 0; i < keys.size(); ++i) {
        JsonObject key(keys[i], o.file_label(), o.path_of(fmt::format("keys[{}]", i)));
        CameraKey k;
        k.camera = read_camera(key, scene, scene_label, &k.target);
        if (i > 0 && k.camera.type != path.keys[0].camera.type)
            key.fail("type", "differs from keys[0]'s: a path interpolates one kind of camera");
        if (i > 0 && std::isinf(k.camera.zfar) != std::isinf(path.keys[0].camera.zfar))
            key.fail("zfar", "infinite in one key and finite in another: frames between them would have no zfar");
        path.keys.push_back(k);
    }
    for (int f = 0; f < path.frames; ++f) {
        const std::optional<Camera> c = path_camera(path, f);
        std::optional<RangeProblem> p = c ? camera_problem(*c) : std::nullopt;
        if (!c || p)
            o.fail("keys", fmt::format("frame {} between the keys: {}", f,
                                       c ? p->key + ": " + p->what
                                         : "the view direction is undefined (the target meets the eye, or up turns "
                                           "parallel to the view)"));
    }
    return path;
}

Light read_light(JsonObject o) {
    Light l;
    std::string type = o.string("type");
    if (type == "directional") o.only_keys({"type", "name", "direction", "angular_diameter_deg"});
    if (type == "spot") o.only_keys({"type", "name", "position", "direction", "outer_cone_deg", "inner_cone_deg"});
    if (type == "point") o.only_keys({"type", "name", "position"});
    if (type == "rect") o.only_keys({"type", "name", "center", "u", "v"});
    if (type == "disk") o.only_keys({"type", "name", "center", "normal", "radius"});
    if (type == "sphere") o.only_keys({"type", "name", "center", "radius"});
    o.string("name", "");
    if (type == "directional") {
        l.type = LightType::directional;
        l.direction = glm::normalize(o.nonzero_vec3("direction"));
        l.angular_diameter_rad = o.number("angular_diameter_deg", 0.0) * kDeg;  // range: light_problem
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
        for (const char* key : {"u", "v"})  // before nonzero_vec3, which would call 1e200 an overflow
            if (double len = safe_length(o.vec3(key)); len > kMaxExtent)
                o.fail(key, fmt::format("edge length {:g} m exceeds the {:g} m limit", len, kMaxExtent));
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
        l.radius = o.number_in("radius", kMinExtent, kMaxExtent, "expected a radius in [1e-12, 1e15] m");
    } else if (type == "sphere") {
        l.type = LightType::sphere;
        l.position = position(o, "center");
        l.radius = o.number_in("radius", kMinExtent, kMaxExtent, "expected a radius in [1e-12, 1e15] m");
    } else {
        o.fail("type", fmt::format("expected one of directional, spot, point, rect, disk, sphere; got \"{}\"", type));
    }
    if (auto p = light_problem(l)) o.fail(p->key, p->what);  // the checks glTF lights get
    o.finish();
    return l;
}

// `key` as an array of `n` extents in [kMinExtent, kMaxExtent] metres.
glm::dvec3 extents(JsonObject& o, const std::string& key, int n) {
    const nlohmann::json& v = o.get(key);
    if (!v.is_array() || v.size() != static_cast<std::size_t>(n))
        o.fail(key, fmt::format("expected an array of {} sizes in metres", n));
    glm::dvec3 out(0.0);
    for (int i = 0; i < n; ++i) {
        if (!v[i].is_number()) o.fail(key, fmt::format("element {} is not a number", i));
        out[i] = v[i].get<double>();
        if (!(out[i] >= kMinExtent && out[i] <= kMaxExtent))
            o.fail(key, fmt::format("element {} is {}; expected a size in [1e-12, 1e15] m", i, json_excerpt(v[i])));
    }
    return out;
}

Receiver read_receiver(JsonObject o) {
    Receiver r;
    std::string type = o.string("type");
    if (type == "plane") {
        o.only_keys({"type", "center", "normal", "size"});
        r.type = ReceiverType::plane;
        r.center = position(o, "center");
        r.normal = o.has("normal") ? glm::normalize(o.nonzero_vec3("normal")) : glm::dvec3(0, 1, 0);
        r.size = extents(o, "size", 2);
    } else if (type == "box") {
        o.only_keys({"type", "center", "size"});
        r.type = ReceiverType::box;
        r.center = position(o, "center");
        r.size = extents(o, "size", 3);
    } else {
        o.fail("type", fmt::format("expected \"plane\" or \"box\", got \"{}\"", type));
    }
    // Every corner within the coordinate limit (a huge plane at a huge centre would leave it).
    const double reach = glm::length(0.5 * r.size);
    for (int c = 0; c < 3; ++c)
        if (std::abs(r.center[c]) + reach > kMaxCoordinate)
            o.fail("size", fmt::format("reaches beyond the {:g} m coordinate limit", kMaxCoordinate));
    o.finish();
    return r;
}

double lerp(double a, double b, double t) {
    return a == b ? a : a + (b - a) * t;
}

}  // namespace

std::optional<Camera> path_camera(const CameraPath& path, int frame) {
    const std::size_t last = path.keys.size() - 1;
    if (last == 0 || path.frames < 2) return path.keys.at(0).camera;
    // Integers in double: the last frame lands exactly on the last key.
    const double s = static_cast<double>(frame) * static_cast<double>(last) / static_cast<double>(path.frames - 1);
    const std::size_t i = std::min(static_cast<std::size_t>(std::max(s, 0.0)), last - 1);
    const double t = s - static_cast<double>(i);
    const CameraKey &a = path.keys[i], &b = path.keys[i + 1];
    if (t <= 0) return a.camera;  // a key is its own camera, bit for bit
    if (t >= 1) return b.camera;
    Camera c = a.camera;
    const glm::dvec3 eye = a.camera.eye + (b.camera.eye - a.camera.eye) * t;
    const glm::dvec3 target = a.target + (b.target - a.target) * t;
    const glm::dvec3 up = a.camera.up + (b.camera.up - a.camera.up) * t;
    if (!look_at_basis(eye, target, up, c)) return std::nullopt;
    c.yfov_rad = lerp(a.camera.yfov_rad, b.camera.yfov_rad, t);
    c.xmag = lerp(a.camera.xmag, b.camera.xmag, t);
    c.ymag = lerp(a.camera.ymag, b.camera.ymag, t);
    c.znear = lerp(a.camera.znear, b.camera.znear, t);
    c.zfar = std::isinf(a.camera.zfar) ? a.camera.zfar : lerp(a.camera.zfar, b.camera.zfar, t);
    return c;
}

void scale_scene(Scene& scene, double scale) {
    if (scale == 1.0) return;
    for (glm::dvec3& p : scene.positions) p *= scale;
    if (!scene.bounds.empty()) scene.bounds = {scene.bounds.lo * scale, scene.bounds.hi * scale};
    // The cameras scale with the model so that they show the same picture (inf stays inf).
    for (Camera& c : scene.cameras) {
        c.eye *= scale;
        c.znear *= scale;
        c.zfar *= scale;
        c.xmag *= scale;
        c.ymag *= scale;
    }
    for (Light& l : scene.lights) l.position *= scale;
}

Scenario load_scenario(const fs::path& file, const ScenarioOptions& options) {
    Scenario s;
    s.file = file;
    s.label = file.filename().string();
    nlohmann::json root = read_json_file(file);
    JsonObject top(root, s.label, "");
    top.only_keys({"scene", "scale", "image", "camera", "camera_path", "lights", "receivers", "technique", "gate"});

    std::string scene_rel = top.string("scene");
    if (scene_rel.empty()) top.fail("scene", "empty path");
    s.scene_file = fs::absolute(file).parent_path() / scene_rel;
    std::error_code ec;
    if (!fs::exists(s.scene_file, ec)) top.fail("scene", fmt::format("no such file: {}", s.scene_file.string()));
    if (!fs::is_regular_file(s.scene_file, ec))
        top.fail("scene",
                 fmt::format("{}: not a regular file (devices, FIFOs and folders are refused)", s.scene_file.string()));

    JsonObject image = top.object("image");
    image.only_keys({"width", "height"});
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
    s.scale =
        top.number_in("scale", 1.0, kMinScale, kMaxScale, "expected a factor in [1e-6, 1e6] (model units to metres)");
    if (top.has("receivers")) {
        const nlohmann::json& receivers = top.get("receivers");
        if (!receivers.is_array()) top.fail("receivers", "expected an array of receivers (planes and boxes)");
        for (std::size_t i = 0; i < receivers.size(); ++i)
            s.receivers.push_back(read_receiver(JsonObject(receivers[i], s.label, fmt::format("receivers[{}]", i))));
    }
    // Presence is checked before the scene is loaded; a path's first frame may stand for the camera.
    if (top.has("camera") || !top.has("camera_path")) top.get("camera");
    if (top.has("camera_path") && !top.get("camera_path").is_object()) top.fail("camera_path", "expected an object");
    top.finish();

    GltfLoadOptions gltf_options;
    gltf_options.allow_external_paths = options.allow_external_paths;
    gltf_options.max_memory_bytes = options.max_memory_bytes;
    s.scene = load_gltf(s.scene_file, gltf_options);
    scale_scene(s.scene, s.scale);
    if (!s.scene.bounds.empty())
        for (const glm::dvec3& corner : {s.scene.bounds.lo, s.scene.bounds.hi})
            for (int c = 0; c < 3; ++c)
                if (std::abs(corner[c]) > kMaxCoordinate)
                    top.fail("scale", fmt::format("the scaled scene reaches {:g} m, beyond the {:g} m coordinate limit",
                                                  corner[c], kMaxCoordinate));
    for (const Receiver& r : s.receivers) add_receiver(s.scene, r);

    const std::string scene_label = s.scene_file.filename().string();
    if (top.has("camera_path")) s.camera_path = read_camera_path(top.object("camera_path"), s.scene, scene_label);
    s.camera =
        top.has("camera") ? read_camera(top.object("camera"), s.scene, scene_label) : s.camera_path->keys[0].camera;
    if (lights.is_array()) {
        s.lights = std::move(listed);
    } else {
        s.lights = s.scene.lights;
        for (const Light& l : s.lights) validate_light(l, fmt::format("{}: {}", scene_label, l.origin));
    }
    return s;
}

}  // namespace penumbra
