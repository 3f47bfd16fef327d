#include "report/report_files.h"

#include <fmt/format.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/geometric.hpp>
#include <optional>

#include "common/camera.h"
#include "image_io/image_io.h"
#include "report/bitmap_font.h"
#include "report/html_page.h"

namespace penumbra::report {

namespace {

using metrics::PixelClass;

// Correct pixels keep the shading of the truth, lit to shadowed, so the scene stays recognisable.
constexpr float kTruthShadow = 0.16f, kTruthLit = 0.56f;
constexpr glm::vec3 kCorrectLit{kTruthLit}, kCorrectShadow{kTruthShadow};
glm::vec3 truth_shade(float v) {
    return glm::vec3(kTruthShadow + (kTruthLit - kTruthShadow) * v);
}

// What each class means, in words a reader of the class map needs (docs/metrics.md).
const char* class_meaning(PixelClass c) {
    switch (c) {
        case PixelClass::aliasing:
            return "wrong within the filter's reach of a true shadow edge: the map's texels are too coarse there "
                   "(raise the resolution, fit the map tighter, or filter)";
        case PixelClass::acne:
            return "a surface shadowing itself: the map holds this very surface in front of it (too little bias)";
        case PixelClass::peter_panning:
            return "lit where it should be shadowed, near the occluder: the bias pushed the receiver past its "
                   "caster (too much bias)";
        case PixelClass::false_shadow: return "shadowed where nothing occludes the light, for another reason";
        case PixelClass::false_lit:
            return "lit where an occluder blocks the light: casters clipped, culled or outside the map";
        case PixelClass::light_bleeding:
            return "lit inside a true umbra, away from its edges: a moment map's filter mixed this receiver's "
                   "occluder with a farther surface (raise the light-bleed reduction or min variance)";
        case PixelClass::correct: return "within the tolerance of the truth; drawn in the truth's own shading";
        case PixelClass::uncertain: return "not scored: the truth is within float error of a shadow boundary";
        case PixelClass::coverage_mismatch:
            return "not scored: the raster camera saw another surface than the oracle (silhouettes)";
        case PixelClass::back_facing: return "not scored: the surface faces away from the light; dark in both";
        case PixelClass::background: return "no surface";
    }
    return "";
}

// A back_facing pixel outside a spot light's cone is drawn apart (issue #53): it is not a back
// face. Counted with back_facing in report.json (the classes' ids are stable); only the class map
// and its legend tell them apart.
constexpr glm::vec3 kOutsideCone{0.05f, 0.22f, 0.24f};
constexpr const char* kOutsideConeMeaning =
    "not scored: outside the spot light's cone, where it casts no light; dark in both (counted with back_facing)";

bool outside_cone(const Light& light, const glm::dvec3& point) {
    if (light.type != LightType::spot) return false;
    const glm::dvec3 d = point - light.position;
    const double len = glm::length(d);
    return len > 0 && glm::dot(d, light.direction) < std::cos(light.outer_cone_rad) * len;
}

glm::vec3 class_colour(PixelClass c) {
    switch (c) {
        case PixelClass::background: return {0.0f, 0.0f, 0.0f};
        // Not scored: colours no shading of the truth takes (greys) and no error class uses, so
        // neither reads as a shadow nor as a correct pixel (issue 33).
        case PixelClass::back_facing: return {0.04f, 0.06f, 0.3f};
        case PixelClass::uncertain: return {0.6f, 0.1f, 0.6f};
        case PixelClass::coverage_mismatch: return {0.45f, 0.25f, 0.06f};
        case PixelClass::correct: return kCorrectLit;
        case PixelClass::aliasing: return {1.0f, 0.8f, 0.05f};
        case PixelClass::acne: return {0.95f, 0.08f, 0.05f};
        case PixelClass::peter_panning: return {0.05f, 0.75f, 1.0f};
        case PixelClass::false_shadow: return {0.55f, 0.2f, 1.0f};
        case PixelClass::false_lit: return {0.15f, 0.9f, 0.2f};
        case PixelClass::light_bleeding: return {1.0f, 0.45f, 0.75f};
    }
    return {1, 1, 1};
}

std::string css_colour(glm::vec3 linear) {
    auto s = [](float v) {
        v = std::clamp(v, 0.0f, 1.0f);
        v = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
        return static_cast<int>(std::lround(v * 255.0f));
    };
    return fmt::format("#{:02x}{:02x}{:02x}", s(linear.r), s(linear.g), s(linear.b));
}

struct LegendEntry {
    glm::vec3 colour;
    std::string text;
};

// Appends a band under the image with a swatch and a label per entry, wrapping into rows.
std::vector<float> with_legend(std::vector<float> rgb, int W, int H, const std::vector<LegendEntry>& entries,
                               int& out_height) {
    const int scale = W >= 640 ? 2 : 1;
    const int line = (kGlyphHeight + 5) * scale, pad = 4 * scale, swatch = kGlyphHeight * scale;
    // Lay out once to know the band's height.
    std::vector<std::pair<int, int>> at;
    int x = pad, y = pad;
    for (const auto& e : entries) {
        const int w = swatch + 2 * scale + text_width(e.text, scale) + 4 * pad;
        if (x > pad && x + w > W) {
            x = pad;
            y += line;
        }
        at.emplace_back(x, y);
        x += w;
    }
    const int band = y + line + pad;
    out_height = H + band;
    rgb.resize(3 * static_cast<std::size_t>(W) * out_height, 0.04f);  // lighter than "not scored"
    for (std::size_t k = 0; k < entries.size(); ++k) {
        const int ex = at[k].first, ey = H + at[k].second;
        for (int sy = 0; sy < swatch; ++sy)
            for (int sx = 0; sx < swatch; ++sx) {
                const int px = ex + sx, py = ey + sy;
                if (px >= W || py >= out_height) continue;
                float* p = &rgb[3 * (static_cast<std::size_t>(py) * W + px)];
                p[0] = entries[k].colour.r;
                p[1] = entries[k].colour.g;
                p[2] = entries[k].colour.b;
            }
        draw_text(rgb, W, out_height, ex + swatch + 2 * scale, ey, entries[k].text, {0.9f, 0.9f, 0.9f}, scale);
    }
    return rgb;
}

// Where the oracle's pixel i lies, world space: its point where the frame has one, else where the
// camera's ray meets the plane of the triangle the pixel shows (a cached frame keeps the
// triangle, not the point); nullopt without either.
std::optional<glm::dvec3> world_point(const OracleFrame& frame, const Scenario* scenario, std::size_t i) {
    if (i < frame.P.size()) return frame.frame_origin + glm::dvec3(frame.P[i]);
    if (!scenario || i >= frame.prim.size() || frame.width <= 0) return std::nullopt;
    const Scene& scene = scenario->scene;
    const std::uint32_t t = frame.prim[i];
    if (t >= scene.triangles.size()) return std::nullopt;
    const int x = static_cast<int>(i % static_cast<std::size_t>(frame.width));
    const int y = static_cast<int>(i / static_cast<std::size_t>(frame.width));
    const PrimaryRay ray = primary_ray(scenario->camera, frame.width, frame.height, x + 0.5, y + 0.5);
    const glm::dvec3 o = scenario->camera.eye + ray.origin;
    const glm::u32vec3 tri = scene.triangles[t];
    const glm::dvec3 a = scene.positions[tri.x];
    const glm::dvec3 n = glm::cross(scene.positions[tri.y] - a, scene.positions[tri.z] - a);
    const double along = glm::dot(n, ray.direction);
    if (along == 0) return std::nullopt;
    return o + ray.direction * (glm::dot(n, a - o) / along);
}

// `light` (may be null) tells a spot light's outside from its back faces (with `scenario`, the
// frame's, where the frame keeps no points); its pixels are counted into `outside`.
std::vector<float> class_image(const OracleFrame& frame, std::size_t li, const metrics::LightErrorImage& e,
                               const Light* light, const Scenario* scenario, std::uint64_t& outside) {
    const OracleLightImage& o = frame.lights[li];
    const std::size_t n = frame.pixel_count();
    std::vector<float> rgb(3 * n);
    outside = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const auto c = static_cast<PixelClass>(e.cls[i]);
        // Correct pixels keep the shading of the truth, so the scene stays recognisable; a wrong
        // pixel whose error is below the visible threshold is drawn halfway to it (paler).
        const glm::vec3 truth = truth_shade(o.V[i]);
        glm::vec3 col = c == PixelClass::correct ? truth : class_colour(c);
        if (c == PixelClass::back_facing && light && light->type == LightType::spot)
            if (const auto p = world_point(frame, scenario, i); p && outside_cone(*light, *p)) {
                col = kOutsideCone;
                ++outside;
            }
        if (c > PixelClass::correct && std::abs(e.error[i]) < e.visible_threshold) col = 0.5f * (col + truth);
        for (int k = 0; k < 3; ++k) rgb[3 * i + k] = col[k];
    }
    return rgb;
}

constexpr glm::vec3 kDarker{0.95f, 0.12f, 0.06f}, kBrighter{0.1f, 0.45f, 1.0f};

std::vector<float> error_image(const OracleLightImage& o, const metrics::LightErrorImage& e, std::size_t n) {
    std::vector<float> rgb(3 * n);
    for (std::size_t i = 0; i < n; ++i) {
        const auto c = static_cast<PixelClass>(e.cls[i]);
        glm::vec3 col = class_colour(PixelClass::background);
        if (c >= PixelClass::correct) {
            // Dim truth underneath; errors bright, small ones still visible (square-root ramp).
            const glm::vec3 base(0.015f + 0.06f * o.V[i]);
            const float t = std::sqrt(std::min(1.0f, std::abs(e.error[i])));
            col = c == PixelClass::correct ? base : base + (e.error[i] < 0 ? kDarker : kBrighter) * (0.3f + 0.7f * t);
        } else if (c != PixelClass::background) {
            col = glm::vec3(0.01f);
        }
        for (int k = 0; k < 3; ++k) rgb[3 * i + k] = std::min(col[k], 1.0f);
    }
    return rgb;
}

std::vector<float> compare_image(const std::vector<float>& A, const std::vector<float>& Vo,
                                 const std::vector<float>& Vr, int W, int H) {
    const int W2 = 2 * W;
    std::vector<float> rgb(3 * static_cast<std::size_t>(W2) * H);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * W + x;
            const float o = A[i] != 0 ? 0.08f + 0.8f * Vo[i] : 0.02f, r = A[i] != 0 ? 0.08f + 0.8f * Vr[i] : 0.02f;
            for (int k = 0; k < 3; ++k) {
                rgb[3 * (static_cast<std::size_t>(y) * W2 + x) + k] = o;
                rgb[3 * (static_cast<std::size_t>(y) * W2 + W + x) + k] = r;
            }
        }
    const int scale = W >= 640 ? 2 : 1;
    draw_text(rgb, W2, H, 6 * scale, 6 * scale, "oracle (truth)", {1.0f, 0.85f, 0.2f}, scale);
    draw_text(rgb, W2, H, W + 6 * scale, 6 * scale, "raster (technique)", {1.0f, 0.85f, 0.2f}, scale);
    return rgb;
}

std::string light_file(std::size_t li, const char* what) {
    return fmt::format("light{}.{}.png", li, what);
}

// Whole numbers (pixel counts) in full, the rest to four significant digits.
std::string number(double v) {
    if (v == std::floor(v) && std::abs(v) < 1e15) return fmt::format("{:.0f}", v);
    return fmt::format("{:.4g}", v);
}

// A horizontal bar per error class: rates on one shared scale, so lights compare at a glance.
std::string rate_chart(const metrics::LightScore& light) {
    double top = 1e-6;
    for (auto c : metrics::kErrorClasses) top = std::max(top, light.rate(c));
    std::string svg = R"(<svg xmlns="http://www.w3.org/2000/svg" width="420" height="130" role="img">)";
    int y = 4;
    for (auto c : metrics::kErrorClasses) {
        const std::string name(to_string(c));
        const double rate = light.rate(c);
        const int w = static_cast<int>(std::lround(220.0 * rate / top));
        svg += fmt::format(R"(<text x="0" y="{}" font-size="12" fill="#ddd">{}</text>)", y + 13, name);
        svg += fmt::format(R"(<rect x="105" y="{}" width="{}" height="16" fill="{}"/>)", y + 2, std::max(w, 1),
                           css_colour(class_colour(c)));
        svg += fmt::format(R"(<text x="{}" y="{}" font-size="12" fill="#ddd">{:.3f}%</text>)", 110 + w, y + 14,
                           100.0 * rate);
        y += 25;
    }
    return svg + "</svg>";
}

// The metrics of one light that the class table does not show, from the table: every other
// metric appears here without an edit.
std::string metric_rows(const metrics::LightScore& l) {
    std::string rows;
    for (const metrics::Metric& m : metrics::metric_table()) {
        if (m.path.starts_with("counts.") || m.path.starts_with("rates.") || m.path.starts_with("pixels.")) continue;
        const std::optional<double> v = metrics::value_of(m, l);
        if (!v && m.scope == metrics::MetricScope::area_lights) continue;
        rows += fmt::format("<tr><td title=\"{}\">{}</td><td>{}</td><td>{}</td></tr>\n", escape_markup(m.meaning),
                            escape_markup(m.path), v ? number(*v) : "not measured", to_string(m.unit));
    }
    return rows;
}

// The layers a family reports per light (report.json's per-layer metrics, under the family's own
// key: "cascades" for the cascaded family), one row each: the view range it serves, its texel at
// the receivers, its scored pixels and their share of the light's, and its wrong pixels by class.
std::string layer_tables(const nlohmann::json& light, const metrics::LightScore& l) {
    std::string h;
    for (auto it = light.begin(); it != light.end(); ++it) {
        const nlohmann::json& layers = it.value();
        if (!layers.is_array() || layers.empty() || !layers[0].is_object() || !layers[0].contains("near_m") ||
            !layers[0].contains("far_m") || !layers[0].contains("texel_m"))
            continue;
        h += fmt::format(
            "<h3>{} ({})</h3><div class=\"wrap\"><table><tr><th>#</th><th>view depths (m)</th><th>texel (m)</th>"
            "<th>scored pixels</th><th>share</th><th>wrong</th>",
            escape_markup(it.key()), layers.size());
        for (auto c : metrics::kErrorClasses) h += fmt::format("<th>{}</th>", to_string(c));
        h += "</tr>\n";
        const double scored = std::max<double>(1.0, static_cast<double>(l.pixels.scored));
        for (const nlohmann::json& layer : layers) {
            const auto px = layer.contains("pixels") ? layer["pixels"].value("scored", std::uint64_t{0}) : 0;
            std::uint64_t wrong = 0;
            std::string cells;
            for (auto c : metrics::kErrorClasses) {
                const auto n = layer.contains("counts") ? layer["counts"].value(to_string(c), std::uint64_t{0}) : 0;
                wrong += n;
                cells += fmt::format("<td>{}</td>", n);
            }
            h += fmt::format(
                "<tr><td>{}</td><td>{} – {}</td><td>{}</td><td>{}</td><td>{:.1f}%</td><td>{}</td>{}</tr>\n",
                layer.value("index", 0), number(layer.value("near_m", 0.0)), number(layer.value("far_m", 0.0)),
                number(layer.value("texel_m", 0.0)), px, 100.0 * static_cast<double>(px) / scored, wrong, cells);
        }
        h += "</table></div>\n";
    }
    return h;
}

std::string evidence_text(const metrics::ClassificationEvidence& e) {
    if (e.source == metrics::Evidence::depth_map_lookups) return "the technique's depth-map lookups";
    return fmt::format("the oracle's geometry (V only): texel footprint {} m ({}), bias reach {} m ({})",
                       number(e.texel_footprint_m), to_string(e.texel_footprint_source), number(e.bias_reach_m),
                       to_string(e.bias_reach_source));
}

// The light's dominant visible class and the one-line reading of it, or what the light shows
// when nothing dominates.
std::string light_reading(const metrics::LightScore& l, const metrics::RunFacts& facts) {
    if (auto line = metrics::reading_line(l, facts)) return *line;
    if (l.pixels.scored == 0) return "nothing scored";
    return l.wrong_visible == 0 ? "no visible error" : "visible errors below 1% in every class";
}

std::string dominant_class(const metrics::LightScore& l) {
    PixelClass top = PixelClass::correct;
    std::uint64_t most = 0;
    for (auto c : metrics::kErrorClasses)
        if (l.count_visible(c) > most) {
            most = l.count_visible(c);
            top = c;
        }
    if (most == 0) return "none";
    return fmt::format(R"(<span class="swatch" style="background:{}"></span>{})", css_colour(class_colour(top)),
                       to_string(top));
}

std::string html_page(const ReportInputs& in, const metrics::FrameScore& score, const nlohmann::json& report,
                      const OutputTransaction& out, bool facing_view) {
    auto src = [&](const std::string& file) {
        return "data:image/png;base64," + base64_encode(out.written_bytes(file));
    };
    auto img = [&](const std::string& file, const std::string& alt) {
        return fmt::format(R"(<img src="{}" alt="{}">)", src(file), escape_markup(alt));
    };
    std::string h = html_page_head("penumbra report", PageKind::report);
    const Scenario& sc = *in.scenario;
    h += fmt::format("<h1>penumbra report</h1>\n<p>Scenario <code>{}</code>, {}&times;{} pixels, {} light(s). ",
                     escape_markup(in.scenario_file.string()), sc.width, sc.height, sc.lights.size());
    if (in.raster.contains("device"))
        h += fmt::format("Raster device: {}. ", escape_markup(in.raster["device"].value("name", "?")));
    h += fmt::format("penumbra {}.</p>\n", escape_markup(report.value("version", "")));
    if (!in.command_line.empty()) h += fmt::format("<p>Made by <code>{}</code></p>\n", escape_markup(in.command_line));

    // Contents, then the answer: one row per light, the class maps as thumbnails.
    h += "<nav>Contents: <a href=\"#summary\">summary</a>";
    if (in.gate) h += " &middot; <a href=\"#gate\">gate</a>";
    for (std::size_t li = 0; li < score.lights.size(); ++li)
        h += fmt::format(" &middot; <a href=\"#light-{0}\">light {0}</a>", li);
    h += " &middot; <a href=\"#classes\">the classes</a> &middot; <a href=\"#timing\">timing</a> &middot; <a "
         "href=\"#technique\">technique</a> &middot; <a href=\"#scoring\">scoring</a>";
    if (facing_view) h += " &middot; <a href=\"#facing\">facing</a>";
    h += "</nav>\n";
    h += "<h2 id=\"summary\">Summary</h2>\n<div class=\"scroll\"><table id=\"summary-table\"><tr><th>light</th>"
         "<th title=\"wrong pixels, of the scored\">wrong</th><th title=\"wrong with |error| at least the visible "
         "threshold\">visibly wrong</th><th>dominant visible class</th><th>reading</th></tr>\n";
    for (std::size_t li = 0; li < score.lights.size(); ++li) {
        const metrics::LightScore& l = score.lights[li];
        const double scored = std::max<double>(1.0, static_cast<double>(l.pixels.scored));
        h += fmt::format(
            "<tr><td><a href=\"#light-{}\">{} ({})</a></td><td>{:.3f}%</td><td>{:.3f}% ({} px)</td><td>{}</td><td "
            "class=\"reading\">{}</td></tr>\n",
            li, li, escape_markup(to_string(sc.lights[li].type)), 100.0 * l.wrong_fraction,
            100.0 * static_cast<double>(l.wrong_visible) / scored, l.wrong_visible, dominant_class(l),
            escape_markup(light_reading(l, in.facts)));
    }
    h += "</table></div>\n<div class=\"strip\">\n";
    for (std::size_t li = 0; li < score.lights.size(); ++li)
        h += fmt::format(
            R"x(<a href="#light-{0}"><img class="thumb" src="{1}" alt="class map, light {0}, thumbnail">light {0}</a>)x"
            "\n",
            li, src(light_file(li, "classes")));
    h += "</div>\n<details><summary>Technique as JSON</summary><pre>" + escape_markup(report["technique"].dump()) +
         "</pre></details>\n";

    if (in.gate) {
        const bool passed = in.gate->passed;
        h += fmt::format(
            "<h2>Gate: <span class=\"{}\" "
            "id=\"gate\">{}</span></h2>\n<table><tr><th>light</th><th>check</th><th>value</th><th>result</th></tr>\n",
            passed ? "pass" : "fail", passed ? "passed" : "FAILED");
        for (const auto& c : in.gate->outcomes)
            h += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td class=\"{}\">{}</td></tr>\n", c.light,
                             escape_markup(c.name()), std::isfinite(c.value) ? number(c.value) : "not measured",
                             c.passed ? "pass" : "fail", c.passed ? "pass" : "fail");
        h += "</table>\n";
    }
    for (std::size_t li = 0; li < score.lights.size(); ++li) {
        const metrics::LightScore& l = score.lights[li];
        h += fmt::format("<h2 id=\"light-{}\">Light {} ({})</h2>\n", li, li,
                         escape_markup(to_string(sc.lights[li].type)));
        h += fmt::format("<p>{}. Classes from {}.</p>\n", escape_markup(light_reading(l, in.facts)),
                         escape_markup(evidence_text(l.evidence)));
        // The visible rates first, as the terminal, gates and hints read them; every wrong pixel's after.
        h += "<div class=\"grid\"><div><table><tr><th>class</th>"
             "<th title=\"|error| at least the visible threshold\">visible</th><th>visible rate</th><th>pixels</th>"
             "<th>rate</th></tr>\n";
        for (auto c : metrics::kErrorClasses) {
            h += fmt::format(
                "<tr><td><span class=\"swatch\" "
                "style=\"background:{}\"></span>{}</td><td>{}</td><td>{:.4f}%</td><td>{}</td><td>{:.4f}%</td></tr>\n",
                css_colour(class_colour(c)), to_string(c), l.count_visible(c), 100.0 * l.rate_visible(c), l.count(c),
                100.0 * l.rate(c));
        }
        h += "</table><table>\n";
        for (const metrics::Metric& m : metrics::metric_table())
            if (m.path.starts_with("pixels."))
                h += fmt::format("<tr><td title=\"{}\">{} pixels</td><td>{}</td></tr>\n", escape_markup(m.meaning),
                                 m.path.substr(7), number(m.read(l)));
        h += "</table><div class=\"scroll\"><table><tr><th>metric</th><th>value</th><th>unit</th></tr>\n" +
             metric_rows(l) + "</table></div></div>\n";
        h += "<div>" + rate_chart(l) + "</div></div>\n";
        if (report.contains("lights") && li < report["lights"].size()) h += layer_tables(report["lights"][li], l);
        h += "<h3>Classes</h3><div class=\"classmap\"><div>" +
             img(light_file(li, "classes"), fmt::format("class map, light {}", li)) +
             "</div><div><a href=\"#classes\">What each colour means</a></div></div>";
        h += "<h3>Signed error (red: raster darker, blue: raster brighter)</h3>" +
             img(light_file(li, "error"), fmt::format("error map, light {}", li));
        h += "<h3>Oracle and raster</h3>" +
             img(light_file(li, "compare"), fmt::format("oracle and raster, light {}", li));
    }
    if (facing_view) {
        h += "<h2 id=\"facing\">Facing</h2>\n<p>Which side of its triangle each pixel sees. Where the camera's ray "
             "met a single-sided triangle's back first, it saw past it (culled, as an engine culls) to what lies "
             "behind: a mesh with inverted winding, or one seen from inside, shows through there.</p>\n";
        const nlohmann::json& meshes = report["facing"]["meshes"];
        if (!meshes.empty()) {
            h += "<table><tr><th>mesh</th><th>its pixels</th><th>rays that passed its back "
                 "faces</th><th>share</th></tr>\n";
            for (const nlohmann::json& m : meshes)
                h += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{:.1f}%</td></tr>\n",
                                 escape_markup(m.value("mesh", "")), m.value("pixels", std::uint64_t{0}),
                                 m.value("from_behind_px", std::uint64_t{0}), 100.0 * m.value("share", 0.0));
            h += "</table>\n";
        }
        h += img("facing.png", "facing view");
    }
    // The classes in words, with the colours the class maps draw them in.
    h += "<h2 id=\"classes\">The classes</h2>\n<dl class=\"classes\">\n";
    auto term = [&](glm::vec3 colour, const std::string& name, const char* meaning) {
        h += fmt::format("<dt><span class=\"swatch\" style=\"background:{}\"></span>{}</dt><dd>{}</dd>\n",
                         css_colour(colour), name, meaning);
    };
    for (auto c : metrics::kErrorClasses) term(class_colour(c), std::string(to_string(c)), class_meaning(c));
    term(kCorrectLit, "correct, lit", class_meaning(PixelClass::correct));
    term(kCorrectShadow, "correct, in shadow", class_meaning(PixelClass::correct));
    for (auto c : {PixelClass::uncertain, PixelClass::coverage_mismatch, PixelClass::back_facing})
        term(class_colour(c), std::string(to_string(c)), class_meaning(c));
    if (in.scenario && std::any_of(in.scenario->lights.begin(), in.scenario->lights.end(),
                                   [](const Light& l) { return l.type == LightType::spot; }))
        term(kOutsideCone, "outside the cone", kOutsideConeMeaning);
    h += fmt::format(
        "</dl>\n<p>An error class drawn paler is a faint error: wrong, but with |error| under the visible threshold "
        "{:g} (<code>counts_visible</code> leaves it out).</p>\n",
        score.images.empty() ? 0.1 : score.images[0].visible_threshold);
    h += "<h2 id=\"timing\">Timing</h2>\n<table>\n";
    const auto& t = report["timing"];
    h += fmt::format("<tr><td>oracle ({})</td><td>{:.3f} s</td></tr>\n",
                     t.value("oracle_cached", false) ? "cached" : "traced", t.value("oracle_s", 0.0));
    h += fmt::format("<tr><td>raster, wall clock</td><td>{:.3f} s</td></tr>\n", t.value("raster_s", 0.0));
    for (const auto& [k, v] : t["raster_ms"].items())
        h += fmt::format("<tr><td>GPU {}</td><td>{:.2f} ms</td></tr>\n", escape_markup(k), v.get<double>());
    h += fmt::format("<tr><td>metrics</td><td>{:.3f} s</td></tr>\n</table>\n", t.value("metrics_s", 0.0));
    if (in.raster.contains("device") && in.raster["device"].value("type", "") == "cpu")
        h += "<p>The raster device is a CPU (lavapipe): its \"GPU\" times are the CPU's.</p>\n";
    h += "<h2 id=\"technique\">Technique</h2>\n<pre>" + escape_markup(report["technique"].dump(2)) + "</pre>\n";
    h += "<h2 id=\"scoring\">Scoring</h2>\n<pre>" + escape_markup(report["scoring"].dump(2)) + "</pre>\n";
    h += image_check_script();
    h += R"(</body></html>
)";
    return h;
}

}  // namespace

const char* image_check_script() {
    // Marks the body for tests (tests/cli/harness.sh, html_check): data-images "ok" when every
    // image decoded; data-layout "ok" when nothing is wider than the window, else what
    // overflows. A table may be wider only inside a box that scrolls it (overflow-x auto).
    return R"(<script>
window.addEventListener("load", function () {
  var broken = Array.prototype.filter.call(document.images, function (i) { return !i.complete || i.naturalWidth === 0; });
  broken.forEach(function (i) { console.error("image did not load: " + i.alt); });
  document.body.setAttribute("data-images", broken.length === 0 ? "ok" : "broken");
  var width = document.documentElement.clientWidth, wide = [];
  if (document.documentElement.scrollWidth > width) wide.push("page " + document.documentElement.scrollWidth + "px");
  Array.prototype.forEach.call(document.querySelectorAll("table, img, pre, svg, h1, h2, p"), function (e) {
    for (var a = e.parentElement; a; a = a.parentElement) {
      var o = getComputedStyle(a).overflowX;
      if (o === "auto" || o === "scroll") return;
    }
    var r = e.getBoundingClientRect();
    if (r.right > width + 0.5) wide.push(e.tagName.toLowerCase() + " " + Math.round(r.right) + "px");
  });
  document.body.setAttribute("data-layout", wide.length === 0 ? "ok" : "wider than " + width + "px: " + wide.join(", "));
});
</script>
)";
}

// A hue per cascade, mixed a third into the class map (validate --class-map-tint cascade).
constexpr std::array<glm::vec3, 4> kCascadeTints = {
    {{1.0f, 0.85f, 0.1f}, {0.1f, 0.9f, 0.9f}, {0.9f, 0.2f, 0.9f}, {0.3f, 0.95f, 0.3f}}};
constexpr float kCascadeTintWeight = 0.35f;

void write_class_map(OutputTransaction& out, const std::string& name, const OracleFrame& oracle, std::size_t li,
                     const metrics::LightErrorImage& e, const metrics::LightScore& l, const Light* light,
                     const Scenario* scenario, const std::vector<std::uint32_t>* cascade_layer) {
    std::vector<LegendEntry> legend;
    for (auto c : metrics::kErrorClasses)
        legend.push_back({class_colour(c), fmt::format("{} {:.2f}% visible ({:.2f}% in all)", to_string(c),
                                                       100.0 * l.rate_visible(c), 100.0 * l.rate(c))});
    legend.push_back({0.5f * (class_colour(PixelClass::acne) + truth_shade(0.5f)),
                      fmt::format("paler: faint, error under {:g}", e.visible_threshold)});  // the font has no '|'
    legend.push_back({kCorrectLit, "correct, lit"});
    legend.push_back({kCorrectShadow, "correct, in shadow"});
    for (auto c : {PixelClass::uncertain, PixelClass::coverage_mismatch, PixelClass::back_facing})
        legend.push_back({class_colour(c), std::string(to_string(c))});
    std::uint64_t outside = 0;
    std::vector<float> rgb = class_image(oracle, li, e, light, scenario, outside);
    if (light && light->type == LightType::spot)
        legend.push_back({kOutsideCone, fmt::format("outside the cone, {:.1f}% of the image",
                                                    100.0 * double(outside) /
                                                        double(std::max<std::size_t>(1, oracle.pixel_count())))});
    if (cascade_layer && cascade_layer->size() == oracle.pixel_count()) {
        std::uint32_t most = 0;
        for (std::size_t i = 0; i < oracle.pixel_count(); ++i) {
            if (static_cast<PixelClass>(e.cls[i]) == PixelClass::background) continue;
            const std::uint32_t layer = (*cascade_layer)[i];
            most = std::max(most, layer + 1);
            const glm::vec3& tint = kCascadeTints[layer % kCascadeTints.size()];
            for (int k = 0; k < 3; ++k)
                rgb[3 * i + k] = (1 - kCascadeTintWeight) * rgb[3 * i + k] + kCascadeTintWeight * tint[k];
        }
        for (std::uint32_t c = 0; c < most && c < kCascadeTints.size(); ++c)
            legend.push_back({(1 - kCascadeTintWeight) * glm::vec3(0.5f) + kCascadeTintWeight * kCascadeTints[c],
                              most > kCascadeTints.size() ? fmt::format("tint: cascades {} and {}", c, c + 4)
                                                          : fmt::format("tint: cascade {}", c)});
    }
    int h = 0;
    auto classes = with_legend(rgb, oracle.width, oracle.height, legend, h);
    write_png(out, name, oracle.width, h, classes);
}

namespace {

constexpr glm::vec3 kFrontSeen{0.55f, 0.55f, 0.55f};
constexpr glm::vec3 kBackSeen{0.95f, 0.45f, 0.1f};

// Whether a facing view is drawn: where the camera met single-sided back faces first (the
// report's facing), the view a user needs to see which geometry faces the wrong way.
bool wants_facing_view(const ReportInputs& in, const nlohmann::json& report) {
    return in.scenario && !in.scenario->camera_path && report.contains("facing") &&
           report["facing"].value("from_behind_px", std::uint64_t{0}) > 0;
}

// The side of its triangle each pixel sees (docs/metrics.md, "Facing"): the front (counter-
// clockwise as seen) grey, the back of a double-sided triangle orange, with the legend naming the
// meshes whose back faces the camera met first and saw past (single-sided: culled, as engines do).
std::vector<float> facing_image(const ReportInputs& in, const OracleFrame& oracle, const nlohmann::json& facing,
                                int& h) {
    const Scene& scene = in.scenario->scene;
    const int W = oracle.width, H = oracle.height;
    const PrimaryRays rays(in.scenario->camera, W, H);
    std::vector<float> rgb(3 * oracle.pixel_count(), 0.01f);
    std::uint64_t back = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const std::size_t i =
                static_cast<std::size_t>(y) * static_cast<std::size_t>(W) + static_cast<std::size_t>(x);
            const std::uint32_t p = oracle.prim[i];
            if (p == kNoPrimitive || p >= scene.triangles.size()) continue;
            const glm::u32vec3 t = scene.triangles[p];
            const glm::dvec3 n =
                glm::cross(scene.positions[t.y] - scene.positions[t.x], scene.positions[t.z] - scene.positions[t.x]);
            const bool from_behind = glm::dot(n, rays.at(x + 0.5, y + 0.5).direction) > 0;
            back += from_behind;
            const glm::vec3 c = from_behind ? kBackSeen : kFrontSeen;
            for (int k = 0; k < 3; ++k) rgb[3 * i + static_cast<std::size_t>(k)] = c[k];
        }
    const double frame = std::max<double>(1.0, static_cast<double>(oracle.pixel_count()));
    std::vector<LegendEntry> legend = {{kFrontSeen, "front face seen"},
                                       {kBackSeen, fmt::format("back face seen (double-sided), {:.1f}% of the image",
                                                               100.0 * static_cast<double>(back) / frame)},
                                       {glm::vec3(0.01f), "background"}};
    const std::uint64_t culled = facing.value("from_behind_px", std::uint64_t{0});
    if (culled > 0)
        legend.push_back(
            {glm::vec3(0.04f), fmt::format("{:.1f}% of the rays passed single-sided back faces (see the list)",
                                           100.0 * static_cast<double>(culled) / frame)});
    return with_legend(std::move(rgb), W, H, legend, h);
}

}  // namespace

void write_report(OutputTransaction& out, const ReportInputs& in, const OracleFrame& oracle, const RasterFrame& raster,
                  const metrics::FrameScore& score, const nlohmann::json& report) {
    const int W = oracle.width, H = oracle.height;
    const std::size_t n = oracle.pixel_count();
    // Each file is encoded on its own task (the bytes do not depend on the order); the page
    // embeds the PNGs once they are all written.
    tbb::task_group files;
    if (in.errors_exr)
        files.run([&] {
            std::vector<ExrChannel> channels = {{"A", oracle.A, {}}};  // the surface mask, and never an empty file
            for (std::size_t li = 0; li < score.images.size(); ++li) {
                const auto& e = score.images[li];
                channels.push_back({fmt::format("light{}.error", li), e.error, {}});
                channels.push_back(
                    {fmt::format("light{}.class", li), {}, std::vector<std::uint32_t>(e.cls.begin(), e.cls.end())});
                channels.push_back({fmt::format("light{}.perceptual", li), e.perceptual, {}});
            }
            write_exr(out, "errors.exr", W, H, channels);
        });
    for (std::size_t li = 0; li < score.images.size(); ++li) {
        const auto& e = score.images[li];
        // A cascaded light (report.json has its cascades) is tinted by cascade when asked.
        const bool tint = in.tint_cascades && li < raster.lights.size() && raster.lights[li].lookups &&
                          report.contains("lights") && li < report["lights"].size() &&
                          report["lights"][li].contains("cascades");
        files.run([&, li, tint] {
            const Light* light = in.scenario && li < in.scenario->lights.size() ? &in.scenario->lights[li] : nullptr;
            write_class_map(out, light_file(li, "classes"), oracle, li, e, score.lights[li], light, in.scenario,
                            tint ? &raster.lights[li].lookups->layer : nullptr);
        });
        files.run([&, li] {
            const std::vector<LegendEntry> error_legend = {{kDarker, "raster darker than truth"},
                                                           {kBrighter, "raster brighter than truth"},
                                                           {glm::vec3(0.06f), "within tolerance"},
                                                           {glm::vec3(0.01f), "not scored"}};
            int h = 0;
            auto errors = with_legend(error_image(oracle.lights[li], e, n), W, H, error_legend, h);
            write_png(out, light_file(li, "error"), W, h, errors);
        });
        files.run([&, li] {
            write_png(out, light_file(li, "compare"), 2 * W, H,
                      compare_image(oracle.A, oracle.lights[li].V, raster.lights[li].V, W, H));
        });
    }
    const bool facing_view = wants_facing_view(in, report);
    if (facing_view)
        files.run([&] {
            int h = 0;
            const std::vector<float> rgb = facing_image(in, oracle, report["facing"], h);
            write_png(out, "facing.png", W, h, rgb);
        });
    files.wait();
    out.write_json("report.json", report);
    out.write_text("report.html", html_page(in, score, report, out, facing_view));
}

}  // namespace penumbra::report
