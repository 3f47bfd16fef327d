// Internal to the oracle: the Embree scene in the camera-centred frame and the ray queries
// built on it. Shared by tracing (tracer.cpp) and the shadow-boundary search.
#pragma once

#include <cmath>
#include <cstdint>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <limits>
#include <memory>
#include <unordered_map>
#include <vector>

#include "common/frames.h"
#include "common/scenario.h"
#include "oracle/area_sampling.h"
#include "oracle/embree_handles.h"
#include "oracle/oracle.h"
#include "oracle/robust_geometry.h"

namespace penumbra::oracle_detail {

// One light expressed in the local (camera-centred) frame.
struct LocalLight {
    LightType type = LightType::directional;
    glm::dvec3 position{0.0};   // local
    glm::dvec3 to_light{0.0};   // directional: unit vector towards the light
    glm::dvec3 spot_axis{0.0};  // spot: unit direction light travels
    double cos_outer = -1;
    // V is a sampled fraction (area_pass.cpp): an area light, or a sun with a size (is_soft_light).
    bool sampled = false;
    AreaLight area;  // rect, disk, sphere, and a sun with a size
};

// Point and spot shadow rays stop this relative distance short of the light, so geometry
// touching the light position does not count and float rounding of the direction cannot
// carry the ray past it.
inline constexpr double kLightMargin = 64 * robust::kFloatEps;
// |N.L| (or the spot-cone cosine difference) below this is within float error of the
// terminator: a rasteriser may decide either way, so the pixel is flagged ambiguous.
inline constexpr double kTerminatorTolerance = 64 * robust::kFloatEps;

// Unit direction from p towards the light (for a directional light, the same everywhere).
inline glm::dvec3 direction_to_light(const LocalLight& l, const glm::dvec3& p) {
    if (l.type == LightType::directional) return l.to_light;
    glm::dvec3 d = l.position - p;
    double len = glm::length(d);
    return len > 0 ? d / len : glm::dvec3(0.0);
}

// What the primary ray found at one pixel.
struct SurfacePoint {
    bool hit = false;
    std::uint32_t prim = kNoPrimitive;
    glm::dvec3 p{0.0};      // local, double, exactly on the triangle
    glm::dvec3 n{0.0};      // unit geometric normal, facing the camera
    glm::dvec3 error{0.0};  // per-component float error bound of p (robust::surface_error_bound)
    double depth = 0;
    bool ambiguous = false;  // the camera's ray passed within float error of a cut-out's edge
};

// A shadow ray ready to trace, or the reason there is none.
struct ShadowSetup {
    bool lightable = false;  // faces the light and lies inside a spot cone
    bool ambiguous = false;  // within float error of the terminator or the cone's edge
    glm::vec3 origin{0.0f}, dir_f{0.0f};
    glm::dvec3 dir{0.0};
    float tfar = 0;
};
// Aims r (whose origin is set) at a point on a light: the ray stops kLightMargin short of it.
// Returns the distance from the origin to the point.
inline double aim_at_light_point(ShadowSetup& r, const glm::dvec3& target) {
    const glm::dvec3 d = target - glm::dvec3(r.origin);
    const double dist = glm::length(d);
    r.dir = d / dist;
    r.dir_f = glm::vec3(r.dir);
    r.tfar = static_cast<float>(dist * (1.0 - kLightMargin));
    return dist;
}

// Fills `r` in place (inline, no temporary): it runs once per pixel and light on the hot
// path, where building a struct and copying it cost store-forwarding stalls.
inline void setup_shadow(const LocalLight& light, const SurfacePoint& s, ShadowSetup& r) {
    const glm::dvec3 to_light = direction_to_light(light, s.p);
    const double cos_nl = glm::dot(s.n, to_light);
    bool in_cone = true, ambiguous = std::abs(cos_nl) <= kTerminatorTolerance;
    if (light.type == LightType::spot) {
        double c = glm::dot(-to_light, light.spot_axis);
        in_cone = c >= light.cos_outer;
        ambiguous |= std::abs(c - light.cos_outer) <= kTerminatorTolerance;
    }
    r.ambiguous = ambiguous;
    r.lightable = cos_nl > 0 && in_cone;
    if (!r.lightable) return;
    r.origin = robust::offset_ray_origin(s.p, s.n, s.error);
    if (light.type == LightType::directional) {
        r.dir = to_light;
        r.dir_f = glm::vec3(r.dir);
        r.tfar = std::numeric_limits<float>::infinity();
    } else {
        aim_at_light_point(r, light.position);
    }
}

// Traces a packet's active lanes (valid[k] == -1). Where the CPU has no native 16-wide
// kernels (AVX2 and older), Embree 3 hands rtcIntersect16 to its stream fallback, which ignores
// `valid`: it traces every lane whose tnear <= tfar and writes its hit back (rtcore.cpp and
// bvh_intersector_stream_filters.cpp in Embree 3.13; RenderKit/embree#520). An inactive lane
// then traced whatever it held: a previous packet's ray (wasted work), or uninitialised floats
// that trip Embree's finite-ray assertion and abort. Inactive lanes get a defined ray with
// tfar = -inf here, which every path skips (and Valgrind sees no undefined value enter Embree);
// their ray is overwritten, their hit's primID and geomID left as they were.
// as_halves: trace the packet as two 8-wide packets (rtcIntersect8), for a device with native
// 8-wide kernels and no 16-wide ones, where copying the halves in and out costs less than the
// fallback's lane-by-lane gathers (docs/oracle.md section 9).
void intersect_active_lanes(const int* valid, RTCScene scene, RTCIntersectContext* ctx, RTCRayHit16& rh,
                            bool as_halves);
// Whether `device` should get its packets as halves: native 8-wide kernels, no 16-wide ones.
bool packets_as_halves(RTCDevice device);

// Metres from the true surface point p to the hit at Embree's t (measured from the offset origin).
float occluder_distance(const ShadowSetup& setup, const glm::dvec3& p, float t_hit);

struct ShadowAnswer {
    bool blocked = false;
    bool ambiguous = false;
    float occluder_t = kNoDistance;
    std::uint32_t occluder = kNoPrimitive;  // the nearest occluder (set by trace_shadow_verified only)
};

struct TraceCounters {
    std::uint64_t primary = 0, shadow = 0, retraced = 0;
    std::uint64_t culled = 0;  // primary rays traced again past a single-sided triangle's back
    // Of those, per glTF node of the back face met first (docs/metrics.md, "Facing").
    std::unordered_map<std::uint32_t, std::uint64_t> culled_by_node;
};

// One round of kRoundRays shadow rays from a receiver to points spread over an area light.
struct AreaRound {
    int visible = 0;                 // rays that reached the light (points under the horizon do not)
    float occluder_t = kNoDistance;  // nearest occluder met by any ray
};

class Tracer {
  public:
    // embree_isa: OracleSettings::embree_isa.
    explicit Tracer(const Scenario& scenario, const std::string& embree_isa = "");
    void build();  // BVH over the scene in the local frame, centred on the scenario's camera
    // The camera the next traces see from (a camera path's frame): the BVH and the local frame
    // stay; primary rays start at its eye, relative to frame_origin().
    void set_camera(const Camera& camera);
    const Camera& camera() const { return camera_; }
    const glm::dvec3& camera_eye() const { return camera_eye_; }  // local frame

    const Scenario& scenario() const { return scenario_; }
    const EmbreeDevice& device() const { return device_; }
    const glm::dvec3& frame_origin() const { return frame_origin_; }
    const std::vector<LocalLight>& lights() const { return lights_; }

    // Traces tiles first ... last - 1 of a row-major grid of square tiles `tile` pixels wide,
    // `tiles_x` to a row, one after the other. Each tile's output lines are prefetched a tile
    // ahead, so that their reads from memory overlap the tile before instead of stalling this
    // one's stores (docs/oracle.md section 9); not past `last`, whose tiles another thread may
    // be writing.
    void trace_tiles(OracleFrame& frame, int first, int last, int tiles_x, int tile, TraceCounters& counters,
                     std::vector<SurfacePoint>* surfaces = nullptr) const;

    // One round of shadow rays from surface point s to light `li`: points first_point ...
    // first_point + kRoundRays - 1 of the Sobol (0,2)-sequence under the digital shift `scramble`.
    AreaRound trace_area_round(std::size_t li, const SurfacePoint& s, const AreaView& view, int first_point,
                               std::uint64_t scramble, TraceCounters& counters) const;

    // One shadow ray from a point with every candidate hit judged in double: the exact, slow
    // path, used for suspicious hits and for the boundary search. `self_prim` may be kNoPrimitive.
    ShadowAnswer trace_shadow_verified(const ShadowSetup& setup, const glm::dvec3& p, std::uint32_t self_prim) const;

    const glm::dvec3& vertex(std::uint32_t prim, int k) const { return vertices_[tris_[prim][k]]; }
    glm::dvec3 normal_ccw(std::uint32_t prim) const;
    robust::HitVerdict verify(std::uint32_t prim, const glm::dvec3& p, const glm::dvec3& dir,
                              std::uint32_t self_prim) const;
    bool culled_for_camera(std::uint32_t prim, const glm::dvec3& ray_dir) const;
    // Whether triangle prim is a cut-out (alphaMode MASK): part of it may let rays through.
    bool is_cutout(std::uint32_t prim) const { return scenario_.scene.cutout_of(prim) != nullptr; }
    // Whether the exact ray org + t dir (local frame) meets cut-out triangle prim where it is
    // opaque; ambiguous within float error of where that changes (docs/oracle.md, "Cut-outs").
    // (u, v): Embree's float barycentrics, used where the ray grazes the triangle's plane.
    CoverageAnswer cutout_hit(std::uint32_t prim, const glm::dvec3& org, const glm::dvec3& dir, float u, float v) const;

  private:
    // Judges lane k of a traced shadow packet: hits within float error of the receiver are
    // re-judged in double, re-tracing the ray when Embree's hit was spurious.
    ShadowAnswer judge_lane(const RTCRayHit16& sh, int k, const ShadowSetup& setup, const SurfacePoint& s,
                            TraceCounters& counters) const;
    // One tile of trace_tiles: primary rays, then one shadow ray per lightable pixel and punctual
    // light. Area lights are sampled afterwards (area_pass.cpp) from the surface points kept in
    // `surfaces` (one per pixel) when it is given.
    void trace_tile(OracleFrame& frame, int x0, int y0, int size, TraceCounters& counters,
                    std::vector<SurfacePoint>* surfaces = nullptr) const;

    void prefetch_tile_outputs(const OracleFrame& frame, int x0, int y0, int size) const;
    // Fills `s` (every field) from Embree's hit; `n_ccw` is normal_ccw(prim), computed once by
    // the caller.
    void primary_hit(std::uint32_t prim, double u, double v, double t, const glm::dvec3& ray_org,
                     const glm::dvec3& ray_dir, const glm::dvec3& n_ccw, SurfacePoint& s) const;
    double suspicious_hit_distance(const glm::dvec3& p, double cos_hit) const;

    const Scenario& scenario_;
    EmbreeDevice device_;
    bool as_halves_ = false;  // packets go to Embree as two halves (intersect_active_lanes)
    EmbreeScene scene_;
    glm::dvec3 frame_origin_{0.0};
    Camera camera_;
    glm::dvec3 camera_eye_{0.0};              // camera_.eye - frame_origin_: zero but on a camera path
    std::unique_ptr<glm::dvec3[]> vertices_;  // local frame, double
    std::size_t vertex_count_ = 0;
    double max_vertex_norm_ = 0;  // largest |v| in the local frame
    std::vector<LocalLight> lights_;
    const std::vector<glm::u32vec3>& tris_;
    const std::vector<std::uint8_t>& double_sided_;
    const std::vector<std::uint32_t>& triangle_node_;
    bool cutouts_ = false;  // the scene has cut-outs: traces carry their exact rays (cutout_filter)
};

// Primary and shadow rays from the tracer's camera, area-light sampling, shadow boundaries and
// the pixel counts: everything of a frame after the BVH build. `result.frame` is allocated.
// `trace_done`, if any, is called between the area lights and the boundaries (run_oracle's).
void trace_frame(const Tracer& tracer, const OracleSettings& settings, OracleResult& result,
                 const OracleTraceDone& trace_done = {});

// Sizes every channel of `frame` for the scenario's image and lights and fills each with its
// default (no surface, unlit, no distance), the channels side by side.
void allocate_frame(OracleFrame& frame, const Scenario& scenario);

// Fills boundary_m of light `li` and flags pixels within float error of a boundary as U.
// Returns the number of bisection rays traced; adds the time of each part to `times`.
std::uint64_t locate_shadow_boundaries(const Tracer& tracer, OracleFrame& frame, std::size_t li, int bisection_steps,
                                       OracleBoundaryTimes& times);

// Samples area light `li` at every lightable pixel: V, E, occluder_m (docs/oracle.md, "Area
// lights"). `surfaces` holds the primary hit of every pixel.
OracleAreaStats sample_area_light(const Tracer& tracer, OracleFrame& frame, std::size_t li,
                                  const std::vector<SurfacePoint>& surfaces, const OracleSettings& settings,
                                  TraceCounters& counters);

}  // namespace penumbra::oracle_detail
