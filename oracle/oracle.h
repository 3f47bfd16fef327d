// The oracle: exact visibility of every light from the surface seen through each pixel,
// traced with Embree in a camera-centred frame with error-bounded shadow rays.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/frames.h"
#include "common/scenario.h"

namespace penumbra {

struct OracleSettings {
    int threads = 0;                    // 0: all hardware threads
    bool progress = false;              // progress line on stderr
    int boundary_bisection_steps = 12;  // each step halves the boundary's position interval
};

struct OracleLightStats {
    std::uint64_t surface = 0, lightable = 0, shadowed = 0, uncertain = 0;
};

struct OracleStats {
    std::uint64_t primary_rays = 0;
    std::uint64_t shadow_rays = 0;
    std::uint64_t boundary_rays = 0;      // bisection rays locating shadow boundaries
    std::uint64_t verified_retraces = 0;  // rays re-traced with double-precision hit checks
    double build_s = 0, trace_s = 0, boundary_s = 0;
    int threads = 0;
    std::string embree_version;
    std::vector<OracleLightStats> lights;
};

struct OracleResult {
    OracleFrame frame;
    OracleStats stats;
};

// Throws InputError for what the oracle cannot judge (e.g. area lights, for now) and
// EnvironmentError for Embree failures.
OracleResult run_oracle(const Scenario& scenario, const OracleSettings& settings = {});

}  // namespace penumbra
