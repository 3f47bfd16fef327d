// Synthetic oracle + raster frames for the metrics and report tests.
#pragma once

#include <span>

#include "common/frames.h"
#include "metrics/classification.h"

namespace penumbra::test {

// One light; every pixel a lit, lightable surface seen by the same triangle in both frames,
// with a raster verdict that agrees. Tests then break single pixels.
struct Frames {
    OracleFrame o;
    RasterFrame r;
    Frames(int w, int h) {
        const std::size_t n = static_cast<std::size_t>(w) * h;
        o.width = r.width = w;
        o.height = r.height = h;
        o.A.assign(n, 1.0f);
        r.A.assign(n, 1.0f);
        o.prim.assign(n, 7u);
        r.prim.assign(n, 7u);
        OracleLightImage ol;
        ol.V.assign(n, 1.0f);
        ol.E.assign(n, 0.0f);
        ol.U.assign(n, 0.0f);
        ol.lightable.assign(n, 1.0f);
        ol.occluder_m.assign(n, kNoDistance);
        ol.boundary_m.assign(n, kNoDistance);
        o.lights.push_back(ol);
        RasterLightImage rl;
        rl.V.assign(n, 1.0f);
        DepthMapLookups& lk = rl.lookups.emplace();
        lk.ref_depth.assign(n, 0.5f);
        lk.stored_depth.assign(n, 0.6f);
        lk.stored_prim.assign(n, 7u);
        lk.footprint_m.assign(n, 0.01f);
        lk.texel_slope.assign(n, 1e-4f);
        lk.bias_m.assign(n, 0.0f);
        lk.depth_to_m.assign(n, 10.0f);
        lk.flags.assign(n, kRasterSurface);
        r.lights.push_back(rl);
    }
    OracleLightImage& ol() { return o.lights[0]; }
    RasterLightImage& rl() { return r.lights[0]; }
    DepthMapLookups& lk() { return *r.lights[0].lookups; }
    // An engine's frame: V only, no depth-map lookups.
    void drop_lookups() { r.lights[0].lookups.reset(); }
    // The true shadow at pixel i: occluder `d` metres away along the ray, boundary far away.
    void shadow(std::size_t i, float occluder_m) {
        ol().V[i] = 0.0f;
        ol().occluder_m[i] = occluder_m;
    }
    metrics::FrameScore score(metrics::ScoringOptions opt = {}) const {
        return metrics::score_frames(o, r, std::span(&opt, 1));
    }
};

}  // namespace penumbra::test
