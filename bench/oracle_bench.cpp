// Oracle trace speed against a bare Embree loop on the same scene, same rays, same run.
//
// Scene: a 2.36M-triangle terrain (1086 x 1086 quads) under a low sun, seen at 2048 x 2048.
// The bare loop traces the same primary rays (rtcIntersect16) and one shadow ray per pixel
// that faces the light, from o + t d plus a fixed 1e-3 epsilon along the normal: what a
// quick Embree renderer does. It runs twice: with closest-hit shadow rays (rtcIntersect16, what
// the oracle needs for occluder distances) and with any-hit ones (rtcOccluded16).
// Prints Mrays/s for each and the oracle's ratio; best of --repeat runs. --bare 0 runs the
// oracle alone (for profilers and scaling checks).
#include <embree3/rtcore.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <glm/geometric.hpp>
#include <string>

#include "common/camera.h"
#include "common/stopwatch.h"
#include "oracle/oracle.h"

namespace {

using namespace penumbra;

Scenario terrain_scenario(int grid, int size) {
    Scenario s;
    s.label = "bench";
    s.width = s.height = size;
    const double extent = 100.0;
    auto height = [](double x, double z) {
        return 0.8 * std::sin(0.35 * x) * std::cos(0.27 * z) + 0.25 * std::sin(1.7 * x + 0.5) * std::sin(1.3 * z) +
               3.0 * std::exp(-((x - 5) * (x - 5) + (z + 5) * (z + 5)) / 40.0);
    };
    Scene& sc = s.scene;
    for (int j = 0; j <= grid; ++j)
        for (int i = 0; i <= grid; ++i) {
            double x = extent * (double(i) / grid - 0.5), z = extent * (0.5 - double(j) / grid);
            sc.positions.emplace_back(x, height(x, z), z);
        }
    for (int j = 0; j < grid; ++j)
        for (int i = 0; i < grid; ++i) {
            std::uint32_t a = j * (grid + 1) + i, b = a + 1, c = a + grid + 2, d = a + grid + 1;
            sc.triangles.push_back({a, b, c});
            sc.triangles.push_back({a, c, d});
        }
    sc.double_sided.assign(sc.triangles.size(), 0);
    sc.triangle_node.assign(sc.triangles.size(), 0);
    look_at_basis({0, 22, 55}, {0, 0, 0}, {0, 1, 0}, s.camera);
    s.camera.yfov_rad = 50 * M_PI / 180;
    s.camera.znear = 0.1;
    Light sun;
    sun.type = LightType::directional;
    sun.direction = glm::normalize(glm::dvec3(0.6, -0.35, -0.3));
    sun.origin = "sun";
    s.lights = {sun};
    return s;
}

// One lane of a 16-wide ray packet, reset for a new query.
void set_lane(RTCRayHit16& rh, int k, const glm::vec3& o, const glm::vec3& d, float tnear) {
    rh.ray.org_x[k] = o.x;
    rh.ray.org_y[k] = o.y;
    rh.ray.org_z[k] = o.z;
    rh.ray.dir_x[k] = d.x;
    rh.ray.dir_y[k] = d.y;
    rh.ray.dir_z[k] = d.z;
    rh.ray.tnear[k] = tnear;
    rh.ray.tfar[k] = 3e38f;
    rh.ray.time[k] = 0;
    rh.ray.mask[k] = ~0u;
    rh.ray.id[k] = static_cast<unsigned>(k);
    rh.ray.flags[k] = 0;
    rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
}

struct BareResult {
    double seconds;
    std::uint64_t rays;
};

BareResult bare_loop(const Scenario& s, bool closest_hit) {
    RTCDevice device = rtcNewDevice("verbose=0");
    RTCScene scene = rtcNewScene(device);
    rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* vb = static_cast<float*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 12, s.scene.positions.size()));
    auto* ib = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, s.scene.triangles.size()));
    for (std::size_t i = 0; i < s.scene.positions.size(); ++i)
        for (int c = 0; c < 3; ++c) vb[3 * i + c] = static_cast<float>(s.scene.positions[i][c] - s.camera.eye[c]);
    for (std::size_t i = 0; i < s.scene.triangles.size(); ++i)
        for (int c = 0; c < 3; ++c) ib[3 * i + c] = s.scene.triangles[i][c];
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(scene);

    const int W = s.width, H = s.height, tile = 16;
    const int tiles_x = W / tile, tiles_y = H / tile;
    const glm::vec3 L = glm::vec3(-s.lights[0].direction);
    std::atomic<std::uint64_t> rays{0};
    auto t0 = SteadyClock::now();
    tbb::parallel_for(tbb::blocked_range<int>(0, tiles_x * tiles_y, 4), [&](const tbb::blocked_range<int>& r) {
        std::uint64_t local = 0;
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
        const PrimaryRays camera_rays(s.camera, W, H);
        for (int t = r.begin(); t != r.end(); ++t) {
            int x0 = (t % tiles_x) * tile, y0 = (t / tiles_x) * tile;
            for (int by = y0; by < y0 + tile; by += 4)
                for (int bx = x0; bx < x0 + tile; bx += 4) {
                    alignas(64) RTCRayHit16 rh;
                    alignas(64) int valid[16];
                    for (int k = 0; k < 16; ++k) {
                        PrimaryRay pr = camera_rays.at(bx + (k & 3) + 0.5, by + (k >> 2) + 0.5);
                        valid[k] = -1;
                        set_lane(rh, k, glm::vec3(0.0f), glm::vec3(pr.direction), float(s.camera.znear));
                    }
                    rtcIntersect16(valid, scene, &ctx, &rh);
                    local += 16;
                    alignas(64) RTCRayHit16 sh;
                    alignas(64) int svalid[16];
                    for (int k = 0; k < 16; ++k) {
                        svalid[k] = 0;
                        if (rh.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) continue;
                        glm::vec3 d(rh.ray.dir_x[k], rh.ray.dir_y[k], rh.ray.dir_z[k]);
                        glm::vec3 n = glm::normalize(glm::vec3(rh.hit.Ng_x[k], rh.hit.Ng_y[k], rh.hit.Ng_z[k]));
                        if (glm::dot(n, d) > 0) n = -n;
                        if (glm::dot(n, L) <= 0) continue;
                        glm::vec3 o = rh.ray.tfar[k] * d + 1e-3f * n;  // the fixed epsilon an oracle must not use
                        svalid[k] = -1;
                        set_lane(sh, k, o, L, 0.0f);
                        ++local;
                    }
                    if (closest_hit)
                        rtcIntersect16(svalid, scene, &ctx, &sh);
                    else
                        rtcOccluded16(svalid, scene, &ctx, &sh.ray);
                }
        }
        rays += local;
    });
    double seconds = seconds_since(t0);
    rtcReleaseScene(scene);
    rtcReleaseDevice(device);
    return {seconds, rays};
}

}  // namespace

int main(int argc, char** argv) {
    int size = 2048, grid = 1086, repeat = 3, threads = 0, bare = 1;
    for (int i = 1; i + 1 < argc; i += 2) {
        std::string a = argv[i];
        int v = std::atoi(argv[i + 1]);
        if (a == "--size")
            size = v;
        else if (a == "--grid")
            grid = v;
        else if (a == "--repeat")
            repeat = std::max(1, v);
        else if (a == "--threads")
            threads = v;
        else if (a == "--bare")
            bare = v;
    }
    Scenario s = terrain_scenario(grid, size);
    OracleSettings settings;
    settings.threads = threads;
    std::printf("scene: %zu triangles, %dx%d pixels, 1 directional light, %d threads\n", s.scene.triangle_count(), size,
                size, threads > 0 ? threads : int(std::thread::hardware_concurrency()));
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                              threads > 0 ? threads : std::thread::hardware_concurrency());
    double best_oracle = 1e30, best_closest = 1e30, best_any = 1e30, boundary = 0;
    std::uint64_t oracle_rays = 0, bare_rays = 0, retraced = 0, boundary_rays = 0;
    for (int r = 0; r < repeat; ++r) {
        OracleResult o = run_oracle(s, settings);
        oracle_rays = o.stats.primary_rays + o.stats.shadow_rays + o.stats.verified_retraces;
        retraced = o.stats.verified_retraces;
        boundary_rays = o.stats.boundary_rays;
        if (o.stats.trace_s < best_oracle) {
            best_oracle = o.stats.trace_s;
            boundary = o.stats.boundary_s;
        }
        if (!bare) continue;
        BareResult c = bare_loop(s, true), a = bare_loop(s, false);
        bare_rays = c.rays;
        best_closest = std::min(best_closest, c.seconds);
        best_any = std::min(best_any, a.seconds);
    }
    double m_oracle = oracle_rays / best_oracle * 1e-6, m_closest = bare_rays / best_closest * 1e-6,
           m_any = bare_rays / best_any * 1e-6;
    std::printf("oracle trace:            %7.3f s  %8.2f Mrays/s  (%llu rays, %llu re-traced in double)\n", best_oracle,
                m_oracle, (unsigned long long)oracle_rays, (unsigned long long)retraced);
    if (bare) {
        std::printf("bare loop, closest hit:  %7.3f s  %8.2f Mrays/s  ratio oracle/bare = %.3f\n", best_closest,
                    m_closest, m_oracle / m_closest);
        std::printf("bare loop, any hit:      %7.3f s  %8.2f Mrays/s  ratio oracle/bare = %.3f\n", best_any, m_any,
                    m_oracle / m_any);
    }
    std::printf("oracle boundary phase:   %7.3f s  (%llu bisection rays; not in the trace phase)\n", boundary,
                (unsigned long long)boundary_rays);
    return 0;
}
