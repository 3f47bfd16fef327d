#include "pipeline/camera_path.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <memory>

#include "common/camera.h"
#include "common/stopwatch.h"
#include "oracle/oracle_cache.h"
#include "oracle/oracle_output.h"

namespace penumbra {

namespace {

// Where a world point falls in a camera's image: pixel coordinates (centres at + 0.5) and the
// size of a pixel at its depth. Nothing when it lies behind the camera.
struct Projected {
    double px = 0, py = 0;
    double footprint_m = 0;
};

std::optional<Projected> project(const Camera& c, int width, int height, const glm::dvec3& world) {
    const glm::dvec3 rel = world - c.eye;
    const double depth = glm::dot(rel, c.forward);
    const bool persp = c.type == ProjectionType::perspective;
    if (!(depth > 0)) return std::nullopt;
    const glm::dvec2 plane = ndc_to_image_plane(c, width, height);
    const double scale = persp ? depth : 1.0;
    const double nx = glm::dot(rel, c.right) / (scale * plane.x), ny = glm::dot(rel, c.up) / (scale * plane.y);
    Projected p;
    p.px = (nx + 1.0) * 0.5 * width;
    p.py = (1.0 - ny) * 0.5 * height;
    p.footprint_m = 2.0 * scale * plane.y / height;
    return p;
}

}  // namespace

PairFlicker flicker_between(const OracleFrame& oracle_a, const RasterFrame& raster_a, const Camera& camera_a,
                            const OracleFrame& oracle_b, const RasterFrame& raster_b, double tolerance) {
    const int W = oracle_a.width, H = oracle_a.height;
    const std::size_t lights = oracle_b.lights.size();
    PairFlicker out;
    out.flicker.assign(lights, 0);
    out.map.assign(lights, std::vector<std::uint8_t>(oracle_b.pixel_count(), 0));
    const auto tol = static_cast<float>(tolerance);
    auto surface = [](const OracleFrame& o, const RasterFrame& r, std::size_t i) { return o.A[i] != 0 && r.A[i] != 0; };
    auto world = [](const OracleFrame& o, std::size_t i) { return o.frame_origin + glm::dvec3(o.P[i]); };
    for (std::size_t j = 0; j < oracle_b.pixel_count(); ++j) {
        if (!surface(oracle_b, raster_b, j)) continue;
        const glm::dvec3 w = world(oracle_b, j);
        const std::optional<Projected> p = project(camera_a, W, H, w);
        if (!p || !(p->px >= 0 && p->px < W && p->py >= 0 && p->py < H)) continue;
        // Seen in both: a's nearest pixel sees this surface (not an occluder, not what it hid).
        const double reach = 2.0 * p->footprint_m + 1e-6 * glm::length(w - camera_a.eye);
        auto same_surface = [&](std::size_t i, double within) {
            return surface(oracle_a, raster_a, i) && glm::length(world(oracle_a, i) - w) <= within;
        };
        const auto nx = static_cast<int>(p->px), ny = static_cast<int>(p->py);
        const std::size_t nearest = static_cast<std::size_t>(ny) * W + nx;
        if (!same_surface(nearest, reach)) continue;
        ++out.points;
        // The pixels of a around the point: the four centres that enclose it.
        const int x0 = static_cast<int>(std::floor(p->px - 0.5)), y0 = static_cast<int>(std::floor(p->py - 0.5));
        for (std::size_t li = 0; li < lights; ++li) {
            const OracleLightImage &ta = oracle_a.lights[li], &tb = oracle_b.lights[li];
            if (ta.U[nearest] != 0 || tb.U[j] != 0) continue;  // the truth itself is a coin toss there
            if (std::abs(ta.V[nearest] - tb.V[j]) > tol) continue;
            const float vb = raster_b.lights[li].V[j];
            bool moved = true;
            for (int dy = 0; dy < 2 && moved; ++dy)
                for (int dx = 0; dx < 2 && moved; ++dx) {
                    const int x = x0 + dx, y = y0 + dy;
                    if (x < 0 || y < 0 || x >= W || y >= H) continue;
                    const std::size_t i = static_cast<std::size_t>(y) * W + x;
                    if (!same_surface(i, 2.0 * reach)) continue;
                    if (std::abs(raster_a.lights[li].V[i] - vb) <= tol) moved = false;
                }
            if (!moved) continue;
            ++out.flicker[li];
            out.map[li][j] = 1;
        }
    }
    return out;
}

CameraPathResult validate_camera_path(const Scenario& scenario, const raster::Technique& technique,
                                      const metrics::Gate& gate, const ValidateOptions& options) {
    const CameraPath& path = scenario.camera_path.value();
    CameraPathResult out;
    out.frames = path.frames;
    std::vector<Camera> cameras;
    for (int f = 0; f < path.frames; ++f) cameras.push_back(path_camera(path, f).value());  // checked by the loader

    // One copy of the scenario whose camera is each frame's in turn: the raster session and the
    // per-frame verdicts read the camera from it (the scene is copied once, not per frame).
    Scenario frame = scenario;
    frame.camera = cameras[0];
    auto t0 = SteadyClock::now();
    raster::ContextOptions co;
    co.device = options.device;
    raster::VulkanContext ctx(co);
    const double device_s = seconds_since(t0);
    raster::RasterSession session(frame, ctx);
    OracleSettings oracle_settings = options.oracle;
    if (options.progress) oracle_settings.progress = false;  // the frames are counted instead
    OracleSession oracle(frame, oracle_settings);
    out.bvh_builds = oracle.bvh_builds();

    const std::size_t lights = scenario.lights.size();
    std::vector<std::uint64_t> flicker(lights, 0);
    std::uint64_t points = 0;
    out.flicker_map.assign(
        lights, std::vector<std::uint32_t>(
                    static_cast<std::size_t>(scenario.width) * static_cast<std::size_t>(scenario.height), 0));
    std::vector<nlohmann::json> per_frame(lights, nlohmann::json::array());
    nlohmann::json trace_s = nlohmann::json::array();
    double oracle_s = oracle.build_s(), raster_s = 0, metrics_s = 0, flicker_s = 0;
    std::vector<std::string> warnings;
    metrics::GateResult worst;  // each check's worst frame (the temporal ones come at the end)
    ValidateResult previous;
    std::shared_ptr<OracleRun> last_run;  // the last frame's, whose oracle.json tells the whole path
    for (int f = 0; f < path.frames; ++f) {
        frame.camera = cameras[static_cast<std::size_t>(f)];
        if (f > 0) session.set_camera(frame.camera);
        auto t1 = SteadyClock::now();
        auto run = std::make_shared<OracleRun>();
        OracleResult traced = oracle.trace(frame.camera);
        run->info = oracle_json(frame, traced, {});
        run->frame = std::move(traced.frame);
        run->seconds = seconds_since(t1);
        oracle_s += run->seconds;
        trace_s.push_back(run->seconds);
        last_run = run;
        // The frames, counted, on a terminal: a frame's own phases would flicker past.
        if (options.progress)
            options.progress->step(static_cast<std::size_t>(f), static_cast<std::size_t>(path.frames), "frames judged");
        ValidateOptions quiet_frame = options;
        quiet_frame.progress = nullptr;
        ValidateResult r = validate(frame, technique, gate, quiet_frame, &session, std::move(run));
        if (r.gate) metrics::fold_worst_frame(worst, *r.gate, f);
        raster_s += r.raster_s;
        metrics_s += r.metrics_s;
        for (const std::string& w : r.warnings)
            if (std::find(warnings.begin(), warnings.end(), w) == warnings.end()) warnings.push_back(w);

        std::optional<PairFlicker> pair;
        if (f > 0) {
            auto t2 = SteadyClock::now();
            pair = flicker_between(previous.oracle->frame, previous.raster.frame, cameras[f - 1], r.oracle->frame,
                                   r.raster.frame, options.tolerance);
            points += pair->points;
            for (std::size_t li = 0; li < lights; ++li) {
                flicker[li] += pair->flicker[li];
                for (std::size_t i = 0; i < pair->map[li].size(); ++i) out.flicker_map[li][i] += pair->map[li][i];
            }
            flicker_s += seconds_since(t2);
        }
        for (std::size_t li = 0; li < lights && li < r.report["lights"].size(); ++li) {
            const nlohmann::json& l = r.report["lights"][li];
            nlohmann::json entry = {{"frame", f}, {"counts", l["counts"]}, {"rates", l["rates"]}};
            if (pair) {
                entry["flicker_pixels"] = pair->flicker[li];
                entry["points"] = pair->points;
            }
            per_frame[li].push_back(std::move(entry));
        }
        previous = std::move(r);
    }

    out.last = std::move(previous);
    ValidateResult& r = out.last;
    r.warnings = warnings;
    r.raster_timings.device_s = device_s;
    // The verdict is the last frame's with the path's temporal numbers; the gate judges every
    // frame (each check's worst) and the temporal checks once over the path.
    for (std::size_t li = 0; li < lights && li < r.score.lights.size(); ++li)
        r.score.lights[li].temporal = metrics::TemporalScore{
            points, flicker[li], points ? static_cast<double>(flicker[li]) / static_cast<double>(points) : 0.0};
    if (!gate.checks.empty()) r.gate = metrics::camera_path_gate(metrics::evaluate_gate(gate, r.score.lights), worst);
    make_report(frame, r);
    // The report is told apart from other runs by the whole path.
    r.report["fingerprint"] = scenario_fingerprint(scenario);
    for (std::size_t li = 0; li < lights && li < r.report["lights"].size(); ++li) {
        nlohmann::json& t = r.report["lights"][li]["temporal"];  // points, flicker_* from the metrics table
        t["frames"] = path.frames;
        t["pairs"] = path.frames - 1;
        t["per_frame"] = per_frame[li];
    }
    r.report["timing"]["camera_path"] = {{"frames", path.frames},  {"oracle_s", oracle_s},   {"raster_s", raster_s},
                                         {"metrics_s", metrics_s}, {"flicker_s", flicker_s}, {"device_s", device_s}};
    // oracle.json is the last frame's, with what the whole path cost: r.oracle is that run, edited
    // in place (its frame is not copied).
    if (last_run) {
        last_run->info["frames"] = path.frames;
        last_run->info["bvh_builds"] = out.bvh_builds;
        last_run->info["seconds"]["build"] = oracle.build_s();
        last_run->info["camera_path"] = {{"frames", path.frames},
                                         {"bvh_builds", out.bvh_builds},
                                         {"build_s", oracle.build_s()},
                                         {"frame_s", trace_s}};
        last_run->seconds = oracle_s;
    }
    return out;
}

}  // namespace penumbra
