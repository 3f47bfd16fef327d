// Distance from each receiver point to the nearest true shadow boundary, measured across the
// light direction (the metric of a shadow-map texel footprint), independent of any shadow-map
// resolution.
//
// 1. Every pair of 4-adjacent pixels on one plane whose verdicts differ brackets a boundary;
//    bisecting the segment between their surface points with exact shadow rays places it to
//    2^-steps of a pixel footprint.
// 2. The located boundary points are propagated over the image in two raster sweeps (a
//    vector distance transform, Danielsson 1980), each pixel keeping the point nearest to it
//    in the light-lateral metric.
// Boundaries that no pixel pair straddles (hidden from the camera, or lying exactly on a
// silhouette) are not seen; pixels farther from every seen boundary report inf.
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <glm/geometric.hpp>
#include <limits>
#include <thread>
#include <vector>

#include "oracle/tracer.h"

namespace penumbra::oracle_detail {

namespace {

// Squared distance from p to b in the plane perpendicular to the light direction at p.
double lateral_distance2(const glm::dvec3& p, const glm::dvec3& to_light, const glm::dvec3& b) {
    glm::dvec3 d = b - p;
    double along = glm::dot(d, to_light);
    return std::max(0.0, glm::dot(d, d) - along * along);
}

bool same_plane(const Tracer& tr, std::uint32_t a, std::uint32_t b) {
    if (a == b) return true;
    glm::dvec3 na = glm::normalize(tr.normal_ccw(a)), nb = glm::normalize(tr.normal_ccw(b));
    if (std::abs(glm::dot(na, nb)) < 1.0 - 1e-12) return false;
    double scale = glm::length(tr.vertex(a, 0)) + glm::length(tr.vertex(b, 0));
    return std::abs(glm::dot(na, tr.vertex(b, 0) - tr.vertex(a, 0))) <= 1e-12 * std::max(scale, 1e-300);
}

// The threads the boundary sweeps may use: the run's thread limit (tbb::global_control).
int sweep_threads() {
    return static_cast<int>(
        std::max<std::size_t>(1, tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)));
}

// Calls visit(x, y) once for every pixel, row after row, each row from x = 0 up, where visit
// reads only pixels (x' < x, y) and (x' <= x + 1, y - 1) besides (x, y). Rows go round-robin to
// `threads` threads as a wavefront: a chunk of a row starts once the row above has finished one
// pixel past it, so every pixel sees the final values a serial sweep would give it.
template <typename Visit>
void wavefront_sweep(int W, int H, int threads, Visit&& visit) {
    constexpr int kChunk = 64;  // pixels a row finishes between two looks at the row above
    threads = std::clamp(threads, 1, std::max(1, H));
    if (threads == 1) {
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) visit(x, y);
        return;
    }
    std::vector<std::atomic<int>> done(static_cast<std::size_t>(H));  // pixels finished in each row
    for (auto& d : done) d.store(0, std::memory_order_relaxed);
    auto run = [&](int first_row) {
        for (int y = first_row; y < H; y += threads)
            for (int x0 = 0; x0 < W; x0 += kChunk) {
                const int x1 = std::min(W, x0 + kChunk);
                if (y > 0) {
                    const std::atomic<int>& above = done[static_cast<std::size_t>(y - 1)];
                    // The row above is at most a few chunks behind: yield, do not sleep.
                    while (above.load(std::memory_order_acquire) < std::min(W, x1 + 1)) std::this_thread::yield();
                }
                for (int x = x0; x < x1; ++x) visit(x, y);
                done[static_cast<std::size_t>(y)].store(x1, std::memory_order_release);
            }
    };
    std::vector<std::thread> helpers;
    for (int t = 1; t < threads; ++t) helpers.emplace_back(run, t);
    run(0);
    for (std::thread& h : helpers) h.join();
}

}  // namespace

std::uint64_t locate_shadow_boundaries(const Tracer& tr, OracleFrame& frame, std::size_t li, int steps) {
    const int W = frame.width, H = frame.height;
    OracleLightImage& img = frame.lights[li];
    const LocalLight& light = tr.lights()[li];
    std::uint64_t rays = 0;

    // ---- 1. boundary points between straddling pixel pairs ----
    // Rows are searched in parallel (the bisection rays are most of this phase's time); the
    // points are then taken in row-major order, as a serial loop would, so the output does not
    // depend on the thread count.
    struct Straddle {
        int i, j;
        glm::dvec3 seed;
    };
    std::vector<std::vector<Straddle>> rows(static_cast<std::size_t>(H));
    std::atomic<std::uint64_t> ray_count{0};
    tbb::parallel_for(tbb::blocked_range<int>(0, H, 8), [&](const tbb::blocked_range<int>& range) {
        std::uint64_t local_rays = 0;
        for (int y = range.begin(); y != range.end(); ++y) {
            std::vector<Straddle>& row = rows[static_cast<std::size_t>(y)];
            for (int x = 0; x < W; ++x) {
                const int i = y * W + x;
                if (img.lightable[i] == 0) continue;
                for (int dir = 0; dir < 2; ++dir) {
                    int xj = x + (dir == 0), yj = y + (dir == 1);
                    if (xj >= W || yj >= H) continue;
                    const int j = yj * W + xj;
                    if (img.lightable[j] == 0 || img.V[i] == img.V[j]) continue;
                    std::uint32_t pi = frame.prim[i], pj = frame.prim[j];
                    glm::dvec3 a(frame.P[i]), b(frame.P[j]);
                    glm::dvec3 seed;
                    if (same_plane(tr, pi, pj)) {
                        // Bisect on the exact plane of the triangle: points projected onto it in double.
                        glm::dvec3 n = glm::normalize(tr.normal_ccw(pi));
                        const glm::dvec3& v0 = tr.vertex(pi, 0);
                        auto on_plane = [&](const glm::dvec3& q) { return q - glm::dot(q - v0, n) * n; };
                        glm::dvec3 n_lit = glm::dot(n, direction_to_light(light, a)) > 0 ? n : -n;
                        glm::dvec3 vabs = glm::max(glm::abs(tr.vertex(pi, 0)),
                                                   glm::max(glm::abs(tr.vertex(pi, 1)), glm::abs(tr.vertex(pi, 2))));
                        float va = img.V[i];
                        a = on_plane(a);
                        b = on_plane(b);
                        for (int s = 0; s < steps; ++s) {
                            SurfacePoint m;
                            m.hit = true;
                            m.p = on_plane(0.5 * (a + b));
                            m.n = n_lit;
                            m.error = robust::surface_error_bound(m.p, vabs);
                            ShadowSetup setup;
                            setup_shadow(light, m, setup);
                            float vm = 0.0f;
                            if (setup.lightable) {
                                vm = tr.trace_shadow_verified(setup, m.p, kNoPrimitive).blocked ? 0.0f : 1.0f;
                                ++local_rays;
                            }
                            (vm == va ? a : b) = m.p;
                        }
                        seed = 0.5 * (a + b);
                    } else {
                        // A crease or a silhouette: accept the midpoint only where the surface is
                        // continuous (similar normals, no depth jump).
                        glm::dvec3 ni(frame.N[i]), nj(frame.N[j]);
                        double gap = glm::length(b - a);
                        if (glm::dot(ni, nj) < 0.9 || std::abs(glm::dot(ni, b - a)) > 0.1 * gap) continue;
                        seed = 0.5 * (a + b);
                    }
                    row.push_back({i, j, seed});
                }
            }
        }
        ray_count += local_rays;
    });
    rays = ray_count;
    std::vector<glm::dvec3> seeds;
    std::vector<int> nearest(frame.pixel_count(), -1);
    std::vector<double> best(frame.pixel_count(), std::numeric_limits<double>::infinity());
    auto consider = [&](int i, int s) {
        glm::dvec3 p(frame.P[i]);
        double d2 = lateral_distance2(p, direction_to_light(light, p), seeds[s]);
        if (d2 < best[i]) {
            best[i] = d2;
            nearest[i] = s;
        }
    };
    for (const auto& row : rows)
        for (const Straddle& st : row) {
            seeds.push_back(st.seed);
            consider(st.i, static_cast<int>(seeds.size() - 1));
            consider(st.j, static_cast<int>(seeds.size() - 1));
        }
    rows = {};

    // ---- 2. propagate the nearest boundary point across the surface pixels ----
    // Pixel (x, y) takes the nearest of its neighbours' points: in the forward sweep those to
    // its left and in the row above, in the backward sweep the mirror image. Its own point and
    // light direction are computed once, at its first candidate. The sweeps run as wavefronts
    // over the run's threads, with the serial sweeps' result.
    auto sweep = [&](int x, int y, const int(*offsets)[2]) {
        const int i = y * W + x;
        if (frame.A[i] == 0) return;
        int cur = nearest[i];
        double cur_d2 = best[i];
        glm::dvec3 p, to_light;
        bool have_p = false;
        for (int k = 0; k < 4; ++k) {
            const int xn = x + offsets[k][0], yn = y + offsets[k][1];
            if (xn < 0 || yn < 0 || xn >= W || yn >= H) continue;
            const int s = nearest[yn * W + xn];
            if (s < 0 || s == cur) continue;
            if (!have_p) {
                p = glm::dvec3(frame.P[i]);
                to_light = direction_to_light(light, p);
                have_p = true;
            }
            const double d2 = lateral_distance2(p, to_light, seeds[s]);
            if (d2 < cur_d2) {
                cur_d2 = d2;
                cur = s;
            }
        }
        nearest[i] = cur;
        best[i] = cur_d2;
    };
    static const int kForward[4][2] = {{-1, 0}, {-1, -1}, {0, -1}, {1, -1}};
    static const int kBackward[4][2] = {{1, 0}, {1, 1}, {0, 1}, {-1, 1}};
    if (!seeds.empty()) {
        const int threads = sweep_threads();
        wavefront_sweep(W, H, threads, [&](int x, int y) { sweep(x, y, kForward); });
        // The backward sweep is the forward one on the image turned by 180 degrees.
        wavefront_sweep(W, H, threads, [&](int x, int y) { sweep(W - 1 - x, H - 1 - y, kBackward); });
    }

    // ---- 3. distances, and ambiguity within float error of a boundary ----
    const Camera& cam = tr.scenario().camera;
    tbb::parallel_for(std::size_t(0), frame.pixel_count(), [&](std::size_t i) {
        if (img.lightable[i] == 0 || nearest[i] < 0) return;
        double dist = std::sqrt(best[i]);
        img.boundary_m[i] = static_cast<float>(dist);
        // The receiver point carries a float error of ~eps |P|, stretched along the surface by
        // 1 / cos(view angle); the boundary, ~eps |B|. Closer than that, the verdict is a coin
        // toss for any float implementation, so it is flagged rather than guessed.
        glm::dvec3 p(frame.P[i]), n(frame.N[i]);
        glm::dvec3 view = cam.type == ProjectionType::perspective ? glm::normalize(p) : cam.forward;
        double cos_view = std::max(std::abs(glm::dot(n, view)), 1.0 / 64);
        double ambiguity = 64 * robust::kFloatEps * (glm::length(p) + glm::length(seeds[nearest[i]])) / cos_view;
        if (dist <= ambiguity) img.U[i] = 1.0f;
    });
    return rays;
}

}  // namespace penumbra::oracle_detail
