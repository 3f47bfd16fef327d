#include "metrics/perceptual.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <utility>

namespace penumbra::metrics {

namespace {

using Kernel = std::vector<float>;  // odd length, centre in the middle

int kernel_radius(double sigma) {
    return std::max(1, static_cast<int>(std::ceil(3.0 * sigma)));
}

// Gaussian (order 0, sums to 1) or its first/second derivative (positive weights sum to 1,
// as FLIP normalises its feature kernels).
Kernel gaussian_kernel(double sigma, int order) {
    const int r = kernel_radius(sigma);
    Kernel k(static_cast<std::size_t>(2 * r + 1));
    for (int x = -r; x <= r; ++x) {
        const double g = std::exp(-0.5 * x * x / (sigma * sigma));
        const double v = order == 0 ? g : order == 1 ? -x * g : (x * x / (sigma * sigma) - 1.0) * g;
        k[static_cast<std::size_t>(x + r)] = static_cast<float>(v);
    }
    if (order == 2) {  // zero mean, so flat regions give no point response
        double mean = 0;
        for (float v : k) mean += v;
        mean /= static_cast<double>(k.size());
        for (float& v : k) v -= static_cast<float>(mean);
    }
    double norm = 0;
    for (float v : k) norm += order == 0 ? v : std::max(0.0f, v);
    for (float& v : k) v = static_cast<float>(v / norm);
    return k;
}

// One separable pass over rows [y0, y1) with clamp-to-edge borders.
void convolve_x(const std::vector<float>& in, std::vector<float>& out, int W, int y0, int y1, const Kernel& k) {
    const int r = static_cast<int>(k.size() / 2);
    tbb::parallel_for(y0, y1, [&](int y) {
        const float* row = in.data() + static_cast<std::size_t>(y) * W;
        float* dst = out.data() + static_cast<std::size_t>(y) * W;
        for (int x = 0; x < W; ++x) {
            float acc = 0;
            if (x >= r && x + r < W) {
                for (int j = -r; j <= r; ++j) acc += k[static_cast<std::size_t>(j + r)] * row[x + j];
            } else {
                for (int j = -r; j <= r; ++j)
                    acc += k[static_cast<std::size_t>(j + r)] * row[std::clamp(x + j, 0, W - 1)];
            }
            dst[x] = acc;
        }
    });
}

void convolve_y(const std::vector<float>& in, std::vector<float>& out, int W, int H, int y0, int y1, const Kernel& k) {
    const int r = static_cast<int>(k.size() / 2);
    tbb::parallel_for(y0, y1, [&](int y) {
        float* dst = out.data() + static_cast<std::size_t>(y) * W;
        std::fill(dst, dst + W, 0.0f);
        for (int j = -r; j <= r; ++j) {
            const float w = k[static_cast<std::size_t>(j + r)];
            const float* src = in.data() + static_cast<std::size_t>(std::clamp(y + j, 0, H - 1)) * W;
            for (int x = 0; x < W; ++x) dst[x] += w * src[x];
        }
    });
}

float lightness(float Y) {  // CIE L* / 100 of luminance Y in [0, 1]
    const float t = std::clamp(Y, 0.0f, 1.0f);
    const float f = t > 0.008856f ? std::cbrt(t) : 7.787f * t + 16.0f / 116.0f;
    return (116.0f * f - 16.0f) / 100.0f;
}

// The filters' reach: the rows a pixel's error reads beyond its own.
struct Kernels {
    Kernel csf, g0, g1, g2;
    int reach = 0;
    explicit Kernels(double ppd) {
        const double sigma_csf = ppd * std::sqrt(0.0047 / (2.0 * std::numbers::pi * std::numbers::pi));
        const double sigma_feature = 0.5 * 0.082 * ppd;
        csf = gaussian_kernel(sigma_csf, 0);
        g0 = gaussian_kernel(sigma_feature, 0);
        g1 = gaussian_kernel(sigma_feature, 1);
        g2 = gaussian_kernel(sigma_feature, 2);
        reach = static_cast<int>(std::max(csf.size(), g0.size()) / 2);
    }
};

// One picture's filtered lightness and features on the output rows [b0, b1) of a band of Hb
// input rows (its first row `first` of the picture). A band's edges are the image's edges or
// lie beyond every kernel's reach, so clamping at them gives the same values as at the image's:
// a row comes out bit for bit the same from any band that holds it, the whole image included.
struct Filtered {
    // Band-sized, rows outside [b0, b1) unset: the lightness after the contrast-sensitivity
    // filter, and the gradient magnitudes of the first and second derivatives.
    std::vector<float> lightness, edge, point;
};

Filtered filter_picture(const std::vector<float>& picture, int first, int W, int Hb, int b0, int b1, const Kernels& k) {
    const std::size_t nb = static_cast<std::size_t>(W) * Hb;
    const std::vector<float> Y(picture.begin() + static_cast<std::ptrdiff_t>(first) * W,
                               picture.begin() + static_cast<std::ptrdiff_t>(first + Hb) * W);
    Filtered f;
    {
        std::vector<float> h(nb);
        f.lightness.resize(nb);
        convolve_x(Y, h, W, 0, Hb, k.csf);
        convolve_y(h, f.lightness, W, Hb, b0, b1, k.csf);
        tbb::parallel_for(b0, b1, [&](int y) {
            for (int x = 0; x < W; ++x) {
                const std::size_t i = static_cast<std::size_t>(y) * W + x;
                f.lightness[i] = lightness(f.lightness[i]);
            }
        });
    }
    std::vector<float> l(nb), h0(nb), h1(nb), h2(nb), a(nb), b(nb);
    tbb::parallel_for(0, Hb, [&](int y) {
        for (int x = 0; x < W; ++x)
            l[static_cast<std::size_t>(y) * W + x] = lightness(Y[static_cast<std::size_t>(y) * W + x]);
    });
    convolve_x(l, h0, W, 0, Hb, k.g0);
    convolve_x(l, h1, W, 0, Hb, k.g1);
    convolve_x(l, h2, W, 0, Hb, k.g2);
    // |(d/dx, d/dy)| of one derivative order, from its x and y separable halves.
    auto magnitude = [&](const std::vector<float>& hx, const Kernel& kx, const std::vector<float>& hy,
                         const Kernel& ky) {
        std::vector<float> m(nb);
        convolve_y(hx, a, W, Hb, b0, b1, kx);
        convolve_y(hy, b, W, Hb, b0, b1, ky);
        tbb::parallel_for(b0, b1, [&](int y) {
            for (std::size_t i = static_cast<std::size_t>(y) * W; i < static_cast<std::size_t>(y + 1) * W; ++i)
                m[i] = std::hypot(a[i], b[i]);
        });
        return m;
    };
    f.edge = magnitude(h1, k.g0, h0, k.g1);
    f.point = magnitude(h2, k.g0, h0, k.g2);
    return f;
}

// The rows [first, last] where the pictures differ; last < 0 when they are equal.
std::pair<int, int> differing_rows(const std::vector<float>& reference, const std::vector<float>& test, int W, int H) {
    int first = H, last = -1;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x)
            if (reference[static_cast<std::size_t>(y) * W + x] != test[static_cast<std::size_t>(y) * W + x]) {
                first = std::min(first, y);
                last = y;
                break;
            }
    return {first, last};
}

// Only rows near a difference can score above zero; the rest keep 0 and cost nothing. The
// reference's filtered rows come from `reference` (its rows from `ref_first` on) when given,
// else they are filtered here from the band alone.
std::vector<float> error_image(const std::vector<float>& reference_picture, const Filtered* reference, int ref_first,
                               const std::vector<float>& test, int W, int H, const Kernels& k) {
    const std::size_t n = static_cast<std::size_t>(W) * H;
    std::vector<float> err(n, 0.0f);
    const auto [first, last] = differing_rows(reference_picture, test, W, H);
    if (last < 0) return err;
    // Output rows [y0, y1) need input rows one kernel further; intermediate rows another.
    const int y0 = std::max(0, first - k.reach), y1 = std::min(H, last + k.reach + 1);
    const int in0 = std::max(0, y0 - k.reach), in1 = std::min(H, y1 + k.reach);
    const int Hb = in1 - in0, b0 = y0 - in0, b1 = y1 - in0;
    Filtered own;
    if (!reference) {
        own = filter_picture(reference_picture, in0, W, Hb, b0, b1, k);
        reference = &own;
        ref_first = in0;
    }
    const Filtered t = filter_picture(test, in0, W, Hb, b0, b1, k);
    const std::size_t shift = static_cast<std::size_t>(in0 - ref_first) * W;
    // Every pixel on its own: the rows in parallel give the same image, bit for bit.
    tbb::parallel_for(b0, b1, [&](int y) {
        for (int x = 0; x < W; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * W + x, r = i + shift;
            const float colour = std::pow(std::abs(reference->lightness[r] - t.lightness[i]), 0.7f);
            const float df =
                std::max(std::abs(reference->edge[r] - t.edge[i]), std::abs(reference->point[r] - t.point[i]));
            const float feature = std::pow(std::min(1.0f, df / std::numbers::sqrt2_v<float>), 0.5f);
            err[i + static_cast<std::size_t>(in0) * W] = colour > 0 ? std::pow(colour, 1.0f - feature) : 0.0f;
        }
    });
    return err;
}

}  // namespace

std::vector<float> perceptual_error(const std::vector<float>& reference, const std::vector<float>& test, int W, int H,
                                    double ppd) {
    return error_image(reference, nullptr, 0, test, W, H, Kernels(ppd));
}

struct PerceptualReference::Filters {
    Kernels kernels;
    Filtered whole;
};

PerceptualReference::PerceptualReference(std::vector<float> picture, int width, int height, double pixels_per_degree)
    : picture_(std::move(picture)), width_(width), height_(height), pixels_per_degree_(pixels_per_degree) {}

PerceptualReference::~PerceptualReference() = default;
PerceptualReference::PerceptualReference(PerceptualReference&&) noexcept = default;

std::vector<float> PerceptualReference::error(const std::vector<float>& test) {
    if (!filters_) {
        const Kernels k(pixels_per_degree_);
        filters_ = std::make_unique<Filters>(Filters{k, filter_picture(picture_, 0, width_, height_, 0, height_, k)});
    }
    return error_image(picture_, &filters_->whole, 0, test, width_, height_, filters_->kernels);
}

}  // namespace penumbra::metrics
