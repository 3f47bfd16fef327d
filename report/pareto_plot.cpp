#include "report/pareto_plot.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/vec3.hpp>

#include "report/bitmap_font.h"
#include "report/report.h"

namespace penumbra::report {
namespace {

constexpr int kLeft = 90, kRight = 30, kTop = 40, kBottom = 60;
const glm::vec3 kOther{0.55f, 0.55f, 0.6f}, kFront{0.05f, 0.45f, 0.9f}, kChosen{0.9f, 0.15f, 0.1f},
    kInk{0.05f, 0.05f, 0.05f}, kGrid{0.85f, 0.85f, 0.85f};

// One axis: data to [0, 1], ticks at powers of ten (log) or at round steps (linear).
struct Axis {
    bool log = false;
    double lo = 0, hi = 1;

    Axis(bool is_log, const std::vector<double>& values) : log(is_log) {
        std::vector<double> v;
        for (double x : values)
            if (std::isfinite(x) && (!log || x > 0)) v.push_back(log ? std::log10(x) : x);
        if (v.empty()) v = {0.0, 1.0};
        lo = *std::min_element(v.begin(), v.end());
        hi = *std::max_element(v.begin(), v.end());
        if (log) {
            lo = std::floor(lo);
            hi = std::ceil(hi);
        } else {
            lo = std::min(lo, 0.0);
            hi += 0.05 * (hi - lo);  // the largest point off the frame's edge
        }
        if (hi - lo < 1e-12) hi = lo + 1;
    }
    double unit(double x) const {
        const double t = log ? (x > 0 ? std::log10(x) : lo) : x;
        return std::clamp((t - lo) / (hi - lo), 0.0, 1.0);
    }
    std::vector<std::pair<double, std::string>> ticks() const {
        std::vector<std::pair<double, std::string>> t;
        if (log) {
            const int step = std::max(1, static_cast<int>(std::ceil((hi - lo) / 8)));
            for (int e = static_cast<int>(lo); e <= static_cast<int>(hi); e += step)
                t.emplace_back((e - lo) / (hi - lo), fmt::format("1e{}", e));
        } else {
            const double raw = (hi - lo) / 5, mag = std::pow(10.0, std::floor(std::log10(raw)));
            const double step = raw / mag < 2 ? 2 * mag : raw / mag < 5 ? 5 * mag : 10 * mag;
            for (double x = std::ceil(lo / step) * step; x <= hi + 1e-9 * step; x += step)
                t.emplace_back((x - lo) / (hi - lo), fmt::format("{:.3g}", x));
        }
        return t;
    }
};

struct Frame {
    Axis x, y;
    int width, height;
    double px(double v) const { return kLeft + x.unit(v) * (width - kLeft - kRight); }
    double py(double v) const { return height - kBottom - y.unit(v) * (height - kTop - kBottom); }
};

Frame frame_of(const ScatterPlot& p, int width, int height) {
    std::vector<double> xs, ys;
    for (const auto& q : p.points) {
        xs.push_back(q.x);
        ys.push_back(q.y);
    }
    if (p.x_limit) xs.push_back(*p.x_limit);
    return {Axis(p.log_x, xs), Axis(p.log_y, ys), width, height};
}

std::vector<const PlotPoint*> front_by_x(const ScatterPlot& p) {
    std::vector<const PlotPoint*> f;
    for (const auto& q : p.points)
        if (q.on_front) f.push_back(&q);
    std::sort(f.begin(), f.end(), [](auto* a, auto* b) { return a->x < b->x; });
    return f;
}

// Which points get their label printed: the chosen one first, then front points, then the rest, skipping any
// whose label box would overlap one already placed (a crowded front stays readable).
std::vector<double> labelled(const ScatterPlot& p, const Frame& f) {
    // The label's left edge per point (NaN: not printed): right of the point, or left of it
    // where it would leave the frame.
    std::vector<double> at(p.points.size(), std::nan(""));
    std::vector<std::array<double, 4>> boxes;  // x0, y0, x1, y1
    auto place = [&](std::size_t i) {
        const PlotPoint& q = p.points[i];
        if (q.label.empty()) return;
        const double w = kGlyphAdvance * static_cast<double>(q.label.size());
        double x0 = f.px(q.x) + 8;
        if (x0 + w > f.width - 4) x0 = f.px(q.x) - 8 - w;
        const double y0 = f.py(q.y) - 16, x1 = x0 + w, y1 = y0 + 14;
        for (const auto& b : boxes)
            if (x0 < b[2] && b[0] < x1 && y0 < b[3] && b[1] < y1) return;
        boxes.push_back({x0, y0, x1, y1});
        at[i] = x0;
    };
    for (std::size_t i = 0; i < p.points.size(); ++i)
        if (p.points[i].chosen) place(i);
    for (std::size_t i = 0; i < p.points.size(); ++i)
        if (p.points[i].on_front && !p.points[i].chosen) place(i);
    for (std::size_t i = 0; i < p.points.size(); ++i)
        if (!p.points[i].on_front && !p.points[i].chosen) place(i);
    return at;
}

std::string hex(glm::vec3 c) {
    auto b = [](float v) { return static_cast<int>(std::lround(std::clamp(v, 0.0f, 1.0f) * 255)); };
    return fmt::format("#{:02x}{:02x}{:02x}", b(c.r), b(c.g), b(c.b));
}

// Pixels of the RGB image.
struct Canvas {
    std::vector<float> rgb;
    int w, h;
    void dot(double cx, double cy, double r, glm::vec3 c, bool ring = false) {
        for (int y = static_cast<int>(cy - r - 1); y <= static_cast<int>(cy + r + 1); ++y)
            for (int x = static_cast<int>(cx - r - 1); x <= static_cast<int>(cx + r + 1); ++x) {
                const double d = std::hypot(x + 0.5 - cx, y + 0.5 - cy);
                if (ring ? std::abs(d - r) > 0.8 : d > r) continue;
                set(x, y, c);
            }
    }
    void set(int x, int y, glm::vec3 c) {
        if (x < 0 || y < 0 || x >= w || y >= h) return;
        float* p = &rgb[(static_cast<std::size_t>(y) * w + x) * 3];
        p[0] = c.r, p[1] = c.g, p[2] = c.b;
    }
    void line(double x0, double y0, double x1, double y1, glm::vec3 c) {
        const int n = static_cast<int>(std::max(std::abs(x1 - x0), std::abs(y1 - y0))) + 1;
        for (int k = 0; k <= n; ++k) {
            const double t = static_cast<double>(k) / n;
            const double x = x0 + t * (x1 - x0), y = y0 + t * (y1 - y0);
            set(static_cast<int>(x), static_cast<int>(y), c);
            set(static_cast<int>(x), static_cast<int>(y) + 1, c);
        }
    }
    void text(double x, double y, std::string_view s, glm::vec3 c) {
        draw_text(rgb, w, h, static_cast<int>(x), static_cast<int>(y), s, c);
    }
};

}  // namespace

std::string plot_svg(const ScatterPlot& p, int width, int height) {
    const Frame f = frame_of(p, width, height);
    std::string s =
        fmt::format(R"(<svg xmlns="http://www.w3.org/2000/svg" width="{0}" height="{1}" viewBox="0 0 {0} {1}" )"
                    R"(font-family="sans-serif" font-size="12">)"
                    "\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n",
                    width, height);
    s += fmt::format(R"(<text x="{}" y="22" font-size="15">{}</text>)"
                     "\n",
                     kLeft, escape_markup(p.title));
    for (const auto& [t, label] : f.x.ticks()) {
        const double x = kLeft + t * (width - kLeft - kRight);
        s += fmt::format(R"(<line x1="{0:.1f}" y1="{1}" x2="{0:.1f}" y2="{2}" stroke="{3}"/>)"
                         R"(<text x="{0:.1f}" y="{4}" text-anchor="middle">{5}</text>)"
                         "\n",
                         x, kTop, height - kBottom, hex(kGrid), height - kBottom + 16, escape_markup(label));
    }
    for (const auto& [t, label] : f.y.ticks()) {
        const double y = height - kBottom - t * (height - kTop - kBottom);
        s += fmt::format(R"(<line x1="{0}" y1="{1:.1f}" x2="{2}" y2="{1:.1f}" stroke="{3}"/>)"
                         R"(<text x="{4}" y="{5:.1f}" text-anchor="end">{6}</text>)"
                         "\n",
                         kLeft, y, width - kRight, hex(kGrid), kLeft - 6, y + 4, escape_markup(label));
    }
    s += fmt::format(R"(<text x="{}" y="{}" text-anchor="middle">{}</text>)"
                     "\n"
                     R"svg(<text transform="translate(16 {}) rotate(-90)" text-anchor="middle">{}</text>)svg"
                     "\n",
                     (kLeft + width - kRight) / 2, height - 18, escape_markup(p.x_label), (kTop + height - kBottom) / 2,
                     escape_markup(p.y_label));
    const auto front = front_by_x(p);
    if (front.size() > 1) {
        s += fmt::format(R"(<polyline fill="none" stroke="{}" stroke-width="2" points=")", hex(kFront));
        for (auto* q : front) s += fmt::format("{:.1f},{:.1f} ", f.px(q->x), f.py(q->y));
        s += "\"/>\n";
    }
    if (p.x_limit)
        s += fmt::format(R"(<line x1="{0:.1f}" y1="{1}" x2="{0:.1f}" y2="{2}" stroke="{3}" stroke-dasharray="6 4"/>)"
                         R"(<text x="{4:.1f}" y="{5}" fill="{3}">{6}</text>)"
                         "\n",
                         f.px(*p.x_limit), kTop, height - kBottom, hex(kChosen), f.px(*p.x_limit) + 4, kTop + 12,
                         escape_markup(p.x_limit_label));
    const std::vector<double> label = labelled(p, f);
    for (std::size_t i = 0; i < p.points.size(); ++i) {
        const PlotPoint& q = p.points[i];
        const glm::vec3 c = q.chosen ? kChosen : q.on_front ? kFront : kOther;
        s += fmt::format(R"(<circle cx="{:.1f}" cy="{:.1f}" r="{}" fill="{}"><title>{}</title></circle>)"
                         "\n",
                         f.px(q.x), f.py(q.y),
                         q.chosen     ? 6
                         : q.on_front ? 4
                                      : 3,
                         hex(c), escape_markup(q.label));
        if (q.chosen)
            s += fmt::format(R"(<circle cx="{:.1f}" cy="{:.1f}" r="10" fill="none" stroke="{}" stroke-width="2"/>)"
                             "\n",
                             f.px(q.x), f.py(q.y), hex(kChosen));
        if (q.start)
            s += fmt::format(R"(<rect x="{:.1f}" y="{:.1f}" width="16" height="16" fill="none" stroke="{}" )"
                             R"(stroke-width="1.5"/>)"
                             "\n",
                             f.px(q.x) - 8, f.py(q.y) - 8, hex(kInk));
        if (!std::isnan(label[i]))
            s += fmt::format(R"(<text x="{:.1f}" y="{:.1f}" font-size="10" fill="{}">{}</text>)"
                             "\n",
                             label[i], f.py(q.y) - 6, hex(c), escape_markup(q.label));
    }
    const bool any_chosen = std::any_of(p.points.begin(), p.points.end(), [](const auto& q) { return q.chosen; });
    s += fmt::format(R"(<text x="{}" y="{}" fill="{}">● Pareto front</text>)", width - kRight - 270, kTop - 8,
                     hex(kFront));
    if (any_chosen)
        s += fmt::format(R"(<text x="{}" y="{}" fill="{}">◉ chosen</text>)", width - kRight - 160, kTop - 8,
                         hex(kChosen));
    if (std::any_of(p.points.begin(), p.points.end(), [](const auto& q) { return q.start; }))
        s += fmt::format(R"(<text x="{}" y="{}" fill="{}">□ start</text>)", width - kRight - 350, kTop - 8, hex(kInk));
    s += fmt::format(R"(<text x="{}" y="{}" fill="{}">● other</text>)"
                     "\n</svg>\n",
                     width - kRight - 80, kTop - 8, hex(kOther));
    return s;
}

std::vector<float> plot_rgb(const ScatterPlot& p, int width, int height) {
    const Frame f = frame_of(p, width, height);
    Canvas c{std::vector<float>(static_cast<std::size_t>(width) * height * 3, 1.0f), width, height};
    c.text(kLeft, 14, p.title, kInk);
    for (const auto& [t, label] : f.x.ticks()) {
        const double x = kLeft + t * (width - kLeft - kRight);
        c.line(x, kTop, x, height - kBottom, kGrid);
        c.text(x - text_width(label) / 2.0, height - kBottom + 8, label, kInk);
    }
    for (const auto& [t, label] : f.y.ticks()) {
        const double y = height - kBottom - t * (height - kTop - kBottom);
        c.line(kLeft, y, width - kRight, y, kGrid);
        c.text(kLeft - 6 - text_width(label), y - kGlyphHeight / 2.0, label, kInk);
    }
    c.line(kLeft, height - kBottom, width - kRight, height - kBottom, kInk);
    c.line(kLeft, kTop, kLeft, height - kBottom, kInk);
    c.text((kLeft + width - kRight - text_width(p.x_label)) / 2.0, height - 24, p.x_label, kInk);
    c.text(8, kTop - 16, p.y_label, kInk);
    const auto front = front_by_x(p);
    for (std::size_t k = 1; k < front.size(); ++k)
        c.line(f.px(front[k - 1]->x), f.py(front[k - 1]->y), f.px(front[k]->x), f.py(front[k]->y), kFront);
    const std::vector<double> label = labelled(p, f);
    for (std::size_t i = 0; i < p.points.size(); ++i) {
        const PlotPoint& q = p.points[i];
        if (q.on_front || q.chosen) continue;
        c.dot(f.px(q.x), f.py(q.y), 2.5, kOther);
        if (!std::isnan(label[i])) c.text(label[i], f.py(q.y) - 12, q.label, kOther);
    }
    if (p.x_limit) {
        const double x = f.px(*p.x_limit);
        for (int y = kTop; y < height - kBottom; y += 10) c.line(x, y, x, y + 5, kChosen);
        c.text(x + 4, kTop + 4, p.x_limit_label, kChosen);
    }
    for (std::size_t i = 0; i < p.points.size(); ++i) {
        const PlotPoint& q = p.points[i];
        if (!q.on_front && !q.chosen) continue;
        const glm::vec3 col = q.chosen ? kChosen : kFront;
        c.dot(f.px(q.x), f.py(q.y), q.chosen ? 5 : 3.5, col);
        if (q.chosen) c.dot(f.px(q.x), f.py(q.y), 9, col, true);
        if (!std::isnan(label[i])) c.text(label[i], f.py(q.y) - 12, q.label, col);
    }
    for (const PlotPoint& q : p.points)
        if (q.start) c.dot(f.px(q.x), f.py(q.y), 7, kInk, true);
    const int lx = width - kRight - 300;
    c.dot(lx, kTop - 14, 3.5, kFront);
    c.text(lx + 8, kTop - 17, "pareto front", kInk);
    if (std::any_of(p.points.begin(), p.points.end(), [](const auto& q) { return q.chosen; })) {
        c.dot(lx + 110, kTop - 14, 5, kChosen);
        c.text(lx + 118, kTop - 17, "chosen", kInk);
    }
    c.dot(lx + 180, kTop - 14, 2.5, kOther);
    c.text(lx + 188, kTop - 17, "other", kInk);
    return c.rgb;
}

}  // namespace penumbra::report
