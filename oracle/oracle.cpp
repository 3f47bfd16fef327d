#include "oracle/oracle.h"

#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_group.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <exception>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

#include "common/stopwatch.h"
#include "oracle/tracer.h"

namespace penumbra {

namespace {

constexpr int kTile = 16;  // pixels per tile side: the unit of parallel work

}  // namespace

namespace oracle_detail {

void allocate_frame(OracleFrame& frame, const Scenario& scenario) {
    frame.width = scenario.width;
    frame.height = scenario.height;
    const std::size_t n = frame.pixel_count();
    frame.lights.resize(scenario.lights.size());
    // Filling a fresh channel is mostly the kernel's first-touch page faults and zeroing
    // (0.14 s for the 240 MB of a 2048^2 frame); channels are separate mappings, so the
    // threads fault them in side by side.
    std::vector<std::function<void()>> fills = {
        [&] { frame.A.assign(n, 0.0f); }, [&] { frame.prim.assign(n, kNoPrimitive); },
        [&] { frame.depth.assign(n, 0.0f); }, [&] { frame.P.assign(n, glm::vec3(0.0f)); },
        [&] { frame.N.assign(n, glm::vec3(0.0f)); }};
    for (auto& img : frame.lights) {
        fills.push_back([&img, n] { img.V.assign(n, 0.0f); });
        fills.push_back([&img, n] { img.E.assign(n, 0.0f); });  // punctual lights are exact
        fills.push_back([&img, n] { img.U.assign(n, 0.0f); });
        fills.push_back([&img, n] { img.lightable.assign(n, 0.0f); });
        fills.push_back([&img, n] { img.occluder_m.assign(n, kNoDistance); });
        fills.push_back([&img, n] { img.boundary_m.assign(n, kNoDistance); });
    }
    tbb::parallel_for(std::size_t(0), fills.size(), [&](std::size_t i) { fills[i](); });
}

}  // namespace oracle_detail

OracleResult run_oracle(const Scenario& scenario, const OracleSettings& settings, const OracleTraceDone& trace_done) {
    using namespace oracle_detail;
    const int threads =
        settings.threads > 0 ? settings.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));

    OracleResult result;
    result.settings = settings;
    OracleStats& stats = result.stats;
    stats.threads = threads;

    // The frame is allocated while the BVH is built: its 240 MB (at 2048^2) are mostly the
    // kernel's first-touch faults, which a thread the build leaves idle can take (with one
    // thread, the task runs at wait(), after the build). frame_s is the wait that is left.
    OracleFrame& frame = result.frame;
    tbb::task_group frame_task;
    frame_task.run([&] { allocate_frame(frame, scenario); });
    auto t0 = SteadyClock::now();
    auto owned = std::make_unique<Tracer>(scenario, settings.embree_isa);
    Tracer& tracer = *owned;
    stats.embree_version = tracer.device().version();
    tracer.build();
    stats.build_s = seconds_since(t0);

    t0 = SteadyClock::now();
    frame_task.wait();
    stats.frame_s = seconds_since(t0);
    // The hook's work reads the frame's arrays: should anything below throw, it must end before
    // `result` (declared before this guard, so destroyed after it) frees them.
    std::shared_future<void> hook_work;
    struct WaitOnThrow {
        std::shared_future<void>& work;
        int exceptions = std::uncaught_exceptions();
        ~WaitOnThrow() {
            if (std::uncaught_exceptions() > exceptions && work.valid()) work.wait();
        }
    } wait_on_throw{hook_work};
    OracleTraceDone keep_work;
    if (trace_done)
        keep_work = [&](const OracleFrame& f) {
            hook_work = trace_done(f);
            return hook_work;
        };
    trace_frame(tracer, settings, result, keep_work);
    result.tracer_released = std::async(std::launch::async, [t = std::move(owned)]() mutable { t.reset(); }).share();
    return result;
}

namespace oracle_detail {

void trace_frame(const Tracer& tracer, const OracleSettings& settings, OracleResult& result,
                 const OracleTraceDone& trace_done) {
    OracleFrame& frame = result.frame;
    OracleStats& stats = result.stats;
    frame.frame_origin = tracer.frame_origin();
    auto t0 = SteadyClock::now();

    // ---- primary and shadow rays, tile by tile; each pixel's answer is independent of the
    // tiling and of the thread that computes it, so the output is deterministic ----
    const int tiles_x = (frame.width + kTile - 1) / kTile, tiles_y = (frame.height + kTile - 1) / kTile;
    const int tile_count = tiles_x * tiles_y;
    std::atomic<std::uint64_t> primary{0}, shadow{0}, retraced{0}, culled{0};
    std::atomic<int> tiles_done{0};
    const auto& lights = tracer.lights();
    const bool any_area = std::any_of(lights.begin(), lights.end(), [](const LocalLight& l) { return l.sampled; });
    std::vector<SurfacePoint> surfaces(any_area ? frame.pixel_count() : 0);  // kept for area sampling only
    const bool progress = settings.progress && ::isatty(STDERR_FILENO);
    std::mutex progress_mutex, culled_mutex;
    std::map<std::uint32_t, std::uint64_t> culled_by_node;
    int last_percent = -1;
    tbb::parallel_for(tbb::blocked_range<int>(0, tile_count, 4), [&](const tbb::blocked_range<int>& r) {
        TraceCounters c;
        tracer.trace_tiles(frame, r.begin(), r.end(), tiles_x, kTile, c, any_area ? &surfaces : nullptr);
        primary += c.primary;
        shadow += c.shadow;
        retraced += c.retraced;
        culled += c.culled;
        if (!c.culled_by_node.empty()) {
            std::lock_guard lock(culled_mutex);
            for (const auto& [node, n] : c.culled_by_node) culled_by_node[node] += n;
        }
        int done = tiles_done += static_cast<int>(r.size());
        if (progress) {
            int pct = static_cast<int>(100.0 * done / tile_count);
            std::lock_guard lock(progress_mutex);
            if (pct != last_percent) {
                last_percent = pct;
                std::fprintf(stderr, "\rpenumbra oracle: tracing %3d%%", pct);
            }
        }
    });
    if (progress) std::fprintf(stderr, "\r\033[K");
    tracer.device().check("tracing");
    stats.trace_s = seconds_since(t0);
    stats.primary_rays = primary;
    stats.shadow_rays = shadow;
    stats.verified_retraces = retraced;
    stats.culled_retraces = culled;
    stats.culled_by_node.assign(culled_by_node.begin(), culled_by_node.end());

    // ---- area lights: adaptive sampling, one light after the other (each is parallel inside) ----
    t0 = SteadyClock::now();
    stats.lights.resize(lights.size());
    for (std::size_t li = 0; li < lights.size(); ++li) {
        if (!lights[li].sampled) continue;
        TraceCounters c;
        stats.lights[li].area = true;
        stats.lights[li].sampling = sample_area_light(tracer, frame, li, surfaces, settings, c);
        stats.shadow_rays += c.shadow;
        stats.verified_retraces += c.retraced;
    }
    tracer.device().check("area-light sampling");
    stats.area_s = seconds_since(t0);

    // Every channel is final now but U and boundary_m, which only the boundary phase below
    // writes (locate_shadow_boundaries' `finish`); the pixel counts after it only read.
    if (trace_done) trace_done(frame);

    // ---- shadow boundaries of punctual lights (and the ambiguity they imply), one light per
    // task; a sampled light's (an area light's, a sun's with a size) visibility is continuous,
    // it has no such boundary ----
    t0 = SteadyClock::now();
    std::atomic<std::uint64_t> boundary_rays{0};
    std::vector<OracleBoundaryTimes> boundary_parts(lights.size());
    tbb::parallel_for(std::size_t(0), lights.size(), [&](std::size_t li) {
        if (lights[li].sampled) return;
        boundary_rays +=
            locate_shadow_boundaries(tracer, frame, li, settings.boundary_bisection_steps, boundary_parts[li]);
    });
    for (const OracleBoundaryTimes& t : boundary_parts) {
        OracleBoundaryTimes& sum = stats.boundary_parts;
        sum.locate_s += t.locate_s;
        sum.merge_s += t.merge_s;
        sum.grid_s += t.grid_s;
        sum.sweeps_s += t.sweeps_s;
        sum.lists_s += t.lists_s;
        sum.pixels_s += t.pixels_s;
    }
    tracer.device().check("boundary search");
    stats.boundary_rays = boundary_rays;
    stats.boundary_s = seconds_since(t0);

    // The pixel counts, in parallel (sums of integers: the same in any order; 0.01 s serially).
    for (std::size_t li = 0; li < frame.lights.size(); ++li) {
        const OracleLightImage& img = frame.lights[li];
        OracleLightStats& ls = stats.lights[li];
        struct Counts {
            std::uint64_t surface = 0, lightable = 0, shadowed = 0, uncertain = 0;
        };
        const Counts counts = tbb::parallel_reduce(
            tbb::blocked_range<std::size_t>(0, frame.pixel_count(), std::size_t(1) << 14), Counts{},
            [&](const tbb::blocked_range<std::size_t>& r, Counts c) {
                for (std::size_t i = r.begin(); i != r.end(); ++i) {
                    if (frame.A[i] == 0) continue;
                    ++c.surface;
                    if (img.lightable[i] == 0) continue;
                    ++c.lightable;
                    c.shadowed += img.V[i] == 0;
                    c.uncertain += img.U[i] != 0;
                }
                return c;
            },
            [](Counts a, const Counts& b) {
                a.surface += b.surface;
                a.lightable += b.lightable;
                a.shadowed += b.shadowed;
                a.uncertain += b.uncertain;
                return a;
            });
        ls.surface = counts.surface;
        ls.lightable = counts.lightable;
        ls.shadowed = counts.shadowed;
        ls.uncertain = counts.uncertain;
    }
}

}  // namespace oracle_detail

struct OracleSession::Impl {
    Impl(const Scenario& scenario, const OracleSettings& s)
        : settings(s),
          threads(s.threads > 0 ? s.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()))),
          limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads)),
          tracer(scenario, s.embree_isa) {}
    OracleSettings settings;
    int threads;
    tbb::global_control limit;  // held for the session: every trace runs under it
    oracle_detail::Tracer tracer;
    int builds = 0;
    double build_s = 0;
};

OracleSession::OracleSession(const Scenario& scenario, const OracleSettings& settings)
    : impl_(std::make_unique<Impl>(scenario, settings)) {
    auto t0 = SteadyClock::now();
    impl_->tracer.build();
    impl_->build_s = seconds_since(t0);
    ++impl_->builds;
}

OracleSession::~OracleSession() = default;

int OracleSession::bvh_builds() const {
    return impl_->builds;
}

double OracleSession::build_s() const {
    return impl_->build_s;
}

OracleResult OracleSession::trace(const Camera& camera) {
    using namespace oracle_detail;
    OracleResult result;
    result.settings = impl_->settings;
    result.stats.threads = impl_->threads;
    result.stats.embree_version = impl_->tracer.device().version();
    auto t0 = SteadyClock::now();
    allocate_frame(result.frame, impl_->tracer.scenario());
    result.stats.frame_s = seconds_since(t0);
    impl_->tracer.set_camera(camera);
    trace_frame(impl_->tracer, impl_->settings, result);
    return result;
}

}  // namespace penumbra
