#include "common/scenario.h"

#include <fmt/format.h>

#include <algorithm>
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

// "up": "y" (glTF's, the default) or "z" (a Z-up export, stood upright); true for "z".
bool read_up(JsonObject& o) {
    if (!o.has("up")) return false;
    const std::string up = o.string("up");
    if (up != "y" && up != "z")
        o.fail("up", fmt::format("\"{}\": expected \"y\" (glTF's) or \"z\" (a Z-up model)", up));
    return up == "z";
}

// One entry of a "scene" list: {"model", "translation", "rotation" | "rotation_deg", "scale", "up"}.
template <typename ModelFile>
ModelPlacement read_model(JsonObject& o, const ModelFile& model_file, double scenario_scale, bool default_z_up) {
    o.only_keys({"model", "translation", "rotation", "rotation_deg", "scale", "up"});
    ModelPlacement m;
    m.file = model_file(o, "model");
    if (o.has("translation")) m.translation = position(o, "translation");
    if (o.has("rotation") && o.has("rotation_deg"))
        o.fail("rotation_deg", "given with \"rotation\": one rotation, a quaternion or Euler angles");
    if (o.has("rotation")) {
        // glTF's order: [x, y, z, w], a unit quaternion (normalised within glTF's tolerance).
        const nlohmann::json& q = o.get("rotation");
        if (!q.is_array() || q.size() != 4) o.fail("rotation", "expected a quaternion [x, y, z, w]");
        double v[4];
        for (int i = 0; i < 4; ++i) {
            if (!q[i].is_number() || !std::isfinite(q[i].get<double>()))
                o.fail("rotation", fmt::format("element {} is not a finite number", i));
            v[i] = q[i].get<double>();
        }
        const double len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3]);
        if (!(std::abs(len - 1.0) < 1e-3))
            o.fail("rotation", fmt::format("length {:g}; expected a unit quaternion [x, y, z, w]", len));
        m.rotation = glm::normalize(glm::dquat(v[3], v[0], v[1], v[2]));
    } else if (o.has("rotation_deg")) {
        // Euler degrees about X, then Y, then Z (each about the world's axis): R = Rz Ry Rx.
        const glm::dvec3 e = o.vec3("rotation_deg");
        for (int c = 0; c < 3; ++c)
            if (std::abs(e[c]) > 360.0) o.fail("rotation_deg", fmt::format("{:g} is not in [-360, 360] degrees", e[c]));
        m.rotation = glm::angleAxis(e.z * kDeg, glm::dvec3(0, 0, 1)) * glm::angleAxis(e.y * kDeg, glm::dvec3(0, 1, 0)) *
                     glm::angleAxis(e.x * kDeg, glm::dvec3(1, 0, 0));
    }
    m.scale = scenario_scale * o.number_in("scale", 1.0, kMinScale, kMaxScale,
                                           "expected a factor in [1e-6, 1e6] (the model's units to metres)");
    m.z_up = o.has("up") ? read_up(o) : default_z_up;
    o.finish();
    return m;
}

// `target`, when given, receives the look-at target (a glTF camera's: one metre ahead).
Camera read_camera(JsonObject cam, const Scene& scene, const std::string& scene_label,
                   glm::dvec3* target_out = nullptr) {
    Camera c;
    if (cam.has("gltf_camera")) {
        long long index = cam.integer("gltf_camera", 0, 1 << 30);
        std::optional<double> zfar;  // replaces the glTF camera's (init writes one where it has none)
        if (cam.has("zfar")) zfar = cam.number_in("zfar", 0, kInf, "expected zfar > znear");
        cam.finish();
        if (index >= static_cast<long long>(scene.cameras.size()))
            cam.fail("gltf_camera", fmt::format("the scene has {} cameras", scene.cameras.size()));
        if (!scene.camera_placed[index])
            cam.fail("gltf_camera", fmt::format("camera {} is not used by any node of the scene", index));
        c = scene.cameras[index];
        if (zfar) {
            if (!(*zfar > c.znear))
                cam.fail("zfar", fmt::format("must exceed the glTF camera's znear ({} <= {})", *zfar, c.znear));
            c.zfar = *zfar;
        }
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

nlohmann::json scene_files_json(const Scenario& s) {
    if (s.models.size() <= 1) return s.scene_file.string();
    nlohmann::json files = nlohmann::json::array();
    for (const ModelPlacement& m : s.models) files.push_back(m.file.string());
    return files;
}

Scenario load_scenario(const fs::path& file, const ScenarioOptions& options) {
    Scenario s;
    s.file = file;
    s.label = file.filename().string();
    nlohmann::json root = read_json_file(file, kScenarioJson);
    JsonObject top(root, s.label, "");
    top.only_keys(
        {"scene", "scale", "up", "image", "camera", "camera_path", "lights", "receivers", "technique", "gate"});

    // "scene": one glTF file, or a list of models (strings or placements), read after the cheap checks.
    const nlohmann::json& scene_value = top.get("scene");
    if (!scene_value.is_string() && !(scene_value.is_array() && !scene_value.empty()))
        top.fail("scene", "expected a glTF file or a non-empty array of models");
    if (scene_value.is_array() && scene_value.size() > kMaxModels)
        top.fail("scene", fmt::format("{} models; at most {}", scene_value.size(), kMaxModels));
    const fs::path scenario_dir = fs::absolute(file).parent_path();
    const auto model_file = [&](JsonObject& o, const std::string& key) {
        const std::string rel = o.string(key);
        if (rel.empty()) o.fail(key, "empty path");
        const fs::path f = scenario_dir / rel;
        std::error_code ec;
        if (!fs::exists(f, ec)) o.fail(key, fmt::format("no such file: {}", f.string()));
        if (!fs::is_regular_file(f, ec))
            o.fail(key, fmt::format("{}: not a regular file (devices, FIFOs and folders are refused)", f.string()));
        return f;
    };
    const bool default_z_up = read_up(top);
    s.scale =
        top.number_in("scale", 1.0, kMinScale, kMaxScale, "expected a factor in [1e-6, 1e6] (model units to metres)");
    if (scene_value.is_string()) {
        ModelPlacement m;
        m.file = model_file(top, "scene");
        m.scale = s.scale;
        m.z_up = default_z_up;
        s.models.push_back(m);
    } else {
        for (std::size_t i = 0; i < scene_value.size(); ++i) {
            const std::string path = fmt::format("scene[{}]", i);
            const nlohmann::json wrapped = {{"model", scene_value[i]}};
            JsonObject o = scene_value[i].is_string() ? JsonObject(wrapped, s.label, path)
                                                      : JsonObject(scene_value[i], s.label, path);
            s.models.push_back(read_model(o, model_file, s.scale, default_z_up));
            s.models.back().label = fmt::format("{}: {}", path, s.models.back().file.filename().string());
        }
    }
    s.scene_file = s.models[0].file;

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
    for (const ModelPlacement& m : s.models) {
        Scene part = load_gltf(m.file, gltf_options);
        // The budget holds for the scene, not for each model: what this one takes is gone.
        const std::uint64_t used = part.positions.size() * sizeof(glm::dvec3) +
                                   part.triangles.size() * (sizeof(glm::u32vec3) + sizeof(std::uint32_t) + 1);
        gltf_options.max_memory_bytes -= std::min(gltf_options.max_memory_bytes, used);
        place_model(part, m);
        append_model(s.scene, std::move(part), s.models.size() > 1 ? m.label : "");
    }
    if (!s.scene.bounds.empty())
        for (const glm::dvec3& corner : {s.scene.bounds.lo, s.scene.bounds.hi})
            for (int c = 0; c < 3; ++c)
                if (std::abs(corner[c]) > kMaxCoordinate)
                    top.fail(s.models.size() > 1 ? "scene" : "scale",
                             fmt::format("the {} scene reaches {:g} m, beyond the {:g} m coordinate limit",
                                         s.models.size() > 1 ? "placed" : "scaled", corner[c], kMaxCoordinate));
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
