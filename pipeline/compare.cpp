#include "pipeline/compare.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <limits>

#include "common/camera.h"
#include "common/errors.h"
#include "common/projection.h"
#include "common/stopwatch.h"

namespace penumbra {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Where a camera ray meets the plane of a triangle: the view depth t (the ray's direction has
// forward component 1), NaN when the ray runs parallel to the plane.
double plane_depth(const Scene& scene, std::uint32_t prim, const glm::dvec3& eye, const PrimaryRay& ray) {
    const auto& tri = scene.triangles[prim];
    const glm::dvec3 a = scene.positions[tri.x], b = scene.positions[tri.y], c = scene.positions[tri.z];
    const glm::dvec3 n = glm::cross(b - a, c - a);
    const double den = glm::dot(n, ray.direction);
    if (den == 0.0) return kNaN;
    return glm::dot(n, a - (eye + ray.origin)) / den;
}

// The engine's view depth at pixel i, NaN where it saw no surface. ndc and ndc-gl are read with
// the inverse of the projection `penumbra camera` prints (a standard, not reversed, depth range;
// GL's NDC z maps to window depth by w = (z + 1) / 2).
double engine_view_depth(const Camera& cam, const CameraProjection& proj, const EngineFrame& f, std::size_t i) {
    const double d = (*f.depth)[i];
    if (!std::isfinite(d)) return kNaN;
    if (f.depth_space == DepthSpace::linear) return d > 0 && d < cam.zfar ? d : kNaN;
    return proj.view_depth(f.depth_space == DepthSpace::ndc_gl ? 0.5 * (d + 1.0) : d);
}

// A way the engine frame can sit against penumbra's view: engine pixel (x + dx, y + dy), or row
// H - 1 - y when flipped, shows oracle pixel (x, y).
struct Alignment {
    int dx = 0, dy = 0;
    bool flip = false;
    std::string describe() const {
        if (flip) return "flipped vertically (row 0 at the bottom, as GL's glReadPixels returns it)";
        return fmt::format("shifted by ({:+d}, {:+d}) px (x right, y down)", dx, dy);
    }
};

std::vector<Alignment> candidate_alignments() {
    std::vector<Alignment> a = {{}};
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
            if (dx != 0 || dy != 0) a.push_back({dx, dy, false});
    a.push_back({0, 0, true});
    return a;
}

// The engine pixel that shows oracle pixel (x, y) under an alignment, or -1 outside the frame.
std::ptrdiff_t mapped(const Alignment& a, int x, int y, int w, int h) {
    const int ex = x + a.dx, ey = a.flip ? h - 1 - y : y + a.dy;
    if (ex < 0 || ey < 0 || ex >= w || ey >= h) return -1;
    return static_cast<std::ptrdiff_t>(ey) * w + ex;
}

struct Disagreement {
    std::uint64_t bad = 0, total = 0;
    double fraction() const { return total ? double(bad) / double(total) : 0.0; }
};

// A frame is misaligned when another alignment explains it far better than the identity: more
// than three times the best other's disagreeing pixels plus 20 (an aligned frame's own errors
// and silhouettes disagree under every alignment alike; a shifted one disagrees along every
// edge only under the identity). Counts, not a floor on the fraction: a one-pixel shift of a
// large image disagrees at a small fraction of it. The better alignment must itself agree at
// 95% of the pixels or more: shadows wrong nearly everywhere (acne) disagree under every
// alignment, and which is least bad says nothing (the engine's depth does not have this limit).
void check_alignment(const EngineFrame& frame, const std::vector<Disagreement>& d, const char* what) {
    const auto alignments = candidate_alignments();
    std::size_t best = 0;
    for (std::size_t k = 1; k < d.size(); ++k)
        if (d[k].fraction() < d[best].fraction()) best = k;
    if (best == 0 || d[0].bad <= 3 * d[best].bad + 20 || d[best].fraction() > 0.05) return;
    throw InputError(fmt::format(
        "{}: the frame does not line up with the scenario's camera: {} disagrees at {:.2f}% of the pixels, far above "
        "normal, but at {:.2f}% when the frame is {}; render with the view `penumbra camera` prints (pixel centres at "
        "+0.5, row 0 at the top)",
        frame.label, what, 100.0 * d[0].fraction(), 100.0 * d[best].fraction(), alignments[best].describe()));
}

float median_light_distance(const Scenario& sc, const OracleFrame& of, const std::vector<double>& depth,
                            const glm::dvec3& light_pos) {
    PrimaryRays rays(sc.camera, of.width, of.height);
    std::vector<double> dist;
    for (int y = 0; y < of.height; y += 4)
        for (int x = 0; x < of.width; x += 4) {
            const std::size_t i = static_cast<std::size_t>(y) * of.width + x;
            if (!std::isfinite(depth[i])) continue;
            const PrimaryRay r = rays.at(x + 0.5, y + 0.5);
            dist.push_back(glm::length(sc.camera.eye + r.origin + depth[i] * r.direction - light_pos));
        }
    if (dist.empty()) return 0.0f;
    std::nth_element(dist.begin(), dist.begin() + dist.size() / 2, dist.end());
    return static_cast<float>(dist[dist.size() / 2]);
}

// The texel footprint a shadow map of `res` texels per side has at the receivers (docs/compare.md):
// a directional map over the scene's bounding sphere, a spot map over its cone, a cube face
// (90 degrees) for point and area lights, at the median distance of the receivers the camera sees.
float footprint_from_resolution(const Scenario& sc, const OracleFrame& of, const std::vector<double>& depth,
                                const Light& l, int res) {
    if (l.type == LightType::directional) return static_cast<float>(2.0 * sc.scene.bounds.radius() / res);
    const float d = median_light_distance(sc, of, depth, l.position);
    const double half_tan = l.type == LightType::spot ? std::tan(l.outer_cone_rad) : 1.0;
    return static_cast<float>(2.0 * half_tan * d / res);
}

// A verdict on too little of the surface is no verdict: refuse it (exit 2), saying why, rather
// than pass a gate on the pixels that happen to be left.
void check_scored_surface(const Scenario& sc, const EngineFrame& f, const Coverage& cov, const CompareOptions& opt) {
    if (cov.surface == 0)
        throw InputError(fmt::format("{}: the scenario's camera sees no surface: nothing to score", sc.label));
    const double seen = 1.0 - cov.mismatch_fraction();
    if (seen >= opt.min_scored_surface) return;
    const std::string why =
        cov.source == "depth"
            ? fmt::format(
                  "the engine's depth ({}) shows no surface, or another, at the rest; is --depth-space right (linear: "
                  "view depth in metres; ndc: the depth buffer in [0, 1]; ndc-gl: [-1, 1]), and is the depth "
                  "buffer the one rendered with the view `penumbra camera` prints?",
                  to_string(f.depth_space))
            : fmt::format(
                  "the rest lies within --silhouette-band {} px of a silhouette; give a smaller band or the "
                  "engine's depth",
                  opt.silhouette_band_px);
    throw InputError(fmt::format(
        "{}: only {:.2f}% of the {} surface pixels the oracle sees can be scored (at least {:g}% must be): {}",
        cov.source == "depth" ? f.depth_label : f.label, 100.0 * seen, cov.surface, 100.0 * opt.min_scored_surface,
        why));
}

}  // namespace

const char* to_string(DepthSpace s) {
    switch (s) {
        case DepthSpace::linear: return "linear";
        case DepthSpace::ndc: return "ndc";
        case DepthSpace::ndc_gl: return "ndc-gl";
    }
    return "?";
}

std::vector<double> oracle_view_depth(const Scenario& sc, const OracleFrame& of) {
    PrimaryRays rays(sc.camera, of.width, of.height);
    std::vector<double> depth(of.pixel_count(), kNaN);
    for (int y = 0; y < of.height; ++y)
        for (int x = 0; x < of.width; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * of.width + x;
            if (of.A[i] == 0 || of.prim[i] == kNoPrimitive) continue;
            depth[i] = plane_depth(sc.scene, of.prim[i], sc.camera.eye, rays.at(x + 0.5, y + 0.5));
        }
    return depth;
}

void check_engine_frame(const Scenario& sc, const EngineFrame& f) {
    if (f.width != sc.width || f.height != sc.height)
        throw InputError(fmt::format("{}: {}x{} pixels; expected the scenario's image size, {}x{} ({})", f.label,
                                     f.width, f.height, sc.width, sc.height, sc.label));
    if (f.V.size() != sc.lights.size())
        throw InputError(fmt::format("{}: {} shadow channels; expected one per light of {} ({})", f.label, f.V.size(),
                                     sc.label, sc.lights.size()));
    const std::size_t n = static_cast<std::size_t>(f.width) * f.height;
    for (std::size_t li = 0; li < f.V.size(); ++li) {
        if (f.V[li].size() != n)
            throw InputError(fmt::format("{}: light {}: {} values; expected {}", f.label, li, f.V[li].size(), n));
        for (std::size_t i = 0; i < n; ++i) {
            const float v = f.V[li][i];
            // A little beyond [0, 1] is the engine's rounding (half floats); more is another encoding.
            if (std::isfinite(v) && v >= -1e-3f && v <= 1.001f) continue;
            throw InputError(
                fmt::format("{}: light {}: {} at pixel ({}, {}); expected a shadow factor in [0, 1] (1 = lit){}",
                            f.label, li, std::isnan(v) ? std::string("NaN") : fmt::format("{}", v), i % f.width,
                            i / f.width, v > 1.0f && std::isfinite(v) ? " (was it written as 0..255?)" : ""));
        }
    }
    if (f.depth && f.depth->size() != n)
        throw InputError(fmt::format("{}: {} depth values; expected {} ({}x{})", f.depth_label, f.depth->size(), n,
                                     sc.width, sc.height));
    if (f.depth)
        for (std::size_t i = 0; i < n; ++i)
            if (std::isnan((*f.depth)[i]))
                throw InputError(fmt::format("{}: NaN at pixel ({}, {}); expected a depth ({})", f.depth_label,
                                             i % f.width, i / f.width, to_string(f.depth_space)));
}

Coverage engine_coverage(const Scenario& sc, const OracleFrame& of, const std::vector<double>& depth,
                         const EngineFrame& f, const CompareOptions& opt) {
    const int W = of.width, H = of.height;
    const std::size_t n = of.pixel_count();
    Coverage cov;
    cov.seen.assign(n, 0);
    const auto alignments = candidate_alignments();
    std::vector<Disagreement> d(alignments.size());
    auto same_surface = [&](double ze, double zo) {
        return std::isfinite(ze) && std::isfinite(zo) && std::abs(ze - zo) <= opt.depth_tolerance * zo;
    };

    if (f.depth) {
        cov.source = "depth";
        const CameraProjection proj(sc.camera, sc.width, sc.height, sc.scene.bounds);
        std::vector<double> ze(n);
        for (std::size_t i = 0; i < n; ++i) ze[i] = engine_view_depth(sc.camera, proj, f, i);
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) {
                const std::size_t i = static_cast<std::size_t>(y) * W + x;
                if (of.A[i] == 0) continue;
                cov.seen[i] = same_surface(ze[i], depth[i]);
                for (std::size_t k = 0; k < alignments.size(); ++k) {
                    const std::ptrdiff_t j = mapped(alignments[k], x, y, W, H);
                    if (j < 0) continue;
                    ++d[k].total;
                    d[k].bad += !same_surface(ze[j], depth[i]);
                }
            }
        check_alignment(f, d, "the engine's depth");
    } else {
        // No depth: leave out the oracle's silhouettes (a neighbour within the band that is
        // background, or whose ray does not meet this pixel's plane at its own depth: another
        // surface, not a crease of this one).
        cov.source = "silhouette_band";
        PrimaryRays rays(sc.camera, W, H);
        const int r = std::max(0, opt.silhouette_band_px);
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) {
                const std::size_t i = static_cast<std::size_t>(y) * W + x;
                if (of.A[i] == 0) continue;
                bool edge = false;
                for (int v = std::max(0, y - r); v <= std::min(H - 1, y + r) && !edge; ++v)
                    for (int u = std::max(0, x - r); u <= std::min(W - 1, x + r) && !edge; ++u) {
                        const std::size_t j = static_cast<std::size_t>(v) * W + u;
                        if (j == i) continue;
                        if (of.A[j] == 0) {
                            edge = true;
                            break;
                        }
                        if (of.prim[j] == of.prim[i]) continue;
                        const double t = plane_depth(sc.scene, of.prim[i], sc.camera.eye, rays.at(u + 0.5, v + 0.5));
                        edge = !same_surface(t, depth[j]);
                    }
                cov.seen[i] = !edge;
            }
        // Alignment from the shadows themselves: wrong by more than half, where the oracle is
        // sure and the pixel lies off the silhouettes.
        for (std::size_t li = 0; li < of.lights.size(); ++li) {
            const OracleLightImage& o = of.lights[li];
            for (int y = 0; y < H; ++y)
                for (int x = 0; x < W; ++x) {
                    const std::size_t i = static_cast<std::size_t>(y) * W + x;
                    if (!cov.seen[i] || o.lightable[i] == 0 || o.U[i] != 0) continue;
                    for (std::size_t k = 0; k < alignments.size(); ++k) {
                        const std::ptrdiff_t j = mapped(alignments[k], x, y, W, H);
                        if (j < 0) continue;
                        ++d[k].total;
                        d[k].bad += std::abs(f.V[li][j] - o.V[i]) > 0.5f;
                    }
                }
        }
        check_alignment(f, d, "the shadow image");
    }
    for (std::size_t i = 0; i < n; ++i)
        if (of.A[i] != 0) {
            ++cov.surface;
            cov.mismatch += cov.seen[i] == 0;
        }
    return cov;
}

ValidateResult compare(const Scenario& sc, const EngineFrame& f, const CompareOptions& opt, const metrics::Gate& gate) {
    check_engine_frame(sc, f);
    ValidateResult r;
    r.oracle = std::make_shared<const OracleRun>(oracle_for(sc, opt.validate));
    if (r.oracle->warning) r.warnings.push_back(*r.oracle->warning);
    const OracleFrame& of = r.oracle->frame;

    auto t0 = SteadyClock::now();
    const std::vector<double> depth = oracle_view_depth(sc, of);
    const Coverage cov = engine_coverage(sc, of, depth, f, opt);
    check_scored_surface(sc, f, cov, opt);

    // The engine's frame as a V-only RasterFrame: A and prim say where it saw the oracle's
    // surface (anything else is a coverage mismatch to the metrics).
    RasterFrame& rf = r.raster.frame;
    rf.width = f.width;
    rf.height = f.height;
    rf.frame_origin = of.frame_origin;
    const std::size_t n = of.pixel_count();
    const CameraProjection proj(sc.camera, sc.width, sc.height, sc.scene.bounds);
    rf.A.assign(n, 0.0f);
    rf.prim.assign(n, kNoPrimitive);
    for (std::size_t i = 0; i < n; ++i) {
        if (cov.seen[i]) {
            rf.A[i] = 1.0f;
            rf.prim[i] = of.prim[i];
        } else if (of.A[i] != 0) {
            rf.A[i] = 1.0f;  // a surface, not the oracle's one: coverage_mismatch
        } else if (f.depth && std::isfinite(engine_view_depth(sc.camera, proj, f, i))) {
            rf.A[i] = 1.0f;  // the engine saw a surface where there is none
        }
    }
    for (const auto& v : f.V) rf.lights.push_back({v, std::nullopt});

    metrics::ScoringOptions so;
    so.tolerance = static_cast<float>(opt.validate.tolerance);
    so.visible_threshold = static_cast<float>(opt.validate.visible_threshold);
    so.filter_reach_texels = opt.filter_reach_texels;
    so.light_bleeding = opt.moments;
    so.depth_quantum = 0.0f;
    r.scoring.assign(sc.lights.size(), so);
    for (std::size_t li = 0; li < sc.lights.size(); ++li) {
        r.scoring[li].soft = is_soft_light(sc.lights[li]);
        r.scoring[li].bias_reach_m = opt.bias_reach_m;
        if (opt.texel_footprint_m)
            r.scoring[li].texel_footprint_m = opt.texel_footprint_m;
        else if (opt.shadow_map_resolution)
            r.scoring[li].texel_footprint_m =
                footprint_from_resolution(sc, of, depth, sc.lights[li], *opt.shadow_map_resolution);
    }
    r.score = metrics::score_frames(of, rf, r.scoring);
    std::uint64_t scored = 0;
    for (const auto& l : r.score.lights) scored += l.pixels.scored;
    if (scored == 0)
        throw InputError(
            fmt::format("{}: no pixel can be scored: no light reaches a surface the engine's frame shows "
                        "({} of {} surface pixels seen)",
                        f.label, cov.surface - cov.mismatch, cov.surface));
    r.metrics_s = seconds_since(t0);

    r.engine = f.info;
    r.engine["depth"] = f.depth ? nlohmann::json(to_string(f.depth_space)) : nlohmann::json(nullptr);
    r.raster_info = {{"engine", r.engine}};
    r.timing = {{"oracle_s", r.oracle->seconds},
                {"oracle_cached", r.oracle->cached},
                {"raster_s", 0.0},
                {"device_s", 0.0},
                {"raster_ms", nlohmann::json::object()},
                {"metrics_s", r.metrics_s}};
    if (!gate.checks.empty()) r.gate = metrics::evaluate_gate(gate, r.score.lights);
    r.report = report::report_json(report_inputs(sc, r, r.oracle->info), r.score);
    nlohmann::json coverage = {{"source", cov.source},
                               {"surface", cov.surface},
                               {"mismatch", cov.mismatch},
                               {"mismatch_fraction", cov.mismatch_fraction()}};
    if (cov.source == "depth") {
        coverage["depth_tolerance"] = opt.depth_tolerance;
        coverage["note"] = "pixels where the engine's depth buffer shows another surface are not scored";
    } else {
        coverage["band_px"] = opt.silhouette_band_px;
        coverage["note"] =
            "no engine depth: pixels within band_px of the oracle's silhouettes are left out, and pixels where the "
            "engine saw other geometry cannot be found";
    }
    r.report["coverage"] = coverage;
    r.report["engine"] = r.engine;
    return r;
}

}  // namespace penumbra
