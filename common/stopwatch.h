// Wall-clock seconds for the per-phase timings every stage reports (oracle.json, raster.json,
// report.json) and the benchmarks print.
#pragma once

#include <chrono>

namespace penumbra {

using SteadyClock = std::chrono::steady_clock;

inline double seconds_since(SteadyClock::time_point t0) {
    return std::chrono::duration<double>(SteadyClock::now() - t0).count();
}

}  // namespace penumbra
