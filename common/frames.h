// Per-pixel results exchanged between modules (design.md, "Data flow"). Images are row-major,
// row 0 at the top, one value per pixel.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <limits>
#include <string>
#include <vector>

namespace penumbra {

inline constexpr std::uint32_t kNoPrimitive = 0xFFFFFFFFu;
inline constexpr float kNoDistance = std::numeric_limits<float>::infinity();

// What the oracle knows about one light at every pixel.
struct OracleLightImage {
    std::vector<float> V;           // visibility in [0, 1]
    std::vector<float> E;           // 95% half-width of V (0 when exact)
    std::vector<float> U;           // 1 where the truth is within float error of a boundary
    std::vector<float> lightable;   // 1 where the surface faces the light (and lies in a spot cone)
    std::vector<float> occluder_m;  // metres along the shadow ray to the nearest occluder; inf if none
    std::vector<float>
        boundary_m;  // metres (across the light direction) to the nearest shadow boundary; inf if none seen
};

struct OracleFrame {
    int width = 0, height = 0;
    glm::dvec3 frame_origin{0.0};     // world position of the local frame (the camera eye)
    std::vector<float> A;             // 1 surface, 0 background
    std::vector<std::uint32_t> prim;  // triangle index into Scene::triangles, kNoPrimitive if none
    std::vector<float> depth;         // view depth (metres along the camera's forward axis)
    std::vector<glm::vec3> P;         // surface point relative to frame_origin
    std::vector<glm::vec3> N;         // unit geometric normal on the side the camera sees
    std::vector<OracleLightImage> lights;

    std::size_t pixel_count() const { return static_cast<std::size_t>(width) * height; }
};

}  // namespace penumbra
