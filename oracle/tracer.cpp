#include "oracle/tracer.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <glm/geometric.hpp>
#include <limits>
#include <utility>

#include "common/camera.h"
#include "common/errors.h"

namespace penumbra::oracle_detail {

namespace {

constexpr int kPacket = 16;  // rays per Embree packet: a 4x4 block of pixels, or one area-light round
static_assert(kRoundRays == kPacket);

// Context of every trace: Embree hands the RTCIntersectContext pointer back to the filters, so
// it is the first member.
struct FilterContext {
    RTCIntersectContext embree;
    const Tracer* tracer = nullptr;
    glm::dvec3 p{0.0}, dir{0.0};  // true (double) origin and direction of a single ray
    std::uint32_t self_prim = kNoPrimitive;
    bool ambiguous = false;
    // A packet's true rays by ray id (set_lane's k), for the cut-out filter; null: p and dir.
    const glm::dvec3* lane_org = nullptr;
    const glm::dvec3* lane_dir = nullptr;
    std::uint32_t ambiguous_lanes = 0;  // bit k: ray k passed within float error of a cut-out's edge
};

FilterContext make_context(const Tracer* tracer, bool coherent) {
    FilterContext ctx;
    rtcInitIntersectContext(&ctx.embree);
    if (coherent) ctx.embree.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    ctx.tracer = tracer;
    return ctx;
}

// Hits on a cut-out where its coverage is below the cutoff are no hits (glTF 2.0 3.9.4): judged
// on the exact ray in double (Tracer::cutout_hit). Set on the geometry only where the scene has
// cut-outs; every trace's context is a FilterContext.
void cutout_filter(const RTCFilterFunctionNArguments* args) {
    const auto* tracer = static_cast<const Tracer*>(args->geometryUserPtr);
    auto* ctx = reinterpret_cast<FilterContext*>(args->context);
    for (unsigned i = 0; i < args->N; ++i) {
        if (!args->valid[i]) continue;
        const std::uint32_t prim = RTCHitN_primID(args->hit, args->N, i);
        if (!tracer->is_cutout(prim)) continue;
        const unsigned id = RTCRayN_id(args->ray, args->N, i);
        const bool lanes = ctx->lane_org != nullptr && id < 16;
        const CoverageAnswer a =
            tracer->cutout_hit(prim, lanes ? ctx->lane_org[id] : ctx->p, lanes ? ctx->lane_dir[id] : ctx->dir,
                               RTCHitN_u(args->hit, args->N, i), RTCHitN_v(args->hit, args->N, i));
        if (a.ambiguous) {
            ctx->ambiguous = true;
            if (id < 32) ctx->ambiguous_lanes |= 1u << id;
        }
        if (!a.opaque) args->valid[i] = 0;
    }
}

// Every candidate hit of a re-traced shadow ray is judged in double.
void shadow_filter(const RTCFilterFunctionNArguments* args) {
    auto* ctx = reinterpret_cast<FilterContext*>(args->context);
    for (unsigned i = 0; i < args->N; ++i) {
        if (!args->valid[i]) continue;
        std::uint32_t prim = RTCHitN_primID(args->hit, args->N, i);
        switch (ctx->tracer->verify(prim, ctx->p, ctx->dir, ctx->self_prim)) {
            case robust::HitVerdict::real: break;
            case robust::HitVerdict::edge: ctx->ambiguous = true; break;
            case robust::HitVerdict::in_plane:
                ctx->ambiguous = true;
                args->valid[i] = 0;
                break;
            case robust::HitVerdict::spurious: args->valid[i] = 0; break;
        }
    }
}

// Single-sided triangles seen from behind are culled for the camera, as a rasteriser would.
void camera_cull_filter(const RTCFilterFunctionNArguments* args) {
    auto* ctx = reinterpret_cast<FilterContext*>(args->context);
    for (unsigned i = 0; i < args->N; ++i)
        if (args->valid[i] && ctx->tracer->culled_for_camera(RTCHitN_primID(args->hit, args->N, i), ctx->dir))
            args->valid[i] = 0;
}

void set_ray(RTCRay& r, const glm::vec3& o, const glm::vec3& d, float tnear, float tfar) {
    r.org_x = o.x;
    r.org_y = o.y;
    r.org_z = o.z;
    r.dir_x = d.x;
    r.dir_y = d.y;
    r.dir_z = d.z;
    r.tnear = tnear;
    r.tfar = tfar;
    r.time = 0;
    r.mask = 0xFFFFFFFFu;
    r.id = 0;
    r.flags = 0;
}

void set_lane(RTCRay16& r, int k, const glm::vec3& o, const glm::vec3& d, float tnear, float tfar) {
    r.org_x[k] = o.x;
    r.org_y[k] = o.y;
    r.org_z[k] = o.z;
    r.dir_x[k] = d.x;
    r.dir_y[k] = d.y;
    r.dir_z[k] = d.z;
    r.tnear[k] = tnear;
    r.tfar[k] = tfar;
    r.time[k] = 0;
    r.mask[k] = 0xFFFFFFFFu;
    r.id[k] = static_cast<unsigned>(k);
    r.flags[k] = 0;
}

}  // namespace

void intersect_active_lanes(const int* valid, RTCScene scene, RTCIntersectContext* ctx, RTCRayHit16& rh,
                            bool as_halves) {
    for (int k = 0; k < kPacket; ++k) {
        if (valid[k]) continue;
        set_lane(rh.ray, k, glm::vec3(0.0f), glm::vec3(0.0f), 0.0f, -std::numeric_limits<float>::infinity());
    }
    if (!as_halves) {
        rtcIntersect16(valid, scene, ctx, &rh);
        return;
    }
    constexpr std::size_t kHalf = 8 * sizeof(float);
    for (int o = 0; o < kPacket; o += 8) {
        alignas(32) int half_valid[8];
        alignas(32) RTCRayHit8 half;
        std::memcpy(half_valid, valid + o, sizeof half_valid);
        if (std::all_of(half_valid, half_valid + 8, [](int v) { return v == 0; })) continue;
        for (auto [to, from] : {std::pair{half.ray.org_x, rh.ray.org_x},
                                {half.ray.org_y, rh.ray.org_y},
                                {half.ray.org_z, rh.ray.org_z},
                                {half.ray.tnear, rh.ray.tnear},
                                {half.ray.dir_x, rh.ray.dir_x},
                                {half.ray.dir_y, rh.ray.dir_y},
                                {half.ray.dir_z, rh.ray.dir_z},
                                {half.ray.time, rh.ray.time},
                                {half.ray.tfar, rh.ray.tfar}})
            std::memcpy(to, from + o, kHalf);
        for (auto [to, from] : {std::pair{half.ray.mask, rh.ray.mask},
                                {half.ray.id, rh.ray.id},
                                {half.ray.flags, rh.ray.flags},
                                {half.hit.primID, rh.hit.primID},
                                {half.hit.geomID, rh.hit.geomID},
                                {half.hit.instID[0], rh.hit.instID[0]}})
            std::memcpy(to, from + o, kHalf);
        rtcIntersect8(half_valid, scene, ctx, &half);
        for (auto [to, from] : {std::pair{rh.ray.tfar, half.ray.tfar},
                                {rh.hit.Ng_x, half.hit.Ng_x},
                                {rh.hit.Ng_y, half.hit.Ng_y},
                                {rh.hit.Ng_z, half.hit.Ng_z},
                                {rh.hit.u, half.hit.u},
                                {rh.hit.v, half.hit.v}})
            std::memcpy(to + o, from, kHalf);
        for (auto [to, from] : {std::pair{rh.hit.primID, half.hit.primID},
                                {rh.hit.geomID, half.hit.geomID},
                                {rh.hit.instID[0], half.hit.instID[0]}})
            std::memcpy(to + o, from, kHalf);
    }
}

bool packets_as_halves(RTCDevice device) {
    return rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED) == 0 &&
           rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED) != 0;
}

float occluder_distance(const ShadowSetup& setup, const glm::dvec3& p, float t_hit) {
    // Embree's t counts from the offset origin; the answer is the distance from the true point.
    return static_cast<float>(glm::length(glm::dvec3(setup.origin) + static_cast<double>(t_hit) * setup.dir - p));
}

namespace {

// Embree's device configuration; it reads an unknown ISA name as SSE2, so names are checked here.
std::string device_config(const std::string& embree_isa) {
    if (embree_isa.empty()) return "verbose=0";
    for (const char* known : {"sse2", "sse4.2", "avx", "avx2", "avx512"})
        if (embree_isa == known) return "verbose=0,max_isa=" + embree_isa;
    throw InputError(fmt::format("embree_isa \"{}\": not one of sse2, sse4.2, avx, avx2, avx512", embree_isa));
}

}  // namespace

Tracer::Tracer(const Scenario& scenario, const std::string& embree_isa)
    : scenario_(scenario),
      device_(device_config(embree_isa)),
      as_halves_(packets_as_halves(device_.get())),
      scene_(device_),
      tris_(scenario.scene.triangles),
      double_sided_(scenario.scene.double_sided),
      triangle_node_(scenario.scene.triangle_node),
      cutouts_(scenario.scene.has_masks()) {}

void Tracer::set_camera(const Camera& camera) {
    camera_ = camera;
    camera_eye_ = camera.eye - frame_origin_;
}

void Tracer::build() {
    frame_origin_ = scenario_.camera.eye;
    set_camera(scenario_.camera);
    const auto& world = scenario_.scene.positions;
    // Written in parallel, without a serial zero-fill first (a maximum is exact whatever the
    // order): 4.5M vertices took 0.1 s serially.
    vertex_count_ = world.size();
    vertices_ = std::make_unique_for_overwrite<glm::dvec3[]>(vertex_count_);
    constexpr std::size_t kGrain = std::size_t(1) << 15;
    max_vertex_norm_ = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, world.size(), kGrain), 0.0,
        [&](const tbb::blocked_range<std::size_t>& r, double m) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) {
                vertices_[i] = world[i] - frame_origin_;  // in double: float precision goes where the pixels are
                m = std::max(m, glm::length(vertices_[i]));
            }
            return m;
        },
        [](double a, double b) { return std::max(a, b); });
    RTCScene sc = scene_.get();
    // ROBUST: watertight traversal, no cracks between triangles sharing an edge.
    // CONTEXT_FILTER_FUNCTION: lets the rare re-traced rays judge their hits in double.
    rtcSetSceneFlags(sc, RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);
    if (!tris_.empty()) {
        RTCGeometry geom = rtcNewGeometry(device_.get(), RTC_GEOMETRY_TYPE_TRIANGLE);
        auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                               3 * sizeof(float), vertex_count_));
        // The scene's own triangles are the index buffer (three uint32 each): no copy.
        static_assert(sizeof(glm::u32vec3) == 3 * sizeof(unsigned));
        rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, tris_.data(), 0,
                                   sizeof(glm::u32vec3), tris_.size());
        device_.check("buffer allocation");
        if (!vb) throw EnvironmentError("Embree: cannot allocate geometry buffers");
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, vertex_count_, kGrain),
                          [&](const tbb::blocked_range<std::size_t>& r) {
                              for (std::size_t i = r.begin(); i != r.end(); ++i) {
                                  glm::vec3 f = glm::vec3(vertices_[i]);
                                  vb[3 * i] = f.x;
                                  vb[3 * i + 1] = f.y;
                                  vb[3 * i + 2] = f.z;
                              }
                          });
        if (cutouts_) {  // blended materials are opaque in the truth
            rtcSetGeometryUserData(geom, const_cast<Tracer*>(this));
            rtcSetGeometryIntersectFilterFunction(geom, &cutout_filter);
        }
        rtcCommitGeometry(geom);
        rtcAttachGeometry(sc, geom);
        rtcReleaseGeometry(geom);  // the scene holds the reference now
    }
    rtcCommitScene(sc);
    device_.check("BVH build");
    for (const Light& l : scenario_.lights) {
        LocalLight ll;
        ll.sampled = is_soft_light(l);
        if (ll.sampled) ll.area = make_area_light(l, frame_origin_);
        ll.type = l.type;
        ll.position = l.position - frame_origin_;
        ll.to_light = -l.direction;
        ll.spot_axis = l.direction;
        ll.cos_outer = l.type == LightType::spot ? std::cos(l.outer_cone_rad) : -1.0;
        lights_.push_back(ll);
    }
}

glm::dvec3 Tracer::normal_ccw(std::uint32_t prim) const {
    return glm::cross(vertex(prim, 1) - vertex(prim, 0), vertex(prim, 2) - vertex(prim, 0));
}

robust::HitVerdict Tracer::verify(std::uint32_t prim, const glm::dvec3& p, const glm::dvec3& dir,
                                  std::uint32_t self_prim) const {
    if (prim == self_prim) return robust::HitVerdict::spurious;  // a plane cannot shadow itself
    return robust::verify_hit(p, dir, vertex(prim, 0), vertex(prim, 1), vertex(prim, 2));
}

bool Tracer::culled_for_camera(std::uint32_t prim, const glm::dvec3& ray_dir) const {
    return !double_sided_[prim] && glm::dot(normal_ccw(prim), ray_dir) > 0;
}

CoverageAnswer Tracer::cutout_hit(std::uint32_t prim, const glm::dvec3& org, const glm::dvec3& dir, float u,
                                  float v) const {
    // Moeller and Trumbore (1997) in double on the exact triangle: the barycentrics of the true
    // ray, not of Embree's float one. Their error is a few ulps over |cos| of the ray and the
    // plane; the texel reach below is far above that and far below a texel.
    const glm::dvec3 &v0 = vertex(prim, 0), e1 = vertex(prim, 1) - v0, e2 = vertex(prim, 2) - v0;
    const glm::dvec3 pvec = glm::cross(dir, e2);
    const double det = glm::dot(e1, pvec);
    const double scale = glm::length(e1) * glm::length(e2) * glm::length(dir);
    constexpr double kReachTexels = 1e-6;
    if (!(std::abs(det) > 1e-9 * scale)) {  // grazing: the plane's answer is Embree's, and unsure
        CoverageAnswer a = scenario_.scene.cutout_coverage(prim, u, v, kReachTexels);
        a.ambiguous = true;
        return a;
    }
    const glm::dvec3 s = org - v0, qvec = glm::cross(s, e1);
    const double b1 = glm::dot(s, pvec) / det, b2 = glm::dot(dir, qvec) / det;
    const double cos_plane = std::abs(det) / scale;  // |sin| of the triangle's corner folds in: a bound
    return scenario_.scene.cutout_coverage(prim, b1, b2, kReachTexels / std::max(cos_plane, 1e-3));
}

double Tracer::suspicious_hit_distance(const glm::dvec3& p, double cos_hit) const {
    // Embree's plane-distance error is ~eps * (|origin| + |vertex|); along the ray it grows as
    // 1 / cos(ray, hit plane). Hits closer than 64x that are re-judged in double.
    return 64 * robust::kFloatEps * (glm::length(p) + max_vertex_norm_) / std::max(cos_hit, 1e-9);
}

void Tracer::primary_hit(std::uint32_t prim, double u, double v, double t, const glm::dvec3& ray_org,
                         const glm::dvec3& ray_dir, const glm::dvec3& n_ccw, SurfacePoint& s) const {
    // Rebuild the point from Embree's barycentrics and the double vertices: it lies on the
    // exact triangle whatever the float error of t.
    double b1 = std::clamp(u, 0.0, 1.0), b2 = std::clamp(v, 0.0, 1.0);
    if (b1 + b2 > 1.0) {
        double k = 1.0 / (b1 + b2);
        b1 *= k;
        b2 *= k;
    }
    double b0 = 1.0 - b1 - b2;
    const glm::dvec3 &v0 = vertex(prim, 0), &v1 = vertex(prim, 1), &v2 = vertex(prim, 2);
    s.hit = true;
    s.prim = prim;
    s.p = b0 * v0 + b1 * v1 + b2 * v2;
    s.error = robust::surface_error_bound(s.p, b0 * glm::abs(v0) + b1 * glm::abs(v1) + b2 * glm::abs(v2));
    s.n = glm::normalize(n_ccw);
    if (glm::dot(s.n, ray_dir) > 0) s.n = -s.n;
    s.depth = t;
    // The pixel's exact ray against the exact triangle's plane, where the ray does not graze it
    // (docs/design.md, "One surface point per pixel"): Embree's float barycentrics err by
    // eps x the triangle's size, metres on a triangle 10^7 m across (docs/stress.md, depth_range_1e7).
    const double cos_ray = glm::dot(s.n, ray_dir);
    if (std::abs(cos_ray) > 1e-6 * glm::length(ray_dir)) {
        const double t_plane = glm::dot(s.n, v0 - ray_org) / cos_ray;
        if (std::isfinite(t_plane) && t_plane > 0) {
            s.p = ray_org + t_plane * ray_dir;
            s.depth = t_plane;
        }
    }
}

ShadowAnswer Tracer::trace_shadow_verified(const ShadowSetup& setup, const glm::dvec3& p,
                                           std::uint32_t self_prim) const {
    FilterContext ctx = make_context(this, false);
    ctx.embree.filter = &shadow_filter;
    ctx.p = p;
    ctx.dir = setup.dir;
    ctx.self_prim = self_prim;
    RTCRayHit rh{};
    set_ray(rh.ray, setup.origin, setup.dir_f, 0.0f, setup.tfar);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene_.get(), &ctx.embree, &rh);
    ShadowAnswer a;
    a.ambiguous = ctx.ambiguous;
    if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
        a.blocked = true;
        a.occluder_t = occluder_distance(setup, p, rh.ray.tfar);
        a.occluder = rh.hit.primID;
    }
    return a;
}

ShadowAnswer Tracer::judge_lane(const RTCRayHit16& sh, int k, const ShadowSetup& setup, const SurfacePoint& s,
                                TraceCounters& counters) const {
    ShadowAnswer ans;
    if (sh.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) return ans;
    ans.blocked = true;
    ans.occluder_t = occluder_distance(setup, s.p, sh.ray.tfar[k]);
    glm::dvec3 ng(sh.hit.Ng_x[k], sh.hit.Ng_y[k], sh.hit.Ng_z[k]);
    double cos_hit = std::abs(glm::dot(ng, setup.dir)) / std::max(glm::length(ng), 1e-300);
    if (ans.occluder_t < suspicious_hit_distance(s.p, cos_hit)) {
        auto verdict = verify(sh.hit.primID[k], s.p, setup.dir, s.prim);
        if (verdict == robust::HitVerdict::edge) {
            ans.ambiguous = true;
        } else if (verdict != robust::HitVerdict::real) {
            ans = trace_shadow_verified(setup, s.p, s.prim);
            ++counters.retraced;
        }
    }
    return ans;
}

AreaRound Tracer::trace_area_round(std::size_t li, const SurfacePoint& s, const AreaView& view, int first_point,
                                   std::uint64_t scramble, TraceCounters& counters) const {
    const AreaLight& light = lights_[li].area;
    const glm::vec3 origin = robust::offset_ray_origin(s.p, s.n, s.error);
    const auto shift_s = static_cast<std::uint32_t>(scramble), shift_t = static_cast<std::uint32_t>(scramble >> 32);
    FilterContext coherent = make_context(this, true);  // one origin, one light: a tight bundle
    alignas(64) RTCRayHit16 sh;
    alignas(64) int valid[kPacket];
    ShadowSetup setup[kPacket];
    // A cut-out's hits are judged on each sample's exact ray (the sampled V's confidence bound
    // covers a sample within float error of a cut-out's edge, as of any other edge).
    glm::dvec3 lane_org[kPacket], lane_dir[kPacket];
    if (cutouts_) {
        std::fill(lane_org, lane_org + kPacket, s.p);
        coherent.lane_org = lane_org;
        coherent.lane_dir = lane_dir;
    }
    bool any = false;
    for (int k = 0; k < kRoundRays; ++k) {
        valid[k] = 0;
        const auto index = static_cast<std::uint32_t>(first_point + k);
        double u = (sobol_dim0(index) ^ shift_s) * 0x1p-32;
        double v = (sobol_dim1(index) ^ shift_t) * 0x1p-32;
        setup[k].origin = origin;
        if (light.type == LightType::directional) {  // a sun with a size: a direction, no point
            const glm::dvec3 d = sun_direction(light, u, v);
            if (!(glm::dot(s.n, d) > 0)) continue;  // under the tangent plane
            setup[k].dir = d;
            setup[k].dir_f = glm::vec3(d);
            setup[k].tfar = std::numeric_limits<float>::infinity();
        } else {
            glm::dvec3 q = area_light_point(light, view, u, v);
            // A point under the receiver's tangent plane is hidden by the receiver itself.
            if (!(glm::dot(s.n, q - s.p) > 0)) continue;
            if (!(aim_at_light_point(setup[k], q) > 0)) continue;
        }
        set_lane(sh.ray, k, origin, setup[k].dir_f, 0.0f, setup[k].tfar);
        sh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
        lane_dir[k] = setup[k].dir;
        valid[k] = -1;
        any = true;
        ++counters.shadow;
    }
    AreaRound round;
    if (!any) return round;
    intersect_active_lanes(valid, scene_.get(), &coherent.embree, sh, as_halves_);
    for (int k = 0; k < kRoundRays; ++k) {
        if (!valid[k]) continue;
        ShadowAnswer ans = judge_lane(sh, k, setup[k], s, counters);
        if (!ans.blocked)
            ++round.visible;
        else
            round.occluder_t = std::min(round.occluder_t, ans.occluder_t);
    }
    return round;
}

void Tracer::prefetch_tile_outputs(const OracleFrame& frame, int x0, int y0, int size) const {
    const int width = std::min(size, frame.width - x0);
    if (width <= 0) return;
    auto lines = [](const void* first, std::size_t bytes) {
        const char* p = static_cast<const char*>(first);
        for (std::size_t o = 0; o < bytes; o += 64) __builtin_prefetch(p + o, 1);
        __builtin_prefetch(p + bytes - 1, 1);  // the last line, where the span is not line-aligned
    };
    const auto w = static_cast<std::size_t>(width);
    for (int y = y0; y < std::min(y0 + size, frame.height); ++y) {
        const std::size_t i =
            static_cast<std::size_t>(y) * static_cast<std::size_t>(frame.width) + static_cast<std::size_t>(x0);
        lines(&frame.A[i], w * sizeof(float));
        lines(&frame.prim[i], w * sizeof(std::uint32_t));
        lines(&frame.depth[i], w * sizeof(float));
        lines(&frame.P[i], w * sizeof(glm::vec3));
        lines(&frame.N[i], w * sizeof(glm::vec3));
        for (std::size_t li = 0; li < lights_.size(); ++li) {
            if (lights_[li].sampled) continue;  // sampled later (area_pass.cpp)
            const OracleLightImage& img = frame.lights[li];
            for (const std::vector<float>* channel : {&img.V, &img.U, &img.lightable, &img.occluder_m})
                lines(&(*channel)[i], w * sizeof(float));
        }
    }
}

void Tracer::trace_tiles(OracleFrame& frame, int first, int last, int tiles_x, int tile, TraceCounters& counters,
                         std::vector<SurfacePoint>* surfaces) const {
    auto corner = [&](int t) { return glm::ivec2(t % tiles_x, t / tiles_x) * tile; };
    if (first < last) prefetch_tile_outputs(frame, corner(first).x, corner(first).y, tile);
    for (int t = first; t < last; ++t) {
        if (t + 1 < last) prefetch_tile_outputs(frame, corner(t + 1).x, corner(t + 1).y, tile);
        trace_tile(frame, corner(t).x, corner(t).y, tile, counters, surfaces);
    }
}

void Tracer::trace_tile(OracleFrame& frame, int x0, int y0, int size, TraceCounters& counters,
                        std::vector<SurfacePoint>* surfaces) const {
    const Camera& cam = camera_;
    const bool moved = camera_eye_ != glm::dvec3(0.0);  // a camera path's later frame
    const int W = frame.width, H = frame.height;
    const float znear = static_cast<float>(cam.znear);
    const float zfar = static_cast<float>(std::min(cam.zfar, 3.0e38));
    const PrimaryRays rays(cam, W, H);
    // Per-packet state lives for the whole tile and every per-pixel result is written in
    // place: zero-filled temporaries and struct copies per pixel (store-forwarding stalls) were
    // the largest part of the 15% this loop lost before (docs/history/oracle-speed.md).
    SurfacePoint surf[kPacket];
    ShadowSetup setup[kPacket];
    glm::dvec3 shadow_org[kPacket], shadow_dir[kPacket];  // the exact shadow rays, for cut-outs
    TraceCounters local;  // counted here, not through `counters`, which the compiler must assume aliases

    for (int by = y0; by < std::min(y0 + size, H); by += 4) {
        for (int bx = x0; bx < std::min(x0 + size, W); bx += 4) {
            alignas(64) RTCRayHit16 rh;
            alignas(64) int valid[kPacket];
            glm::dvec3 ray_dir[kPacket];
            glm::dvec3 ray_org[kPacket];
            int pixel[kPacket];
            for (int k = 0; k < kPacket; ++k) {
                int x = bx + (k & 3), y = by + (k >> 2);
                valid[k] = (x < W && y < H) ? -1 : 0;
                pixel[k] = valid[k] ? y * W + x : -1;
                PrimaryRay r = rays.at(x + 0.5, y + 0.5);
                if (moved) r.origin += camera_eye_;
                ray_dir[k] = r.direction;
                ray_org[k] = r.origin;
                set_lane(rh.ray, k, glm::vec3(r.origin), glm::vec3(r.direction), znear, zfar);
                rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
                local.primary += valid[k] != 0;
            }
            FilterContext coherent = make_context(this, true);
            if (cutouts_) {
                coherent.lane_org = ray_org;
                coherent.lane_dir = ray_dir;
            }
            intersect_active_lanes(valid, scene_.get(), &coherent.embree, rh, as_halves_);

            // The double vertices of the hit triangles are cache misses on large scenes: ask for
            // all lanes' indices first, so the misses overlap instead of queueing lane by lane.
            for (int k = 0; k < kPacket; ++k)
                if (valid[k] && rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID)
                    __builtin_prefetch(&tris_[rh.hit.primID[k]]);

            for (int k = 0; k < kPacket; ++k) {
                surf[k].hit = false;
                if (!valid[k] || rh.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) continue;
                std::uint32_t prim = rh.hit.primID[k];
                double t = rh.ray.tfar[k], u = rh.hit.u[k], v = rh.hit.v[k];
                glm::dvec3 n_ccw = normal_ccw(prim);
                // culled_for_camera, the facing test first: it needs no memory.
                if (glm::dot(n_ccw, ray_dir[k]) > 0 && !double_sided_[prim]) {
                    // Rare: re-trace this ray alone, culling the backs of single-sided surfaces.
                    FilterContext ctx = make_context(this, false);
                    ctx.embree.filter = &camera_cull_filter;
                    ctx.p = ray_org[k];
                    ctx.dir = ray_dir[k];
                    RTCRayHit one{};
                    set_ray(one.ray, glm::vec3(rh.ray.org_x[k], rh.ray.org_y[k], rh.ray.org_z[k]),
                            glm::vec3(rh.ray.dir_x[k], rh.ray.dir_y[k], rh.ray.dir_z[k]), znear, zfar);
                    one.hit.geomID = RTC_INVALID_GEOMETRY_ID;
                    rtcIntersect1(scene_.get(), &ctx.embree, &one);
                    ++local.culled;  // counted apart from the shadow rays re-judged in double
                    ++local.culled_by_node[prim < triangle_node_.size() ? triangle_node_[prim] : 0u];
                    if (ctx.ambiguous) coherent.ambiguous_lanes |= 1u << k;
                    if (one.hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
                    prim = one.hit.primID;
                    n_ccw = normal_ccw(prim);
                    t = one.ray.tfar;
                    u = one.hit.u;
                    v = one.hit.v;
                }
                primary_hit(prim, u, v, t, ray_org[k], ray_dir[k], n_ccw, surf[k]);
                surf[k].ambiguous = (coherent.ambiguous_lanes >> k) & 1u;
                const int i = pixel[k];
                frame.A[i] = 1.0f;
                frame.prim[i] = prim;
                frame.depth[i] = static_cast<float>(surf[k].depth);
                frame.P[i] = glm::vec3(surf[k].p);
                frame.N[i] = glm::vec3(surf[k].n);
                if (surfaces) (*surfaces)[static_cast<std::size_t>(i)] = surf[k];
            }

            for (std::size_t li = 0; li < lights_.size(); ++li) {
                if (lights_[li].sampled) continue;
                OracleLightImage& img = frame.lights[li];
                alignas(64) RTCRayHit16 sh;
                alignas(64) int svalid[kPacket];
                bool any = false;
                for (int k = 0; k < kPacket; ++k) {
                    svalid[k] = 0;
                    if (!surf[k].hit) continue;
                    ShadowSetup& st = setup[k];
                    setup_shadow(lights_[li], surf[k], st);
                    const int i = pixel[k];
                    img.lightable[i] = st.lightable ? 1.0f : 0.0f;
                    img.U[i] = st.ambiguous || surf[k].ambiguous ? 1.0f : 0.0f;
                    if (!st.lightable) continue;  // back-facing or outside the cone: V = 0, no ray
                    svalid[k] = -1;
                    any = true;
                    set_lane(sh.ray, k, st.origin, st.dir_f, 0.0f, st.tfar);
                    sh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
                    ++local.shadow;
                }
                if (!any) continue;
                // Closest hit, not any hit: the occluder distance is part of the answer (the
                // metrics measure peter-panning gaps with it).
                FilterContext shadow = make_context(this, true);
                if (cutouts_) {
                    for (int k = 0; k < kPacket; ++k) {
                        shadow_org[k] = surf[k].p;
                        shadow_dir[k] = setup[k].dir;
                    }
                    shadow.lane_org = shadow_org;
                    shadow.lane_dir = shadow_dir;
                }
                intersect_active_lanes(svalid, scene_.get(), &shadow.embree, sh, as_halves_);
                for (int k = 0; k < kPacket; ++k) {
                    if (!svalid[k]) continue;
                    const int i = pixel[k];
                    ShadowAnswer ans;
                    if (sh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID)  // most lanes miss: judge only hits
                        ans = judge_lane(sh, k, setup[k], surf[k], local);
                    img.V[i] = ans.blocked ? 0.0f : 1.0f;
                    img.occluder_m[i] = ans.blocked ? ans.occluder_t : kNoDistance;
                    if (ans.ambiguous || ((shadow.ambiguous_lanes >> k) & 1u)) img.U[i] = 1.0f;
                }
            }
        }
    }
    counters.primary += local.primary;
    counters.shadow += local.shadow;
    counters.retraced += local.retraced;
    counters.culled += local.culled;
    for (const auto& [node, n] : local.culled_by_node) counters.culled_by_node[node] += n;
}

}  // namespace penumbra::oracle_detail
