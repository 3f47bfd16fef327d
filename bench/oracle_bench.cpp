// The whole `penumbra oracle` run against bare Embree on the same geometry, same rays, same run.
//
// Two scenes, each written as a .glb and a scenario.json into a temporary folder:
// - terrain: a 2.36M-triangle terrain (1086 x 1086 quads) under a low sun, perspective view;
// - spheres: a 32 x 32 field of UV spheres (48 x 25 segments, 2.36M triangles in all) floating
//   0.5 m above a plane, orthographic top view, one oblique directional light.
// Both at 2048 x 2048. For each scene and thread count (1 and 2):
// - the oracle: `penumbra oracle SCENARIO --out DIR --threads N -q` as a child process (the
//   real command, file writes included): wall time, peak resident memory, and the phases it
//   reports in oracle.json (load, build, frame, trace, boundary, write);
// - bare Embree: read the .glb's bytes; build (float vertices relative to the eye copied into
//   Embree's buffers, rtcCommitScene); trace the same primary rays and one closest-hit shadow
//   ray per pixel that faces the light (16-wide packets both, sent to Embree as the oracle
//   sends them: rtcIntersect16, or two rtcIntersect8 where only 8-wide kernels are native;
//   float o + t d + 1e-3 n origins: the fixed epsilon an oracle must not use), no outputs.
//   Embree's peak allocation is read through its memory monitor.
// - the trace phase interleaved in one process: the oracle's tile loop (Tracer::trace_tiles, as
//   run_oracle drives it) and the bare loop's, on the same scene and tiles, alternating in
//   chunks of a few milliseconds, so that the other load on a shared machine, which comes and
//   goes over seconds, falls on both alike (--interleave 0 skips it).
// Prints the median of --repeat runs (and the range) for every phase and the ratios the
// goals are stated in (docs/oracle.md section 9).
//
// --threads-sweep: the oracle alone at 1, 2, 4, 8, 16 threads (those up to the machine's cores,
// or the --threads list), one table of the phases per scene (issue #39), each run's oracle.exr
// compared byte for byte with the first; --baseline PATH times another binary in the same
// rounds (and compares its oracle.exr too); --embree-builds low,medium,high times bare Embree's
// build and trace at each build quality (with +compact or +dynamic: those scene flags too) at the
// largest thread count. The scenes field32 and field64 are the issue's: 32 x 32 or 64 x 64
// spheres (48 x 25 segments: 2.36M or 9.44M triangles) over a 200 m plane. --unwelded 1 writes
// every triangle with its own three vertices, as the 453 MB .glb of field64 was.
#include <embree3/rtcore.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <glm/geometric.hpp>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "common/camera.h"
#include "common/scenario.h"
#include "common/stopwatch.h"
#include "oracle/tracer.h"

namespace {

namespace fs = std::filesystem;
using namespace penumbra;
using json = nlohmann::json;

struct Mesh {
    std::vector<float> positions;  // xyz
    std::vector<std::uint32_t> indices;
    void vertex(double x, double y, double z) {
        positions.push_back(float(x));
        positions.push_back(float(y));
        positions.push_back(float(z));
    }
    std::uint32_t vertex_count() const { return static_cast<std::uint32_t>(positions.size() / 3); }
};

// The scene files and what the bare loop needs to know without parsing the scenario.
struct BenchScene {
    std::string name;
    fs::path scenario;
    Camera camera;
    glm::dvec3 light_direction;  // the direction light travels
    int size = 0;
};

Mesh terrain_mesh(int grid) {
    const double extent = 100.0;
    auto height = [](double x, double z) {
        return 0.8 * std::sin(0.35 * x) * std::cos(0.27 * z) + 0.25 * std::sin(1.7 * x + 0.5) * std::sin(1.3 * z) +
               3.0 * std::exp(-((x - 5) * (x - 5) + (z + 5) * (z + 5)) / 40.0);
    };
    Mesh m;
    for (int j = 0; j <= grid; ++j)
        for (int i = 0; i <= grid; ++i) {
            double x = extent * (double(i) / grid - 0.5), z = extent * (0.5 - double(j) / grid);
            m.vertex(x, height(x, z), z);
        }
    for (int j = 0; j < grid; ++j)
        for (int i = 0; i < grid; ++i) {
            std::uint32_t a = j * (grid + 1) + i, b = a + 1, c = a + grid + 2, d = a + grid + 1;
            m.indices.insert(m.indices.end(), {a, b, c, a, c, d});
        }
    return m;
}

// `count` x `count` UV spheres of radius 0.3 m on a 1 m grid, their lowest point 0.5 m above a
// ground plane at y = 0; counter-clockwise seen from outside, or clockwise (`inside_out`: the
// camera then sees the spheres' back faces, which the oracle culls as a rasteriser would).
// The plane reaches `plane_half` metres from the centre (0: just past the spheres).
Mesh sphere_field_mesh(int count, int segments, int rings, bool inside_out, double plane_half = 0) {
    Mesh m;
    const double r = 0.3, half = plane_half > 0 ? plane_half : count / 2.0 + 1;
    m.vertex(-half, 0, half);
    m.vertex(half, 0, half);
    m.vertex(half, 0, -half);
    m.vertex(-half, 0, -half);
    m.indices.insert(m.indices.end(), {0, 1, 2, 0, 2, 3});
    for (int sj = 0; sj < count; ++sj)
        for (int si = 0; si < count; ++si) {
            const double cx = si - count / 2.0 + 0.5, cz = sj - count / 2.0 + 0.5, cy = 0.5 + r;
            const std::uint32_t top = m.vertex_count();
            m.vertex(cx, cy + r, cz);
            for (int j = 1; j < rings; ++j) {
                double theta = M_PI * j / rings;
                for (int i = 0; i < segments; ++i) {
                    double phi = 2 * M_PI * i / segments;
                    m.vertex(cx + r * std::sin(theta) * std::cos(phi), cy + r * std::cos(theta),
                             cz - r * std::sin(theta) * std::sin(phi));
                }
            }
            const std::uint32_t bottom = m.vertex_count();
            m.vertex(cx, cy - r, cz);
            auto ring = [&](int j, int i) { return top + 1 + (j - 1) * segments + (i % segments); };
            for (int i = 0; i < segments; ++i) m.indices.insert(m.indices.end(), {top, ring(1, i), ring(1, i + 1)});
            for (int j = 1; j + 1 < rings; ++j)
                for (int i = 0; i < segments; ++i) {
                    std::uint32_t a = ring(j, i), b = ring(j + 1, i), c = ring(j + 1, i + 1), d = ring(j, i + 1);
                    m.indices.insert(m.indices.end(), {a, b, c, a, c, d});
                }
            for (int i = 0; i < segments; ++i)
                m.indices.insert(m.indices.end(), {bottom, ring(rings - 1, i + 1), ring(rings - 1, i)});
        }
    if (inside_out)
        for (std::size_t t = 6; t < m.indices.size(); t += 3) std::swap(m.indices[t + 1], m.indices[t + 2]);
    return m;
}

// Every triangle with its own three vertices, indexed 0, 1, 2, ...: how exporters that do not weld
// write a mesh (the 453 MB .glb of the 9.4M-triangle field: 340 MB of positions, 113 MB
// of indices; the welded one is 170 MB).
Mesh unwelded(const Mesh& m) {
    Mesh u;
    u.positions.resize(m.indices.size() * 3);
    u.indices.resize(m.indices.size());
    for (std::size_t k = 0; k < m.indices.size(); ++k) {
        std::copy_n(m.positions.begin() + static_cast<std::ptrdiff_t>(3 * std::size_t(m.indices[k])), 3,
                    u.positions.begin() + static_cast<std::ptrdiff_t>(3 * k));
        u.indices[k] = static_cast<std::uint32_t>(k);
    }
    return u;
}

// A one-mesh, one-primitive .glb (glTF 2.0 binary container: 12-byte header, JSON chunk, BIN chunk).
void write_glb(const fs::path& file, const Mesh& m) {
    const std::size_t pos_bytes = m.positions.size() * 4, idx_bytes = m.indices.size() * 4;
    float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
    for (std::size_t i = 0; i < m.positions.size(); ++i) {
        lo[i % 3] = std::min(lo[i % 3], m.positions[i]);
        hi[i % 3] = std::max(hi[i % 3], m.positions[i]);
    }
    json j = {
        {"asset", {{"version", "2.0"}}},
        {"scene", 0},
        {"scenes", {{{"nodes", {0}}}}},
        {"nodes", {{{"mesh", 0}}}},
        {"meshes", {{{"primitives", {{{"attributes", {{"POSITION", 0}}}, {"indices", 1}}}}}}},
        {"accessors",
         {{{"bufferView", 0},
           {"componentType", 5126},
           {"count", m.vertex_count()},
           {"type", "VEC3"},
           {"min", {lo[0], lo[1], lo[2]}},
           {"max", {hi[0], hi[1], hi[2]}}},
          {{"bufferView", 1}, {"componentType", 5125}, {"count", m.indices.size()}, {"type", "SCALAR"}}}},
        {"bufferViews",
         {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", pos_bytes}},
          {{"buffer", 0}, {"byteOffset", pos_bytes}, {"byteLength", idx_bytes}}}},
        {"buffers", {{{"byteLength", pos_bytes + idx_bytes}}}},
    };
    std::string text = j.dump();
    text.resize((text.size() + 3) / 4 * 4, ' ');
    const auto json_len = static_cast<std::uint32_t>(text.size()),
               bin_len = static_cast<std::uint32_t>(pos_bytes + idx_bytes);
    const std::uint32_t header[3] = {0x46546C67u, 2u, 12 + 8 + json_len + 8 + bin_len};
    const std::uint32_t json_head[2] = {json_len, 0x4E4F534Au}, bin_head[2] = {bin_len, 0x004E4942u};
    std::ofstream f(file, std::ios::binary);
    f.write(reinterpret_cast<const char*>(header), 12);
    f.write(reinterpret_cast<const char*>(json_head), 8);
    f.write(text.data(), json_len);
    f.write(reinterpret_cast<const char*>(bin_head), 8);
    f.write(reinterpret_cast<const char*>(m.positions.data()), static_cast<std::streamsize>(pos_bytes));
    f.write(reinterpret_cast<const char*>(m.indices.data()), static_cast<std::streamsize>(idx_bytes));
    if (!f) throw std::runtime_error("cannot write " + file.string());
}

BenchScene make_scene(const fs::path& dir, const std::string& name, int size, bool inside_out, bool unweld) {
    BenchScene s;
    s.name = name;
    s.size = size;
    fs::create_directories(dir / name);
    json cam;
    glm::dvec3 eye, target, up;
    if (name == "terrain") {
        const Mesh m = terrain_mesh(1086);
        write_glb(dir / name / "scene.glb", unweld ? unwelded(m) : m);
        eye = {0, 22, 55}, target = {0, 0, 0}, up = {0, 1, 0};
        s.light_direction = glm::normalize(glm::dvec3(0.6, -0.35, -0.3));
        s.camera.type = ProjectionType::perspective;
        s.camera.yfov_rad = 50 * M_PI / 180;
        s.camera.znear = 0.1;
        cam = {{"type", "perspective"}, {"yfov_deg", 50}, {"znear", 0.1}};
    } else if (name == "spheres" || name == "field32" || name == "field64") {
        const int count = name == "field64" ? 64 : 32;
        const Mesh m = sphere_field_mesh(count, 48, 25, inside_out, name == "spheres" ? 0.0 : 100.0);
        write_glb(dir / name / "scene.glb", unweld ? unwelded(m) : m);
        eye = {0, 20, 0}, target = {0, 0, 0}, up = {0, 0, -1};
        s.light_direction = glm::normalize(glm::dvec3(0.3, -1.0, 0.2));
        s.camera.type = ProjectionType::orthographic;
        const double mag = count / 2.0 + 0.5;
        s.camera.xmag = s.camera.ymag = mag;
        s.camera.znear = 0;
        cam = {{"type", "orthographic"}, {"xmag", mag}, {"ymag", mag}, {"znear", 0}};
    } else {
        throw std::runtime_error("unknown scene " + name + " (terrain, spheres, field32, field64)");
    }
    look_at_basis(eye, target, up, s.camera);
    cam["eye"] = {eye.x, eye.y, eye.z};
    cam["target"] = {target.x, target.y, target.z};
    cam["up"] = {up.x, up.y, up.z};
    const glm::dvec3& d = s.light_direction;
    json scenario = {{"scene", "scene.glb"},
                     {"image", {{"width", size}, {"height", size}}},
                     {"camera", cam},
                     {"lights", {{{"type", "directional"}, {"direction", {d.x, d.y, d.z}}}}}};
    s.scenario = dir / name / "scenario.json";
    std::ofstream(s.scenario) << scenario.dump(1);
    return s;
}

// ---- the oracle, as the command a user runs ----

struct OracleRun {
    double wall = 0, load = 0, build = 0, frame = 0, trace = 0, boundary = 0, write = 0;
    json boundary_parts;  // oracle.json's boundary_seconds and write_seconds (as write_exr, write_png)
    double peak_mib = 0;
    double cpu = 0;  // user + system seconds of the child: on a shared machine, steadier than its wall time
    std::uint64_t primary = 0, shadow = 0, retraced = 0;
};

OracleRun run_penumbra(const std::string& penumbra, const BenchScene& s, const fs::path& out, int threads) {
    fs::remove_all(out);
    const std::string th = std::to_string(threads);
    auto t0 = SteadyClock::now();
    pid_t pid = fork();
    if (pid == 0) {
        execl(penumbra.c_str(), penumbra.c_str(), "oracle", s.scenario.c_str(), "--out", out.c_str(), "--threads",
              th.c_str(), "-q", static_cast<char*>(nullptr));
        _exit(127);
    }
    int status = 0;
    rusage usage{};
    wait4(pid, &status, 0, &usage);
    OracleRun r;
    r.wall = seconds_since(t0);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
        throw std::runtime_error(penumbra + " oracle " + s.scenario.string() + " failed");
    r.peak_mib = usage.ru_maxrss / 1024.0;
    r.cpu = double(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
            1e-6 * double(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
    json j = json::parse(std::ifstream(out / "oracle.json"));
    const json& sec = j.at("seconds");
    r.load = sec.at("load");
    r.build = sec.at("build");
    r.frame = sec.value("frame", 0.0);  // older binaries did not time it
    r.trace = sec.at("trace");
    r.boundary = sec.at("boundary");
    r.write = sec.at("write");
    r.boundary_parts = j.value("boundary_seconds", json::object());
    // oracle.exr's and oracle.png's own times (written side by side), where the binary writes them.
    const json write_parts = j.value("write_seconds", json::object());  // items() must not outlive it
    for (const auto& [k, v] : write_parts.items()) r.boundary_parts["write_" + k] = v;
    r.primary = j.at("rays").at("primary");
    r.shadow = j.at("rays").at("shadow");
    r.retraced = j.at("rays").at("verified_retraces");
    return r;
}

// ---- bare Embree ----

struct BareRun {
    double load = 0, build = 0, trace = 0;
    double commit = 0;           // rtcCommitScene alone: Embree's BVH build
    double embree_peak_mib = 0;  // Embree's own allocations, peak (BVH, buffers)
    std::uint64_t rays = 0;
};

std::atomic<std::int64_t> g_embree_bytes{0}, g_embree_peak{0};
bool embree_memory_monitor(void*, ssize_t bytes, bool) {
    std::int64_t now = g_embree_bytes += bytes, peak = g_embree_peak;
    while (now > peak && !g_embree_peak.compare_exchange_weak(peak, now)) {
    }
    return true;
}

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

// The bare loop's rays, tile by tile (16 x 16 pixels, as the oracle's tiles): primary rays,
// then a shadow ray from every hit that faces the light. Returns the rays traced.
class BareTiles {
  public:
    static constexpr int kTile = 16;
    BareTiles(const BenchScene& s, RTCScene scene, bool halves)
        : scene_(scene),
          halves_(halves),
          W_(s.size),
          H_(s.size),
          tiles_x_(s.size / kTile),
          L_(glm::vec3(-s.light_direction)),
          znear_(static_cast<float>(s.camera.znear)),
          rays_(s.camera, W_, H_) {}
    int tiles_x() const { return tiles_x_; }
    int count() const { return tiles_x_ * (H_ / kTile); }
    std::uint64_t trace(int t) const {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
        std::uint64_t rays = 0;
        const int x0 = (t % tiles_x_) * kTile, y0 = (t / tiles_x_) * kTile;
        for (int by = y0; by < y0 + kTile; by += 4)
            for (int bx = x0; bx < x0 + kTile; bx += 4) {
                alignas(64) RTCRayHit16 rh;
                alignas(64) int valid[16];
                for (int k = 0; k < 16; ++k) {
                    PrimaryRay pr = rays_.at(bx + (k & 3) + 0.5, by + (k >> 2) + 0.5);
                    valid[k] = -1;
                    set_lane(rh, k, glm::vec3(pr.origin), glm::vec3(pr.direction), znear_);
                }
                oracle_detail::intersect_active_lanes(valid, scene_, &ctx, rh, halves_);
                rays += 16;
                alignas(64) RTCRayHit16 sh;
                alignas(64) int svalid[16];
                for (int k = 0; k < 16; ++k) {
                    svalid[k] = 0;
                    if (rh.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) continue;
                    glm::vec3 o(rh.ray.org_x[k], rh.ray.org_y[k], rh.ray.org_z[k]);
                    glm::vec3 d(rh.ray.dir_x[k], rh.ray.dir_y[k], rh.ray.dir_z[k]);
                    glm::vec3 n = glm::normalize(glm::vec3(rh.hit.Ng_x[k], rh.hit.Ng_y[k], rh.hit.Ng_z[k]));
                    if (glm::dot(n, d) > 0) n = -n;
                    if (glm::dot(n, L_) <= 0) continue;
                    svalid[k] = -1;
                    set_lane(sh, k, o + rh.ray.tfar[k] * d + 1e-3f * n, L_, 0.0f);
                    ++rays;
                }
                oracle_detail::intersect_active_lanes(svalid, scene_, &ctx, sh, halves_);
            }
        return rays;
    }

  private:
    RTCScene scene_;
    bool halves_;
    int W_, H_, tiles_x_;
    glm::vec3 L_;
    float znear_;
    PrimaryRays rays_;
};

// The oracle's trace phase and the bare loop's, interleaved: chunk c (kChunk tiles) of pass p
// goes to the oracle when c + p is even, to the bare loop otherwise, so over each pair of passes
// both cover every tile once. Each pair gives a ratio of rays per second, oracle over bare.
struct Interleaved {
    std::vector<double> ratios;  // one per pair of passes
};

Interleaved interleaved_trace(const BenchScene& s, const BareTiles& bare, int pairs) {
    using namespace oracle_detail;
    const Scenario scenario = load_scenario(s.scenario);
    Tracer tracer(scenario);
    tracer.build();
    OracleFrame frame;
    allocate_frame(frame, scenario);  // as run_oracle does
    constexpr int kChunk = 32;        // 8,192 pixels: about 2 ms of tracing on one core
    const int tiles = bare.count(), chunks = (tiles + kChunk - 1) / kChunk;
    Interleaved out;
    for (int pair = 0; pair < pairs; ++pair) {
        double seconds[2] = {0, 0};
        std::uint64_t rays[2] = {0, 0};
        for (int pass = 0; pass < 2; ++pass)
            for (int c = 0; c < chunks; ++c) {
                const int who = (c + pass) % 2;  // 0: the oracle, 1: bare
                std::atomic<std::uint64_t> chunk_rays{0};
                const auto t0 = SteadyClock::now();
                // Ranges of 4 tiles, as run_oracle hands them out.
                const tbb::blocked_range<int> range(c * kChunk, std::min(tiles, (c + 1) * kChunk), 4);
                tbb::parallel_for(range, [&](const tbb::blocked_range<int>& r) {
                    if (who == 1) {
                        for (int t = r.begin(); t != r.end(); ++t) chunk_rays += bare.trace(t);
                        return;
                    }
                    TraceCounters counters;
                    tracer.trace_tiles(frame, r.begin(), r.end(), bare.tiles_x(), BareTiles::kTile, counters);
                    chunk_rays += counters.primary + counters.shadow;
                });
                seconds[who] += seconds_since(t0);
                rays[who] += chunk_rays;
            }
        out.ratios.push_back((double(rays[0]) / seconds[0]) / (double(rays[1]) / seconds[1]));
    }
    return out;
}

BareRun bare_embree(const BenchScene& s, int threads, int interleaved_pairs, Interleaved* interleaved,
                    RTCBuildQuality quality = RTC_BUILD_QUALITY_MEDIUM,
                    RTCSceneFlags extra_flags = RTC_SCENE_FLAG_NONE) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    BareRun out;
    // Load: the file's bytes; the .glb written above has positions then indices in its BIN chunk.
    auto t0 = SteadyClock::now();
    std::vector<char> bytes(fs::file_size(s.scenario.parent_path() / "scene.glb"));
    std::ifstream(s.scenario.parent_path() / "scene.glb", std::ios::binary)
        .read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.load = seconds_since(t0);
    std::uint32_t json_len = 0;
    std::memcpy(&json_len, bytes.data() + 12, 4);
    json gltf = json::parse(bytes.data() + 20, bytes.data() + 20 + json_len);
    const char* bin = bytes.data() + 20 + json_len + 8;
    const std::size_t nv = gltf["accessors"][0]["count"], nt = std::size_t(gltf["accessors"][1]["count"]) / 3;
    const float* pos = reinterpret_cast<const float*>(bin);
    const auto* idx = reinterpret_cast<const unsigned*>(bin + std::size_t(gltf["bufferViews"][1]["byteOffset"]));

    t0 = SteadyClock::now();
    g_embree_bytes = g_embree_peak = 0;
    RTCDevice device = rtcNewDevice(("verbose=0,threads=" + std::to_string(threads)).c_str());
    rtcSetDeviceMemoryMonitorFunction(device, embree_memory_monitor, nullptr);
    RTCScene scene = rtcNewScene(device);
    rtcSetSceneFlags(scene, static_cast<RTCSceneFlags>(RTC_SCENE_FLAG_ROBUST | extra_flags));
    rtcSetSceneBuildQuality(scene, quality);
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(g, quality);
    auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 12, nv));
    auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, nt));
    for (std::size_t i = 0; i < nv; ++i)
        for (int c = 0; c < 3; ++c) vb[3 * i + c] = static_cast<float>(double(pos[3 * i + c]) - s.camera.eye[c]);
    std::memcpy(ib, idx, nt * 12);
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    const auto t_commit = SteadyClock::now();
    rtcCommitScene(scene);
    out.commit = seconds_since(t_commit);
    out.build = seconds_since(t0);

    // Packets as the oracle sends them (oracle/tracer.h): the same kernels, inactive lanes marked.
    const BareTiles tiles(s, scene, oracle_detail::packets_as_halves(device));
    std::atomic<std::uint64_t> rays{0};
    t0 = SteadyClock::now();
    tbb::parallel_for(tbb::blocked_range<int>(0, tiles.count(), 4), [&](const tbb::blocked_range<int>& r) {
        std::uint64_t local = 0;
        for (int t = r.begin(); t != r.end(); ++t) local += tiles.trace(t);
        rays += local;
    });
    out.trace = seconds_since(t0);
    out.rays = rays;
    out.embree_peak_mib = g_embree_peak / (1024.0 * 1024.0);
    if (interleaved_pairs > 0) *interleaved = interleaved_trace(s, tiles, interleaved_pairs);
    rtcReleaseScene(scene);
    rtcReleaseDevice(device);
    return out;
}

// Median and range of one quantity over the repeats.
struct Spread {
    std::vector<double> v;
    double median() const {
        auto s = v;
        std::sort(s.begin(), s.end());
        return s.empty() ? 0 : s[s.size() / 2];
    }
    std::string text(const char* fmt) const {
        char buf[96];
        auto [lo, hi] = std::minmax_element(v.begin(), v.end());
        std::string f = std::string(fmt) + " (" + fmt + "-" + fmt + ")";
        std::snprintf(buf, sizeof buf, f.c_str(), median(), *lo, *hi);
        return buf;
    }
};

bool same_bytes(const fs::path& a, const fs::path& b) {
    std::error_code ec;
    if (fs::file_size(a, ec) != fs::file_size(b, ec) || ec) return false;
    std::ifstream fa(a, std::ios::binary), fb(b, std::ios::binary);
    std::vector<char> ba(1 << 20), bb(1 << 20);
    while (fa && fb) {
        fa.read(ba.data(), static_cast<std::streamsize>(ba.size()));
        fb.read(bb.data(), static_cast<std::streamsize>(bb.size()));
        if (fa.gcount() != fb.gcount() || std::memcmp(ba.data(), bb.data(), static_cast<std::size_t>(fa.gcount())))
            return false;
    }
    return true;
}

// The issue #39 table: the oracle alone at each thread count (and `baseline`, another binary,
// in the same rounds), medians of `repeat`; every oracle.exr compared with the first run's.
void threads_sweep(const BenchScene& s, const fs::path& dir, const std::vector<int>& threads, int repeat,
                   const std::vector<std::pair<std::string, std::string>>& binaries, const std::string& builds) {
    struct Row {
        Spread wall, load, build, frame, trace, boundary, write, peak, cpu;
        std::map<std::string, Spread> parts;
    };
    std::vector<std::vector<Row>> rows(binaries.size(), std::vector<Row>(threads.size()));
    const fs::path reference = dir / s.name / "reference.exr";
    fs::remove(reference);
    int runs = 0;
    std::vector<std::string> differ;
    for (int r = 0; r < repeat; ++r)
        for (std::size_t t = 0; t < threads.size(); ++t)
            for (std::size_t b = 0; b < binaries.size(); ++b) {
                const fs::path out = dir / s.name / "out";
                OracleRun o = run_penumbra(binaries[b].second, s, out, threads[t]);
                Row& row = rows[b][t];
                row.wall.v.push_back(o.wall);
                row.load.v.push_back(o.load);
                row.build.v.push_back(o.build);
                row.frame.v.push_back(o.frame);
                row.trace.v.push_back(o.trace);
                row.boundary.v.push_back(o.boundary);
                row.write.v.push_back(o.write);
                row.peak.v.push_back(o.peak_mib);
                row.cpu.v.push_back(o.cpu);
                for (const auto& [k, v] : o.boundary_parts.items()) row.parts[k].v.push_back(v.get<double>());
                if (!fs::exists(reference)) {
                    fs::copy_file(out / "oracle.exr", reference);
                } else {
                    ++runs;
                    if (!same_bytes(reference, out / "oracle.exr"))
                        differ.push_back(binaries[b].first + " at " + std::to_string(threads[t]) + " threads");
                }
            }
    for (std::size_t b = 0; b < binaries.size(); ++b) {
        std::printf("\n%s (%s), median of %d:\n\n", binaries[b].first.c_str(), binaries[b].second.c_str(), repeat);
        std::printf(
            "| threads | wall s | load | build | frame | trace | boundary | write | peak MiB | speed-up | CPU s |\n");
        std::printf("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n");
        const double one = rows[b][0].wall.median();
        for (std::size_t t = 0; t < threads.size(); ++t) {
            const Row& row = rows[b][t];
            std::printf("| %d | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f | %.0f | %.2f | %.2f |\n", threads[t],
                        row.wall.median(), row.load.median(), row.build.median(), row.frame.median(),
                        row.trace.median(), row.boundary.median(), row.write.median(), row.peak.median(),
                        one / row.wall.median(), row.cpu.median());
        }
        // Every part any thread count reported (oracle.exr's early write only runs from 2 threads).
        std::set<std::string> part_names;
        for (const auto& row : rows[b])
            for (const auto& [k, v] : row.parts) part_names.insert(k);
        if (!part_names.empty()) {
            std::printf("\nboundary and write parts (s):\n\n| threads |");
            for (const std::string& k : part_names) std::printf(" %s |", k.c_str());
            std::printf("\n| --- |");
            for (std::size_t k = 0; k < part_names.size(); ++k) std::printf(" --- |");
            std::printf("\n");
            for (std::size_t t = 0; t < threads.size(); ++t) {
                std::printf("| %d |", threads[t]);
                for (const std::string& k : part_names) {
                    const auto it = rows[b][t].parts.find(k);
                    if (it == rows[b][t].parts.end())
                        std::printf(" - |");
                    else
                        std::printf(" %.4f |", it->second.median());
                }
                std::printf("\n");
            }
        }
    }
    if (binaries.size() > 1) {
        std::printf("\nwall %s / %s (median of per-round ratios):", binaries[0].first.c_str(),
                    binaries[1].first.c_str());
        for (std::size_t t = 0; t < threads.size(); ++t) {
            Spread ratio;
            for (int r = 0; r < repeat; ++r) ratio.v.push_back(rows[0][t].wall.v[r] / rows[1][t].wall.v[r]);
            std::printf("  %d: %s", threads[t], ratio.text("%.3f").c_str());
        }
        std::printf("\n");
        std::printf("CPU s %s / %s (median of per-round ratios):", binaries[0].first.c_str(),
                    binaries[1].first.c_str());
        for (std::size_t t = 0; t < threads.size(); ++t) {
            Spread ratio;
            for (int r = 0; r < repeat; ++r) ratio.v.push_back(rows[0][t].cpu.v[r] / rows[1][t].cpu.v[r]);
            std::printf("  %d: %s", threads[t], ratio.text("%.3f").c_str());
        }
        std::printf("\n");
    }
    std::printf("\noracle.exr: %d runs compared with the first: %s\n", runs,
                differ.empty() ? "all byte-identical" : "DIFFERENT:");
    for (const std::string& d : differ) std::printf("  differs: %s\n", d.c_str());
    if (builds.empty()) return;
    std::printf("\nbare Embree at %d threads, by build quality (median of %d):\n\n", threads.back(), repeat);
    std::printf(
        "| quality | commit s | build s (with the vertex copy) | trace s | peak MiB |\n| --- | --- | --- | --- | --- "
        "|\n");
    std::vector<std::string> qualities;
    for (std::size_t a = 0, e; a <= builds.size(); a = e + 1) {
        e = builds.find(',', a);
        if (e == std::string::npos) e = builds.size();
        if (e > a) qualities.push_back(builds.substr(a, e - a));
    }
    for (const std::string& q : qualities) {
        // QUALITY[+compact][+dynamic]: the build quality and scene flags beside the oracle's ROBUST.
        const RTCBuildQuality quality = q.rfind("low", 0) == 0    ? RTC_BUILD_QUALITY_LOW
                                        : q.rfind("high", 0) == 0 ? RTC_BUILD_QUALITY_HIGH
                                                                  : RTC_BUILD_QUALITY_MEDIUM;
        int flags = RTC_SCENE_FLAG_NONE;
        if (q.find("+compact") != std::string::npos) flags |= RTC_SCENE_FLAG_COMPACT;
        if (q.find("+dynamic") != std::string::npos) flags |= RTC_SCENE_FLAG_DYNAMIC;
        Spread commit, build, trace, peak;
        for (int r = 0; r < repeat; ++r) {
            BareRun b = bare_embree(s, threads.back(), 0, nullptr, quality, static_cast<RTCSceneFlags>(flags));
            commit.v.push_back(b.commit);
            build.v.push_back(b.build);
            trace.v.push_back(b.trace);
            peak.v.push_back(b.embree_peak_mib);
        }
        std::printf("| %s | %s | %s | %s | %s |\n", q.c_str(), commit.text("%.3f").c_str(), build.text("%.3f").c_str(),
                    trace.text("%.3f").c_str(), peak.text("%.0f").c_str());
    }
}

}  // namespace

int main(int argc, char** argv) {
    int size = 2048, repeat = 3, bare = 1, inside_out = 0, interleave = 3, unweld = 0;
    bool sweep = false, threads_given = false;
    std::string scenes = "terrain,spheres", thread_list = "1,2", keep, baseline, builds;
    std::string penumbra = PENUMBRA_BINARY;
    std::setvbuf(stdout, nullptr, _IOLBF, 0);  // line by line, also into a file: the runs are long
    for (int i = 1; i < argc; i += 2) {
        std::string a = argv[i];
        if (a == "--threads-sweep") {
            sweep = true;
            --i;
            continue;
        }
        if (i + 1 >= argc) a = "--help";
        std::string v = a == "--help" ? "" : argv[i + 1];
        if (a == "--size")
            size = std::stoi(v);
        else if (a == "--repeat")
            repeat = std::max(1, std::stoi(v));
        else if (a == "--threads")
            thread_list = v, threads_given = true;
        else if (a == "--baseline")
            baseline = v;
        else if (a == "--embree-builds")
            builds = v;
        else if (a == "--scenes")
            scenes = v;
        else if (a == "--bare")
            bare = std::stoi(v);
        else if (a == "--penumbra")
            penumbra = v;
        else if (a == "--inside-out")
            inside_out = std::stoi(v);
        else if (a == "--unwelded")
            unweld = std::stoi(v);
        else if (a == "--keep")
            keep = v;
        else if (a == "--interleave")
            interleave = std::max(0, std::stoi(v));
        else {
            std::fprintf(stderr,
                         "usage: oracle_bench [--scenes terrain,spheres] [--threads 1,2] [--repeat 3] [--size 2048] "
                         "[--bare 0|1] [--interleave PAIRS] [--inside-out 0|1] [--unwelded 0|1] [--penumbra PATH] "
                         "[--keep DIR]\n"
                         "       oracle_bench --threads-sweep [--scenes field32,field64] [--threads LIST] [--repeat 3] "
                         "[--baseline PATH] [--unwelded 0|1] [--embree-builds low,medium,high,medium+compact,...]\n");
            return 2;
        }
    }
    auto split = [](const std::string& s) {
        std::vector<std::string> out;
        for (std::size_t a = 0, b; a <= s.size(); a = b + 1) {
            b = s.find(',', a);
            if (b == std::string::npos) b = s.size();
            if (b > a) out.push_back(s.substr(a, b - a));
        }
        return out;
    };
    fs::path dir =
        keep.empty() ? fs::temp_directory_path() / ("oracle_bench." + std::to_string(getpid())) : fs::path(keep);
    fs::create_directories(dir);
    std::printf("penumbra: %s\nfiles: %s\n", penumbra.c_str(), dir.c_str());
    std::vector<int> sweep_threads;
    if (sweep) {
        const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
        if (threads_given) {
            for (const std::string& t : split(thread_list)) sweep_threads.push_back(std::stoi(t));
        } else {
            for (int t : {1, 2, 4, 8, 16})
                if (t <= cores) sweep_threads.push_back(t);
        }
        std::printf("threads sweep on %d hardware threads\n", cores);
    }
    for (const std::string& name : split(scenes)) {
        BenchScene s = make_scene(dir, name, size, inside_out != 0, unweld != 0);
        std::printf("\n== %s: %.0f MB %s.glb, %dx%d, 1 directional light ==\n", name.c_str(),
                    fs::file_size(dir / name / "scene.glb") / 1e6, unweld ? "unwelded " : "", size, size);
        if (sweep) {
            std::vector<std::pair<std::string, std::string>> binaries = {{"this build", penumbra}};
            if (!baseline.empty()) binaries.push_back({"baseline", baseline});
            threads_sweep(s, dir, sweep_threads, repeat, binaries, builds);
            continue;
        }
        for (const std::string& ts : split(thread_list)) {
            const int threads = std::stoi(ts);
            Spread wall, load, build, frame, trace, boundary, write, peak, b_load, b_build, b_trace, b_peak,
                whole_ratio, trace_ratio, mem_ratio;
            OracleRun o;
            BareRun b;
            Interleaved interleaved;
            for (int r = 0; r < repeat; ++r) {
                o = run_penumbra(penumbra, s, dir / name / "out", threads);
                wall.v.push_back(o.wall);
                load.v.push_back(o.load);
                build.v.push_back(o.build);
                trace.v.push_back(o.trace);
                boundary.v.push_back(o.boundary);
                frame.v.push_back(o.frame);
                write.v.push_back(o.write);
                peak.v.push_back(o.peak_mib);
                if (!bare) continue;
                b = bare_embree(s, threads, r == repeat - 1 ? interleave : 0, &interleaved);
                b_load.v.push_back(b.load);
                b_build.v.push_back(b.build);
                b_trace.v.push_back(b.trace);
                b_peak.v.push_back(b.embree_peak_mib);
                whole_ratio.v.push_back(o.wall / (b.load + b.build + b.trace));
                // Same rays: the oracle's primary and shadow rays (its re-traces are extra work).
                trace_ratio.v.push_back((double(o.primary + o.shadow) / o.trace) / (double(b.rays) / b.trace));
                const double channels_mib = double(size) * size * (9 + 6) * 4 / (1024.0 * 1024.0);
                mem_ratio.v.push_back(o.peak_mib / (b.embree_peak_mib + channels_mib));
            }
            const std::uint64_t shadow = o.shadow;
            std::printf("-- %d thread%s, median (min-max) of %d --\n", threads, threads > 1 ? "s" : "", repeat);
            std::printf("oracle  whole %s s  peak %s MiB\n", wall.text("%.2f").c_str(), peak.text("%.0f").c_str());
            std::printf("        load %s  build %s  frame %s  trace %s  boundary %s  write %s s\n",
                        load.text("%.2f").c_str(), build.text("%.2f").c_str(), frame.text("%.2f").c_str(),
                        trace.text("%.2f").c_str(), boundary.text("%.2f").c_str(), write.text("%.2f").c_str());
            std::printf("        rays: %llu primary, %llu shadow, %llu re-traced in double (%.2f%% of shadow rays)\n",
                        (unsigned long long)o.primary, (unsigned long long)shadow, (unsigned long long)o.retraced,
                        shadow ? 100.0 * o.retraced / shadow : 0.0);
            if (!bare) continue;
            std::printf("bare    load %s  build %s  trace %s s (%llu rays)  Embree peak %s MiB\n",
                        b_load.text("%.3f").c_str(), b_build.text("%.2f").c_str(), b_trace.text("%.2f").c_str(),
                        (unsigned long long)b.rays, b_peak.text("%.0f").c_str());
            std::printf("ratios  whole oracle / bare load+build+trace %s (goal <= 2)\n",
                        whole_ratio.text("%.2f").c_str());
            std::printf("        trace rays/s oracle / bare %s (goal >= 0.7)\n", trace_ratio.text("%.2f").c_str());
            if (!interleaved.ratios.empty())
                std::printf("        the same, interleaved in one process: %s, median (min-max) of %zu pass pairs\n",
                            Spread{interleaved.ratios}.text("%.3f").c_str(), interleaved.ratios.size());
            std::printf("        peak memory / (Embree peak + frame channels) %s (goal <= 1.5)\n",
                        mem_ratio.text("%.2f").c_str());
        }
    }
    if (keep.empty()) fs::remove_all(dir);
    return 0;
}
