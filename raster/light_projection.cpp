#include "raster/light_projection.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <span>

#include "common/camera.h"
#include "common/errors.h"

namespace penumbra::raster {

namespace {

struct Basis {
    glm::dvec3 right, up, forward;
};

// A light view looking along `forward`, with an up hint that is never parallel to it.
Basis light_basis(const glm::dvec3& forward) {
    glm::dvec3 hint = std::abs(forward.y) < 0.99 ? glm::dvec3(0, 1, 0) : glm::dvec3(1, 0, 0);
    glm::dvec3 right = glm::normalize(glm::cross(forward, hint));
    return {right, glm::cross(right, forward), forward};
}

// Orthographic clip matrix: x, y from the box's [lo, hi] to [-1, 1], depth along forward
// from [znear, zfar] to [0, 1]. Coordinates are relative to `origin`.
glm::dmat4 ortho_matrix(const Basis& b, glm::dvec3 lo, glm::dvec3 hi, const glm::dvec3& origin) {
    glm::dmat4 m(0.0);
    glm::dvec3 sx = b.right * (2.0 / (hi.x - lo.x)), sy = b.up * (2.0 / (hi.y - lo.y)),
               sz = b.forward * (1.0 / (hi.z - lo.z));
    // Row i of the matrix: clip_i = dot(s_i, p_rel + origin) + t_i.
    double tx = glm::dot(sx, origin) - (hi.x + lo.x) / (hi.x - lo.x);
    double ty = glm::dot(sy, origin) - (hi.y + lo.y) / (hi.y - lo.y);
    double tz = glm::dot(sz, origin) - lo.z / (hi.z - lo.z);
    for (int c = 0; c < 3; ++c) {
        m[c][0] = sx[c];
        m[c][1] = sy[c];
        m[c][2] = sz[c];
    }
    m[3] = glm::dvec4(tx, ty, tz, 1.0);
    return m;
}

// Perspective clip matrix (depth 0 at near, 1 at far) of a view at `eye` with a square
// frustum of half-angle tangent `t`.
glm::dmat4 perspective_matrix(const Basis& b, const glm::dvec3& eye_rel, double t, double near, double far) {
    // View coordinates: x = right.(p - eye), y = up.(p - eye), f = forward.(p - eye).
    // clip = (x / t, y / t, far (f - near) / (far - near), f).
    glm::dmat4 m(0.0);
    double a = far / (far - near);
    for (int c = 0; c < 3; ++c) {
        m[c][0] = b.right[c] / t;
        m[c][1] = b.up[c] / t;
        m[c][2] = b.forward[c] * a;
        m[c][3] = b.forward[c];
    }
    m[3][0] = -glm::dot(b.right, eye_rel) / t;
    m[3][1] = -glm::dot(b.up, eye_rel) / t;
    m[3][2] = -glm::dot(b.forward, eye_rel) * a - a * near;
    m[3][3] = -glm::dot(b.forward, eye_rel);
    return m;
}

std::array<glm::dvec3, 8> box_corners(const Bounds& b) {
    std::array<glm::dvec3, 8> c;
    for (int i = 0; i < 8; ++i)
        c[i] = glm::dvec3(i & 1 ? b.hi.x : b.lo.x, i & 2 ? b.hi.y : b.lo.y, i & 4 ? b.hi.z : b.lo.z);
    return c;
}

double distance_to_box(const glm::dvec3& p, const Bounds& b) {
    glm::dvec3 d = glm::max(glm::max(b.lo - p, p - b.hi), glm::dvec3(0.0));
    return glm::length(d);
}

// The camera frustum's eight corners, far plane pulled in to the scene's extent.
std::vector<glm::dvec3> camera_frustum_corners(const Camera& cam, int w, int h, const Bounds& scene,
                                               double shadow_distance) {
    double zf = std::min(cam.zfar, farthest_along(scene, cam.eye, cam.forward));
    if (shadow_distance > 0) zf = std::min(zf, shadow_distance);
    double zn = cam.znear;
    zf = std::max(zn * 1.0001, zf);
    glm::dvec2 plane = ndc_to_image_plane(cam, w, h);
    bool persp = cam.type == ProjectionType::perspective;
    std::vector<glm::dvec3> out;
    for (double z : {zn, zf}) {
        glm::dvec3 centre = cam.eye + cam.forward * z;
        glm::dvec2 half = persp ? plane * z : plane;
        for (int i = 0; i < 4; ++i)
            out.push_back(centre + cam.right * (i & 1 ? half.x : -half.x) + cam.up * (i & 2 ? half.y : -half.y));
    }
    return out;
}

LightProjection fit_directional(const Light& light, const Scene& scene, const Camera& cam, int w, int h, Fit fit,
                                int res, const glm::dvec3& origin, double shadow_distance) {
    LightProjection lp;
    Basis b = light_basis(light.direction);
    auto to_light_space = [&](const glm::dvec3& p) {
        return glm::dvec3(glm::dot(p, b.right), glm::dot(p, b.up), glm::dot(p, b.forward));
    };
    glm::dvec3 lo(1e300), hi(-1e300);
    auto grow = [&](const glm::dvec3& p) {
        glm::dvec3 q = to_light_space(p);
        lo = glm::min(lo, q);
        hi = glm::max(hi, q);
    };
    switch (fit) {
        case Fit::scene_sphere: {  // reference 000: the bounding sphere of the scene
            glm::dvec3 c = to_light_space(scene.bounds.center());
            double r = scene.bounds.radius();
            lo = c - r;
            hi = c + r;
            break;
        }
        case Fit::scene_bounds:  // reference 002: tight box of every vertex in light space
            for (const auto& p : scene.positions) grow(p);
            break;
        case Fit::camera_frustum: {  // reference 004: the camera frustum's corners
            for (const auto& p : camera_frustum_corners(cam, w, h, scene.bounds, shadow_distance)) grow(p);
            // Casters between the light and the frustum must still land in the map: pull the
            // near plane back to the scene (depth clamp would flatten them, not drop them).
            double lo_z = lo.z;
            for (const auto& p : box_corners(scene.bounds)) lo_z = std::min(lo_z, to_light_space(p).z);
            lo.z = lo_z;
            break;
        }
    }
    // A flat scene seen edge-on by its box still needs a non-empty volume.
    double span = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, 1e-9 * std::max(1.0, glm::length(hi))});
    for (int a = 0; a < 3; ++a)
        if (hi[a] - lo[a] < 1e-6 * span) {
            double pad = 0.5e-3 * span;
            lo[a] -= pad;
            hi[a] += pad;
        }
    lp.view_proj.push_back(ortho_matrix(b, lo, hi, origin));
    lp.axis.push_back(b.forward);
    lp.half_extent = glm::dvec2(hi.x - lo.x, hi.y - lo.y) * 0.5;
    lp.metres_per_texel = std::max(hi.x - lo.x, hi.y - lo.y) / res;
    lp.near = 0;
    lp.far = hi.z - lo.z;
    return lp;
}

// Least depth along b.forward of the part of `box` inside the square frustum of half-angle
// tangent `t` at `eye`, or nothing where the frustum misses the box. The least depth of that
// convex intersection lies on a box face clipped to the frustum's four side planes.
std::optional<double> least_depth_in_frustum(const Bounds& box, const glm::dvec3& eye, const Basis& b, double t) {
    const std::array<glm::dvec3, 8> corners = box_corners(box);
    std::array<glm::dvec3, 8> v;  // view coordinates: right, up, depth
    for (int i = 0; i < 8; ++i) {
        const glm::dvec3 d = corners[i] - eye;
        v[i] = glm::dvec3(glm::dot(d, b.right), glm::dot(d, b.up), glm::dot(d, b.forward));
    }
    // Box faces by corner index (bit 0: x, bit 1: y, bit 2: z), each a loop of four corners.
    constexpr int kFaces[6][4] = {{0, 2, 6, 4}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 5, 7, 6}};
    // Inside where every plane's value is >= 0: t z -+ x, t z -+ y.
    auto plane = [t](int k, const glm::dvec3& p) {
        const double side = k < 2 ? p.x : p.y;
        return t * p.z + ((k & 1) ? side : -side);
    };
    std::optional<double> least;
    std::vector<glm::dvec3> poly, clipped;
    for (const auto& face : kFaces) {
        poly.assign({v[face[0]], v[face[1]], v[face[2]], v[face[3]]});
        for (int k = 0; k < 4 && !poly.empty(); ++k) {  // Sutherland-Hodgman
            clipped.clear();
            for (std::size_t i = 0; i < poly.size(); ++i) {
                const glm::dvec3 &a = poly[i], &c = poly[(i + 1) % poly.size()];
                const double da = plane(k, a), dc = plane(k, c);
                if (da >= 0) clipped.push_back(a);
                if ((da >= 0) != (dc >= 0)) clipped.push_back(a + (c - a) * (da / (da - dc)));
            }
            poly.swap(clipped);
        }
        for (const auto& p : poly) least = std::min(least.value_or(p.z), p.z);
    }
    return least;
}

// Near and far planes of a perspective light whose layers look along `bases` with half-angle
// tangent `t`: far beyond the box's farthest corner, near at the least depth along a layer's
// axis of the box inside that layer's frustum. The Euclidean distance to the box is larger
// than that depth off axis and put the box's edges in front of the near plane (lit).
void perspective_range(const glm::dvec3& pos, const Scene& scene, std::span<const Basis> bases, double t,
                       LightProjection& lp) {
    double far = 0;
    for (const auto& c : box_corners(scene.bounds)) far = std::max(far, glm::length(c - pos));
    far *= 1.001;
    lp.far = std::max(far, 1e-6);
    const double floor = lp.far * 5e-4;  // the light inside or at the box: precision decides
    std::optional<double> near;
    if (distance_to_box(pos, scene.bounds) > 0)
        for (const Basis& b : bases)
            if (auto d = least_depth_in_frustum(scene.bounds, pos, b, t)) near = std::min(near.value_or(*d), *d);
    lp.near = std::max(near.value_or(floor), floor);
}

}  // namespace

LightProjection fit_for_technique(const Light& light, const Scene& scene, const Camera& camera, int image_width,
                                  int image_height, const Technique& t, const glm::dvec3& origin,
                                  const std::optional<glm::dvec2>& samples) {
    if (const Cascades* c = light.type == LightType::directional ? cascades_of(t) : nullptr)
        return fit_cascades(light, scene, camera, image_width, image_height, *c, t.resolution, origin, samples);
    return fit_light(light, scene, camera, image_width, image_height, t.fit, t.resolution, origin, t.shadow_distance);
}

void round_to_world_float32(LightProjection& lp, const glm::dvec3& origin) {
    glm::dmat4 to_world(1.0);
    to_world[3] = glm::dvec4(origin, 1.0);
    for (auto& m : lp.view_proj) m = glm::dmat4(glm::mat4(m)) * to_world;
}

const char* to_string(ViewKind k) {
    static const char* const kNames[] = {"ortho", "perspective", "cube_face", "cascade"};
    return kNames[static_cast<int>(k)];
}

std::vector<ShadowView> shadow_views(const LightProjection& lp) {
    static const char* const kFaces[] = {"+x", "-x", "+y", "-y", "+z", "-z"};
    const bool cube = lp.perspective && lp.view_proj.size() == 6;
    const bool cascades = !lp.cascade_texel.empty();
    std::vector<ShadowView> views;
    for (std::size_t k = 0; k < lp.view_proj.size(); ++k) {
        ShadowView v;
        v.kind = cascades         ? ViewKind::cascade
                 : cube           ? ViewKind::cube_face
                 : lp.perspective ? ViewKind::perspective
                                  : ViewKind::ortho;
        if (cube) v.name = kFaces[k];
        v.view_proj = lp.view_proj[k];
        v.axis = lp.axis[k];
        v.metres_per_texel = cascades ? lp.cascade_texel[k] : lp.metres_per_texel;
        v.metres_per_texel_per_metre = lp.metres_per_texel_per_metre;
        v.near = lp.near;
        v.far = lp.far;
        v.half_extent = cascades ? lp.cascade_half_extent[k] : lp.half_extent;
        if (cascades) {
            v.split_near = lp.cascade_near[k];
            v.split_far = lp.cascade_far[k];
        }
        views.push_back(v);
    }
    return views;
}

LightProjection fit_cascades(const Light& light, const Scene& scene, const Camera& cam, int w, int h, const Cascades& c,
                             int res, const glm::dvec3& origin, const std::optional<glm::dvec2>& samples) {
    const bool infinite = !std::isfinite(cam.zfar) || cam.zfar >= 1e30;
    if (!c.max_distance && infinite)
        throw InputError(
            "technique.cascades.max_distance: the camera's zfar is infinite; give the cascades a max_distance "
            "(metres of view depth)");
    const double near = cam.znear, far = c.max_distance.value_or(cam.zfar);
    if (!(far > near))
        throw InputError(
            fmt::format("technique.cascades.max_distance: {} m is not beyond the camera's znear {} m", far, near));
    if (c.split == CascadeSplit::geometric && c.first_far && !(*c.first_far > near && *c.first_far < far))
        throw InputError(
            fmt::format("technique.cascades.first_far: {} m is not between the camera's znear {} m and "
                        "the cascades' far end {} m",
                        *c.first_far, near, far));
    if ((c.split == CascadeSplit::log || c.split == CascadeSplit::practical) && !(near > 0))
        throw InputError(fmt::format("technique.cascades.split: \"{}\" needs a camera znear > 0 (it is {})",
                                     to_string(c.split), near));
    LightProjection lp;
    double first_near = near;
    std::vector<double> bounds;
    if (samples) {
        // SDSM: the visible range, a hundredth wider each way, within the camera's.
        const double pad = 0.01 * std::max(0.0, samples->y - samples->x) + 1e-4 * std::abs(samples->y);
        const double lo = std::clamp(samples->x - pad, near, far), hi = std::clamp(samples->y + pad, lo, far);
        bounds = sdsm_far_bounds(c, near, far, lo, hi);
        first_near = lo;
        lp.sdsm_range = glm::dvec2(lo, bounds.back());
    } else {
        bounds = cascade_far_bounds(c, near, far);
    }
    lp.cascade_overlap = c.overlap;
    Basis b = light_basis(light.direction);
    auto to_light_space = [&](const glm::dvec3& p) {
        return glm::dvec3(glm::dot(p, b.right), glm::dot(p, b.up), glm::dot(p, b.forward));
    };
    // Casters between a slice and the light: the near plane pulled back to the scene.
    double scene_lo_z = 1e300;
    for (const auto& p : box_corners(scene.bounds)) scene_lo_z = std::min(scene_lo_z, to_light_space(p).z);
    const glm::dvec2 plane = ndc_to_image_plane(cam, w, h);
    const bool persp = cam.type == ProjectionType::perspective;
    for (int i = 0; i < c.count; ++i) {
        // bevy's overlap: a cascade starts that fraction before the previous one ends.
        const double zn = i == 0 ? first_near : (1 - c.overlap) * bounds[i - 1], zf = bounds[i];
        std::array<glm::dvec3, 8> corners;
        for (int k = 0; k < 8; ++k) {
            const double z = k & 4 ? zf : zn;
            const glm::dvec2 half = persp ? plane * z : plane;
            corners[k] = cam.eye + cam.forward * z + cam.right * (k & 1 ? half.x : -half.x) +
                         cam.up * (k & 2 ? half.y : -half.y);
        }
        glm::dvec3 lo(1e300), hi(-1e300);
        double texel = 0;
        if (c.fit == CascadeFit::sphere) {
            // The slice's bounding sphere: its radius depends on the slice alone, not on where the
            // camera looks, so the texel size stays constant (what stabilisation needs). Rounded
            // up to 1/16 m so that rounding noise does not change it between frames.
            glm::dvec3 centre(0.0);
            for (const auto& p : corners) centre += p / 8.0;
            double r = 0;
            for (const auto& p : corners) r = std::max(r, glm::length(p - centre));
            r = std::ceil(r * 16) / 16;
            const glm::dvec3 cl = to_light_space(centre);
            lo = cl - r;
            hi = cl + r;
            texel = 2 * r / res;
            if (c.stabilize) {
                lo.x = std::floor(lo.x / texel) * texel;
                lo.y = std::floor(lo.y / texel) * texel;
                hi.x = lo.x + 2 * r;
                hi.y = lo.y + 2 * r;
            }
        } else {
            for (const auto& p : corners) {
                lo = glm::min(lo, to_light_space(p));
                hi = glm::max(hi, to_light_space(p));
            }
            texel = std::max({hi.x - lo.x, hi.y - lo.y, 1e-9}) / res;
            if (c.stabilize) {  // whole texels of this frame's size: the size itself moves with the view
                lo.x = std::floor(lo.x / texel) * texel;
                lo.y = std::floor(lo.y / texel) * texel;
                const double side = std::ceil(std::max(hi.x - lo.x, hi.y - lo.y) / texel) * texel;
                hi.x = lo.x + side;
                hi.y = lo.y + side;
                texel = side / res;
            }
        }
        lo.z = std::min(lo.z, scene_lo_z);
        if (hi.z - lo.z < 1e-6) hi.z = lo.z + 1e-6;
        lp.view_proj.push_back(ortho_matrix(b, lo, hi, origin));
        lp.axis.push_back(b.forward);
        lp.cascade_texel.push_back(std::max(hi.x - lo.x, hi.y - lo.y) / res);
        lp.cascade_near.push_back(zn);
        lp.cascade_far.push_back(zf);
        lp.cascade_origin.emplace_back(lo.x, lo.y);
        lp.cascade_half_extent.push_back(glm::dvec2(hi.x - lo.x, hi.y - lo.y) * 0.5);
        lp.cascade_depth_range.push_back(hi.z - lo.z);
        lp.far = std::max(lp.far, hi.z - lo.z);
    }
    lp.metres_per_texel = lp.cascade_texel.front();
    lp.half_extent = lp.cascade_half_extent.front();
    return lp;
}

glm::dvec2 cascade_bias_scale(const LightProjection& lp, std::size_t k, bool texel_scaled) {
    if (!texel_scaled || k >= lp.cascade_texel.size() || k >= lp.cascade_depth_range.size()) return {1.0, 1.0};
    const double texel = lp.cascade_texel[k] / lp.cascade_texel[0];
    return {texel, texel * lp.cascade_depth_range[0] / lp.cascade_depth_range[k]};
}

double farthest_along(const Bounds& box, const glm::dvec3& eye, const glm::dvec3& axis) {
    double far = -1e300;
    for (const auto& c : box_corners(box)) far = std::max(far, glm::dot(c - eye, axis));
    return far;
}

LightProjection fit_light(const Light& light, const Scene& scene, const Camera& camera, int image_width,
                          int image_height, Fit fit, int resolution, const glm::dvec3& origin, double shadow_distance) {
    if (light.type == LightType::directional)
        return fit_directional(light, scene, camera, image_width, image_height, fit, resolution, origin,
                               shadow_distance);

    LightProjection lp;
    lp.perspective = true;
    glm::dvec3 eye_rel = light.position - origin;
    if (light.type == LightType::spot) {
        constexpr double kMaxHalfAngle = 80.0 * 3.14159265358979323846 / 180.0;
        double half = light.outer_cone_rad;
        if (half > kMaxHalfAngle) {
            lp.warnings.push_back(fmt::format(
                "{}: a {:.1f} degree cone does not fit one perspective map; the map covers 80 degrees and lookups "
                "outside it read as lit",
                light.origin, half * 360.0 / 3.14159265358979323846));
            half = kMaxHalfAngle;
        }
        double t = std::tan(half);
        Basis b = light_basis(light.direction);
        perspective_range(light.position, scene, std::span(&b, 1), t, lp);
        lp.view_proj.push_back(perspective_matrix(b, eye_rel, t, lp.near, lp.far));
        lp.axis.push_back(b.forward);
        lp.metres_per_texel_per_metre = 2.0 * t / resolution;
        return lp;
    }
    // Point light: six exact 90-degree faces.
    const glm::dvec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    std::array<Basis, 6> faces;
    for (int i = 0; i < 6; ++i) {
        const glm::dvec3& f = axes[i];
        glm::dvec3 up = std::abs(f.y) > 0.5 ? glm::dvec3(0, 0, 1) : glm::dvec3(0, 1, 0);
        faces[i] = {glm::cross(f, up), up, f};
    }
    perspective_range(light.position, scene, faces, 1.0, lp);
    for (const Basis& b : faces) {
        lp.view_proj.push_back(perspective_matrix(b, eye_rel, 1.0, lp.near, lp.far));
        lp.axis.push_back(b.forward);
    }
    lp.metres_per_texel_per_metre = 2.0 / resolution;
    return lp;
}

}  // namespace penumbra::raster
