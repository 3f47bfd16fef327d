// Helpers shared by the tests: scenes built in memory (for the oracle's analytic tests) and
// glTF files written to a temporary folder (for the loader's malformed-input tests).
#pragma once

#include <filesystem>
#include <glm/vec3.hpp>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/scenario.h"

namespace penumbra::test {

// A scene assembled from shapes, world space, CCW-outward triangles.
class SceneBuilder {
  public:
    // Returns the index of the first triangle added.
    std::uint32_t triangle(glm::dvec3 a, glm::dvec3 b, glm::dvec3 c, bool double_sided = true);
    std::uint32_t quad(glm::dvec3 a, glm::dvec3 b, glm::dvec3 c, glm::dvec3 d, bool double_sided = true);
    std::uint32_t box(glm::dvec3 lo, glm::dvec3 hi);
    std::uint32_t grid(glm::dvec3 origin, glm::dvec3 u, glm::dvec3 v, int nu, int nv);  // +u x v faces
    // A UV sphere with its vertices on the sphere (so it lies inside it), faces outward.
    std::uint32_t sphere(glm::dvec3 center, double radius, int slices, int stacks);
    Scene build() const { return scene_; }
    std::size_t triangle_count() const { return scene_.triangles.size(); }

  private:
    Scene scene_;
};

// Adds a double-sided cut-out card (alphaMode MASK, common/alpha_coverage.h) as two triangles:
// uv (0, 0) at `corner`, `u` and `v` its full edges, `texture` its alpha. Returns its first triangle.
std::uint32_t add_cutout_card(Scene& scene, glm::dvec3 corner, glm::dvec3 u, glm::dvec3 v, AlphaTexture texture,
                              bool nearest, double cutoff = 0.5);
// A checkerboard alpha of n x n texels, opaque where (i + j) is even.
AlphaTexture checkerboard_alpha(int n);

Camera look_at(glm::dvec3 eye, glm::dvec3 target, double yfov_deg, glm::dvec3 up = {0, 1, 0});
Camera look_at_ortho(glm::dvec3 eye, glm::dvec3 target, double xmag, double ymag, glm::dvec3 up = {0, 1, 0});
Light directional(glm::dvec3 direction);
Light point(glm::dvec3 position);
Light spot(glm::dvec3 position, glm::dvec3 direction, double outer_deg);
Light rect(glm::dvec3 center, glm::dvec3 u, glm::dvec3 v);  // full edges; emits towards u x v
Light disk(glm::dvec3 center, glm::dvec3 normal, double radius);
Light sphere(glm::dvec3 center, double radius);

Scenario make_scenario(Scene scene, Camera camera, std::vector<Light> lights, int width, int height);

// A fresh, empty folder under the system temporary folder, removed with the object.
class TempDir {
  public:
    TempDir();
    ~TempDir();
    const std::filesystem::path& path() const { return path_; }
    std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

  private:
    std::filesystem::path path_;
};

// A minimal valid glTF (one triangle mesh, external .bin) as JSON plus its buffer bytes, for
// tests to break in one place before writing.
struct GltfFixture {
    nlohmann::json doc;
    std::vector<unsigned char> bin;
    GltfFixture();  // a unit quad (two indexed triangles) on y = 0
    std::filesystem::path write(const TempDir& dir, const std::string& name = "scene.gltf") const;
};

void write_text(const std::filesystem::path& file, const std::string& text);

// Path to the assimp test models of Debian's assimp-testmodels package ("" if absent).
std::filesystem::path assimp_model(const std::string& relative);

}  // namespace penumbra::test
