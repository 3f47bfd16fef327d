// validate over a scenario's camera path (docs/metrics.md, "Flicker"): every frame traced,
// rendered and scored, one oracle BVH and one raster session for them all, and the shimmer between
// consecutive frames that the truth does not have.
#pragma once

#include <cstdint>
#include <vector>

#include "common/frames.h"
#include "common/output_files.h"
#include "common/scenario.h"
#include "pipeline/validate.h"

namespace penumbra {

// One pair of consecutive frames, compared (flicker_between).
struct PairFlicker {
    std::uint64_t points = 0;                    // surface points seen in both frames
    std::vector<std::uint64_t> flicker;          // per light: those whose raster V changed while the truth's did not
    std::vector<std::vector<std::uint8_t>> map;  // per light, per pixel of the later frame: 1 where it flickered
};

// The flicker between frame `a`, seen from `camera_a`, and the later frame `b`. Each surface point of b is reprojected
// into a through the oracle's world position; it is seen in both when a's nearest pixel sees the same surface (within
// two pixel footprints). It flickers for a light when the truth's V is within `tolerance` at both (and certain at both)
// while the raster's V at b differs by more than `tolerance` from its V at every pixel of a around
// the reprojected point that sees the same surface: a raster edge that stands still in the world
// but falls between pixel centres is not counted, one that moved is.
PairFlicker flicker_between(const OracleFrame& oracle_a, const RasterFrame& raster_a, const Camera& camera_a,
                            const OracleFrame& oracle_b, const RasterFrame& raster_b, double tolerance);

struct CameraPathResult {
    ValidateResult last;  // the last frame's verdict; report.json carries `temporal` per light
    std::vector<std::vector<std::uint32_t>> flicker_map;  // per light, per pixel: pairs in which it flickered
    int frames = 0;
    int bvh_builds = 0;
};

// Every frame of scenario.camera_path (which must be set): the oracle's BVH built once, one raster
// session whose camera pass is redrawn per frame, each frame scored as validate() scores one.
CameraPathResult validate_camera_path(const Scenario& scenario, const raster::Technique& technique,
                                      const metrics::Gate& gate, const ValidateOptions& options);

}  // namespace penumbra
