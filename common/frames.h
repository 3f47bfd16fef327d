// Per-pixel results exchanged between modules (docs/design.md, "Data flow"). Images are row-major,
// row 0 at the top, one value per pixel.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <limits>
#include <optional>
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

// Flags of RasterLightImage::flags (the values the lookup shader writes).
inline constexpr std::uint32_t kRasterSurface = 1u;      // a triangle covers the pixel
inline constexpr std::uint32_t kRasterBackFacing = 2u;   // N.L <= 0: V = 0 without a lookup
inline constexpr std::uint32_t kRasterOutsideCone = 4u;  // spot light: outside the cone, V = 0
inline constexpr std::uint32_t kRasterOutsideMap = 8u;   // the lookup fell outside the light's map (V = 1)

// The lookups behind a depth-map technique's verdict (docs/raster.md, "Lookup channels"): an
// optional layer, present when the technique samples a depth map. Without it (an engine's frame,
// shadow volumes) the metrics decide the classes from the oracle's geometry (docs/metrics.md).
struct DepthMapLookups {
    std::vector<float> ref_depth;            // receiver depth at the centre texel after every bias (map depth units)
    std::vector<float> stored_depth;         // depth stored in the centre texel; inf outside the map
    std::vector<std::uint32_t> stored_prim;  // triangle stored in the centre texel
    std::vector<float> footprint_m;          // shadow-map texel size at the receiver, metres
    std::vector<float> texel_slope;          // receiver-plane depth change across half a texel (depth units)
    std::vector<float> bias_m;               // every bias together, as metres along the light ray (estimate)
    std::vector<float> depth_to_m;           // metres along the light ray per depth unit, at the receiver
    std::vector<std::uint32_t> flags;        // kRaster*
    std::vector<std::uint32_t> layer;        // the light's shadow view the lookup used (0 without one)

    void resize(std::size_t n) {
        ref_depth.resize(n);
        stored_depth.resize(n);
        stored_prim.resize(n);
        footprint_m.resize(n);
        texel_slope.resize(n);
        bias_m.resize(n);
        depth_to_m.resize(n);
        flags.resize(n);
        layer.resize(n);
    }
};

// What a shadow technique decided for one light at every pixel (docs/design.md, "Data flow").
struct RasterLightImage {
    std::vector<float> V;                    // the technique's shadow factor, 1 lit
    std::optional<DepthMapLookups> lookups;  // depth-map diagnostics, when the technique has them
};

struct RasterFrame {
    int width = 0, height = 0;
    glm::dvec3 frame_origin{0.0};     // world position of the local frame (the camera eye)
    std::vector<float> A;             // 1 surface, 0 background
    std::vector<std::uint32_t> prim;  // triangle seen by the camera pass, kNoPrimitive if none
    std::vector<RasterLightImage> lights;
    std::size_t pixel_count() const { return static_cast<std::size_t>(width) * height; }
};

}  // namespace penumbra
