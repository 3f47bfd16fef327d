#include "raster/area_lights.h"

#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>

#include "common/light_sampling.h"

namespace penumbra::raster {

namespace {

// Radius of the disk with the light's emitting area (a sphere: its own radius).
double equivalent_radius(const Light& l) {
    if (l.type == LightType::rect) return std::sqrt(glm::length(glm::cross(l.u, l.v)) / std::numbers::pi);
    return l.radius;
}

// Point j of n spread over the light: a centred (0,2)-sequence on a rect or disk, a spherical
// Fibonacci point set on a sphere (seen from afar, the points of the far half project like
// those of the near cap, so their shadows average to the cap's).
glm::dvec3 spread_point(const Light& l, int j, int n) {
    const auto i = static_cast<std::uint32_t>(j);
    const double s = std::fmod(sobol_dim0(i) * 0x1p-32 + 0.5 / n, 1.0);
    const double t = std::fmod(sobol_dim1(i) * 0x1p-32 + 0.5 / n, 1.0);
    switch (l.type) {
        case LightType::rect: return l.position + (s - 0.5) * l.u + (t - 0.5) * l.v;
        case LightType::disk: {
            glm::dvec3 e1, e2;
            orthonormal_basis(glm::normalize(l.normal), e1, e2);
            glm::dvec2 d = concentric_disk(s, t);
            return l.position + l.radius * (d.x * e1 + d.y * e2);
        }
        default: {
            const double z = 1.0 - (2.0 * j + 1.0) / n;
            const double phi = j * std::numbers::pi * (3.0 - std::sqrt(5.0));
            const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
            return l.position + l.radius * glm::dvec3(r * std::cos(phi), z, r * std::sin(phi));
        }
    }
}

}  // namespace

ExpandedLights expand_area_lights(const std::vector<Light>& lights, const Technique& technique) {
    ExpandedLights e;
    for (const Light& l : lights) {
        e.first.push_back(e.lights.size());
        if (!is_area_light(l.type)) {
            e.lights.push_back(l);
            e.count.push_back(1);
            continue;
        }
        Light point = l;
        point.type = LightType::point;
        point.radius = equivalent_radius(l);
        const int n = technique.area_samples;
        if (n == 0) {
            e.lights.push_back(point);
        } else {
            for (int j = 0; j < n; ++j) {
                point.position = spread_point(l, j, n);
                e.lights.push_back(point);
            }
        }
        e.count.push_back(static_cast<std::size_t>(std::max(n, 1)));
    }
    return e;
}

Technique expand_light_overrides(const ExpandedLights& expanded, const Technique& technique) {
    Technique t = technique;
    if (technique.lights.empty()) return t;
    t.lights.clear();
    for (std::size_t i = 0; i < expanded.first.size(); ++i)
        t.lights.insert(t.lights.end(), expanded.count[i],
                        i < technique.lights.size() ? technique.lights[i] : LightOverride{});
    return t;
}

RasterResult fold_area_lights(const ExpandedLights& expanded, RasterResult drawn) {
    if (expanded.lights.size() == expanded.first.size()) return drawn;  // nothing was expanded
    RasterResult out;
    out.frame.width = drawn.frame.width;
    out.frame.height = drawn.frame.height;
    out.frame.frame_origin = drawn.frame.frame_origin;
    out.frame.A = std::move(drawn.frame.A);
    out.frame.prim = std::move(drawn.frame.prim);
    const std::vector<RasterLightStats> drawn_lights = std::move(drawn.stats.lights);
    out.stats = std::move(drawn.stats);
    out.stats.lights.clear();
    for (std::size_t li = 0; li < expanded.first.size(); ++li) {
        const std::size_t first = expanded.first[li], n = expanded.count[li];
        RasterLightImage img = std::move(drawn.frame.lights[first]);
        RasterLightStats ls = drawn_lights[first];
        for (std::size_t j = first + 1; j < first + n; ++j) {
            const RasterLightImage& other = drawn.frame.lights[j];
            for (std::size_t i = 0; i < img.V.size(); ++i) {
                img.V[i] += other.V[i];
                // Back-facing only where every point is behind the receiver's tangent plane.
                if (img.lookups && other.lookups && !(other.lookups->flags[i] & kRasterBackFacing))
                    img.lookups->flags[i] &= ~kRasterBackFacing;
            }
            const RasterLightStats& o = drawn_lights[j];
            ls.layers_sampled |= o.layers_sampled;
            ls.layers_rendered += o.layers_rendered;
            ls.shadow_ms += o.shadow_ms;
            ls.lookup_ms += o.lookup_ms;
        }
        if (n > 1)
            for (float& v : img.V) v /= static_cast<float>(n);
        out.frame.lights.push_back(std::move(img));
        out.stats.lights.push_back(std::move(ls));
    }
    return out;
}

}  // namespace penumbra::raster
