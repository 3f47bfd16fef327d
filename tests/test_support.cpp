#include "tests/test_support.h"

#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <fstream>
#include <glm/geometric.hpp>

#include "common/camera.h"

namespace penumbra::test {
namespace fs = std::filesystem;

std::uint32_t SceneBuilder::triangle(glm::dvec3 a, glm::dvec3 b, glm::dvec3 c, bool double_sided) {
    return scene_.add_triangle(a, b, c, double_sided);
}

std::uint32_t SceneBuilder::quad(glm::dvec3 a, glm::dvec3 b, glm::dvec3 c, glm::dvec3 d, bool double_sided) {
    std::uint32_t first = triangle(a, b, c, double_sided);
    triangle(a, c, d, double_sided);
    return first;
}

std::uint32_t SceneBuilder::box(glm::dvec3 lo, glm::dvec3 hi) {
    glm::dvec3 p[8];
    for (int i = 0; i < 8; ++i) p[i] = {i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z};
    std::uint32_t first = quad(p[0], p[2], p[3], p[1], false);  // -z
    quad(p[4], p[5], p[7], p[6], false);                        // +z
    quad(p[0], p[4], p[6], p[2], false);                        // -x
    quad(p[1], p[3], p[7], p[5], false);                        // +x
    quad(p[0], p[1], p[5], p[4], false);                        // -y
    quad(p[2], p[6], p[7], p[3], false);                        // +y
    return first;
}

std::uint32_t SceneBuilder::grid(glm::dvec3 o, glm::dvec3 u, glm::dvec3 v, int nu, int nv) {
    std::uint32_t first = static_cast<std::uint32_t>(scene_.triangles.size());
    for (int j = 0; j < nv; ++j)
        for (int i = 0; i < nu; ++i) {
            glm::dvec3 a = o + (double(i) / nu) * u + (double(j) / nv) * v;
            glm::dvec3 b = o + (double(i + 1) / nu) * u + (double(j) / nv) * v;
            glm::dvec3 c = o + (double(i + 1) / nu) * u + (double(j + 1) / nv) * v;
            glm::dvec3 d = o + (double(i) / nu) * u + (double(j + 1) / nv) * v;
            quad(a, b, c, d, false);
        }
    return first;
}

std::uint32_t SceneBuilder::sphere(glm::dvec3 center, double radius, int slices, int stacks) {
    std::uint32_t first = static_cast<std::uint32_t>(scene_.triangles.size());
    auto at = [&](int i, int j) {
        double phi = 2 * M_PI * i / slices, theta = M_PI * j / stacks;
        return center +
               radius * glm::dvec3(std::sin(theta) * std::cos(phi), std::cos(theta), -std::sin(theta) * std::sin(phi));
    };
    for (int j = 0; j < stacks; ++j)
        for (int i = 0; i < slices; ++i) {
            glm::dvec3 a = at(i, j), b = at(i, j + 1), c = at(i + 1, j + 1), d = at(i + 1, j);
            if (j > 0) triangle(a, b, d);
            if (j < stacks - 1) triangle(b, c, d);
        }
    return first;
}

Camera look_at(glm::dvec3 eye, glm::dvec3 target, double yfov_deg, glm::dvec3 up) {
    Camera c;
    look_at_basis(eye, target, up, c);
    c.type = ProjectionType::perspective;
    c.yfov_rad = yfov_deg * M_PI / 180;
    c.znear = 1e-3 * glm::length(target - eye);
    c.zfar = 1e30;
    return c;
}

Camera look_at_ortho(glm::dvec3 eye, glm::dvec3 target, double xmag, double ymag, glm::dvec3 up) {
    Camera c;
    look_at_basis(eye, target, up, c);
    c.type = ProjectionType::orthographic;
    c.xmag = xmag;
    c.ymag = ymag;
    c.znear = 0;
    c.zfar = 1e30;
    return c;
}

Light directional(glm::dvec3 direction) {
    Light l;
    l.type = LightType::directional;
    l.direction = glm::normalize(direction);
    l.origin = "test directional";
    return l;
}

Light point(glm::dvec3 position) {
    Light l;
    l.type = LightType::point;
    l.position = position;
    l.origin = "test point";
    return l;
}

Light rect(glm::dvec3 center, glm::dvec3 u, glm::dvec3 v) {
    Light l;
    l.type = LightType::rect;
    l.position = center;
    l.u = u;
    l.v = v;
    l.origin = "test rect";
    return l;
}

Light disk(glm::dvec3 center, glm::dvec3 normal, double radius) {
    Light l;
    l.type = LightType::disk;
    l.position = center;
    l.normal = glm::normalize(normal);
    l.radius = radius;
    l.origin = "test disk";
    return l;
}

Light sphere(glm::dvec3 center, double radius) {
    Light l;
    l.type = LightType::sphere;
    l.position = center;
    l.radius = radius;
    l.origin = "test sphere";
    return l;
}

Light spot(glm::dvec3 position, glm::dvec3 direction, double outer_deg) {
    Light l;
    l.type = LightType::spot;
    l.position = position;
    l.direction = glm::normalize(direction);
    l.outer_cone_rad = outer_deg * M_PI / 180;
    l.origin = "test spot";
    return l;
}

Scenario make_scenario(Scene scene, Camera camera, std::vector<Light> lights, int width, int height) {
    Scenario s;
    s.label = "test";
    s.width = width;
    s.height = height;
    s.camera = camera;
    s.lights = std::move(lights);
    s.scene = std::move(scene);
    return s;
}

TempDir::TempDir() {
    static std::atomic<int> counter{0};
    path_ =
        fs::temp_directory_path() / ("penumbra-test-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
    fs::remove_all(path_);
    fs::create_directories(path_);
}

TempDir::~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
}

GltfFixture::GltfFixture() {
    const float pos[] = {0, 0, 0, 1, 0, 0, 1, 0, -1, 0, 0, -1};
    const std::uint16_t idx[] = {0, 1, 2, 0, 2, 3};
    bin.resize(sizeof pos + sizeof idx);
    std::memcpy(bin.data(), pos, sizeof pos);
    std::memcpy(bin.data() + sizeof pos, idx, sizeof idx);
    doc = {
        {"asset", {{"version", "2.0"}}},
        {"scene", 0},
        {"scenes", {{{"nodes", {0}}}}},
        {"nodes", {{{"mesh", 0}}}},
        {"meshes", {{{"primitives", {{{"attributes", {{"POSITION", 0}}}, {"indices", 1}}}}}}},
        {"accessors",
         {{{"bufferView", 0},
           {"componentType", 5126},
           {"count", 4},
           {"type", "VEC3"},
           {"min", {0, 0, -1}},
           {"max", {1, 0, 0}}},
          {{"bufferView", 1}, {"componentType", 5123}, {"count", 6}, {"type", "SCALAR"}}}},
        {"bufferViews",
         {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", sizeof pos}},
          {{"buffer", 0}, {"byteOffset", sizeof pos}, {"byteLength", sizeof idx}}}},
        {"buffers", {{{"uri", "scene.bin"}, {"byteLength", bin.size()}}}},
    };
}

fs::path GltfFixture::write(const TempDir& dir, const std::string& name) const {
    std::ofstream b(dir / "scene.bin", std::ios::binary);
    b.write(reinterpret_cast<const char*>(bin.data()), static_cast<std::streamsize>(bin.size()));
    write_text(dir / name, doc.dump(1));
    return dir / name;
}

void write_text(const fs::path& file, const std::string& text) {
    std::ofstream out(file, std::ios::binary);
    out << text;
}

std::uint32_t add_cutout_card(Scene& scene, glm::dvec3 corner, glm::dvec3 u, glm::dvec3 v, AlphaTexture texture,
                              bool nearest, double cutoff) {
    scene.pad_cutout_arrays();
    CutoutMaterial m;
    m.texture = static_cast<int>(scene.alpha_textures.size());
    m.nearest = nearest;
    m.cutoff = cutoff;
    m.wrap_s = m.wrap_t = TextureWrap::clamp_to_edge;
    m.label = "card";
    scene.alpha_textures.push_back(std::move(texture));
    scene.cutout_materials.push_back(m);
    const auto material = static_cast<std::uint32_t>(scene.cutout_materials.size() - 1);
    const glm::dvec3 p[4] = {corner, corner + u, corner + u + v, corner + v};
    const glm::vec2 uv[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    std::uint32_t first = 0;
    for (const glm::ivec3 t : {glm::ivec3(0, 1, 2), glm::ivec3(0, 2, 3)}) {
        const auto base = static_cast<std::uint32_t>(scene.positions.size());
        const std::uint32_t tri = scene.add_triangle(p[t.x], p[t.y], p[t.z], true);
        if (t.y == 1) first = tri;
        scene.triangle_cutout[tri] = material;
        for (int k = 0; k < 3; ++k) scene.texcoords[base + k] = uv[t[k]];
    }
    return first;
}

AlphaTexture checkerboard_alpha(int n) {
    AlphaTexture t;
    t.width = t.height = n;
    t.label = "checkerboard";
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) t.alpha.push_back((i + j) % 2 == 0 ? 65535 : 0);
    return t;
}

fs::path assimp_model(const std::string& relative) {
    fs::path p = fs::path("/usr/share/assimp/models/glTF2") / relative;
    return fs::exists(p) ? p : fs::path();
}

}  // namespace penumbra::test
