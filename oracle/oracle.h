// The oracle: exact visibility of every light from the surface seen through each pixel,
// traced with Embree in a camera-centred frame with error-bounded shadow rays.
#pragma once

#include <cstdint>
#include <functional>
#include <future>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "common/frames.h"
#include "common/scenario.h"

namespace penumbra {

struct OracleSettings {
    int threads = 0;                    // 0: all hardware threads
    bool progress = false;              // progress line on stderr
    int boundary_bisection_steps = 12;  // where bisection places a boundary: each step halves its interval
    // Area lights (docs/oracle.md, "Area lights"):
    std::uint64_t seed = 0;          // scrambles of the sampling pattern; same seed, same image
    double area_target = 1.0 / 255;  // stop refining a pixel once its 95% half-width E is this small
    int area_max_rays = 4096;        // ... or once it has traced this many rays
    int area_uniform_rays = 0;       // > 0: no adaptivity, every lightable pixel traces exactly this many
    // Embree's max_isa ("sse4.2", "avx2", ...): the widest kernels it may use; "" for the best the
    // CPU has. The answers do not depend on it (docs/oracle.md section 7); tests and bug reports
    // use it to run another CPU's code path.
    std::string embree_isa;
};

// The error bound of the refined pixels after a given number of rays per pixel.
struct ConvergencePoint {
    int rays = 0;                  // rays per pixel
    std::uint64_t sampling = 0;    // refined pixels that traced at least this many rays
    double mean_e = 0, max_e = 0;  // over all refined pixels: E after min(rays, the pixel's own count)
};

struct OracleAreaStats {
    std::uint64_t rays = 0;          // shadow rays to the light
    std::uint64_t refined = 0;       // pixels sampled beyond the first round
    std::uint64_t capped = 0;        // refined pixels that stopped at area_max_rays with E above the target
    double rays_per_pixel_mean = 0;  // over lightable pixels
    int rays_per_pixel_max = 0;
    std::vector<ConvergencePoint> convergence;
};

struct OracleLightStats {
    std::uint64_t surface = 0, lightable = 0, shadowed = 0, uncertain = 0;
    bool area = false;
    OracleAreaStats sampling;  // area lights only
};

// Where the boundary phase's time goes (oracle.json "boundary_seconds"), summed over lights.
struct OracleBoundaryTimes {
    double locate_s = 0;  // boundary points between straddling pixel pairs (the exact shadow rays)
    double merge_s = 0;   // the points in row-major order, each pixel's own nearest
    double grid_s = 0;    // the charts, the grid over them, the points filed by cell
    double sweeps_s = 0;  // each cell's nearest point (the distance transform)
    double lists_s = 0;   // each cell's candidates and each point's neighbours
    double pixels_s = 0;  // each pixel's nearest point and its distance
};

struct OracleStats {
    std::uint64_t primary_rays = 0;
    std::uint64_t shadow_rays = 0;
    std::uint64_t boundary_rays = 0;      // verified rays locating shadow boundaries
    std::uint64_t verified_retraces = 0;  // shadow rays re-traced with double-precision hit checks
    std::uint64_t culled_retraces = 0;    // primary rays traced again past a single-sided back face
    // Those rays by the glTF node of the back face they met first, by node (docs/metrics.md,
    // "Facing"): how much of each mesh the camera sees from behind.
    std::vector<std::pair<std::uint32_t, std::uint64_t>> culled_by_node;
    // frame: the wait for the channels' allocation left after the build it overlaps
    double build_s = 0, frame_s = 0, trace_s = 0, area_s = 0, boundary_s = 0;
    OracleBoundaryTimes boundary_parts;
    int threads = 0;
    std::string embree_version;
    std::vector<OracleLightStats> lights;
};

struct OracleResult {
    OracleFrame frame;
    OracleStats stats;
    OracleSettings settings;  // what produced it
    // run_oracle's BVH and vertex copies (~330 MB on the 2.36M-triangle field) are freed on a
    // thread of their own while the caller writes the frame (0.01-0.05 s that the serial write
    // can hide, #39); the last copy of the result waits for it when destroyed.
    std::shared_future<void> tracer_released;
};

// Called by run_oracle once the trace is done (the area lights' sampling included), before the
// boundary phase, e.g. to start writing the frame (#39). Every channel is final then except each
// light's U and boundary_m, which the boundary phase writes while the work the hook started
// runs: that work must read neither, and must hold the channels' data pointers, not the frame
// (the result is moved out of run_oracle; the arrays stay where they are). The hook returns
// that work (an empty future if it did all of it before returning); should a later phase throw,
// run_oracle waits for it before the frame is freed.
using OracleTraceDone = std::function<std::shared_future<void>(const OracleFrame&)>;

// Throws EnvironmentError for Embree failures.
OracleResult run_oracle(const Scenario& scenario, const OracleSettings& settings = {},
                        const OracleTraceDone& trace_done = {});

// The oracle of a camera path (docs/oracle.md, "Camera paths"): the BVH is built once, in the
// local frame of the scenario's camera, and each frame costs its trace alone. A trace from the
// scenario's camera gives run_oracle's frame; its stats' build_s is 0 (the session's is build_s()).
// The scenario must outlive the session. Throws EnvironmentError for Embree failures.
class OracleSession {
  public:
    explicit OracleSession(const Scenario& scenario, const OracleSettings& settings = {});
    ~OracleSession();
    OracleSession(const OracleSession&) = delete;
    OracleSession& operator=(const OracleSession&) = delete;

    OracleResult trace(const Camera& camera);
    int bvh_builds() const;  // BVHs built: 1, whatever the number of traces
    double build_s() const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace penumbra
