#include "common/alpha_coverage.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <glm/vec3.hpp>

#include "common/errors.h"

namespace penumbra {

namespace {
std::atomic<AlphaImageDecoder> registered_decoder{nullptr};
}

void set_alpha_image_decoder(AlphaImageDecoder decoder) {
    registered_decoder.store(decoder);
}

AlphaImageDecoder alpha_image_decoder() {
    const AlphaImageDecoder d = registered_decoder.load();
    if (!d) throw EnvironmentError("this program cannot decode images: it was built without penumbra's image module");
    return d;
}

namespace {

// Texel index i wrapped into [0, size) (Vulkan 1.3 section 16.9.1, "Wrapping Operation").
int wrap_texel(long long i, int size, TextureWrap wrap) {
    switch (wrap) {
        case TextureWrap::clamp_to_edge: return static_cast<int>(std::clamp<long long>(i, 0, size - 1));
        case TextureWrap::mirrored_repeat: {
            const long long period = 2ll * size;
            long long t = i % period;
            if (t < 0) t += period;
            return static_cast<int>(t < size ? t : period - 1 - t);
        }
        case TextureWrap::repeat: break;
    }
    long long t = i % size;
    return static_cast<int>(t < 0 ? t + size : t);
}

// A texel index from a coordinate; out-of-range doubles (uv of 1e30) saturate instead of
// overflowing, and wrap to a texel like any other.
long long floor_index(double x) {
    constexpr double kLimit = 4.0e18;
    return static_cast<long long>(std::floor(std::clamp(x, -kLimit, kLimit)));
}

glm::dvec2 transformed(const CutoutMaterial& m, glm::dvec2 uv) {
    return glm::dvec2(m.uv_transform * glm::dvec3(uv, 1.0));
}

// Sampling after uv_transform: the texel grid the reach is measured in.
double sample_transformed(const AlphaTexture& t, const CutoutMaterial& m, glm::dvec2 uv) {
    const double x = uv.x * t.width, y = uv.y * t.height;
    auto texel = [&](long long i, long long j) {
        const int tx = wrap_texel(i, t.width, m.wrap_s), ty = wrap_texel(j, t.height, m.wrap_t);
        return t.at(static_cast<std::size_t>(ty) * static_cast<std::size_t>(t.width) + static_cast<std::size_t>(tx));
    };
    if (m.nearest) return texel(floor_index(x), floor_index(y));
    const double xs = x - 0.5, ys = y - 0.5;
    const long long i0 = floor_index(xs), j0 = floor_index(ys);
    const double fx = xs - std::floor(xs), fy = ys - std::floor(ys);
    const double top = (1 - fx) * texel(i0, j0) + fx * texel(i0 + 1, j0);
    const double bottom = (1 - fx) * texel(i0, j0 + 1) + fx * texel(i0 + 1, j0 + 1);
    return (1 - fy) * top + fy * bottom;
}

double coverage_transformed(const CutoutMaterial& m, const AlphaTexture* texture, glm::dvec2 uv, double vertex_alpha) {
    double c = m.factor_alpha * vertex_alpha;
    if (texture) c *= sample_transformed(*texture, m, uv);
    return c;
}

}  // namespace

double sample_alpha(const AlphaTexture& texture, const CutoutMaterial& m, glm::dvec2 uv) {
    return sample_transformed(texture, m, transformed(m, uv));
}

double coverage_at(const CutoutMaterial& m, const AlphaTexture* texture, glm::dvec2 uv, double vertex_alpha) {
    return coverage_transformed(m, texture, transformed(m, uv), vertex_alpha);
}

CoverageAnswer judge_coverage(const CutoutMaterial& m, const AlphaTexture* texture, glm::dvec2 uv, double vertex_alpha,
                              double reach_texels) {
    const glm::dvec2 at = transformed(m, uv);
    const double c = coverage_transformed(m, texture, at, vertex_alpha);
    CoverageAnswer a;
    a.opaque = c >= m.cutoff;
    // On the contour itself (a constant coverage equal to the cutoff, or a bilinear ramp through
    // it): the answer turns on the last bit of the coverage.
    a.ambiguous = std::abs(c - m.cutoff) <= 1e-12;
    if (!texture || a.ambiguous) return a;
    const glm::dvec2 reach(reach_texels / texture->width, reach_texels / texture->height);
    for (const glm::dvec2 corner : {glm::dvec2(-1, -1), glm::dvec2(1, -1), glm::dvec2(-1, 1), glm::dvec2(1, 1)})
        if ((coverage_transformed(m, texture, at + corner * reach, vertex_alpha) >= m.cutoff) != a.opaque) {
            a.ambiguous = true;
            break;
        }
    return a;
}

}  // namespace penumbra
