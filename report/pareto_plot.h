// A scatter plot of one error against another (tune: acne against peter-panning; sweep: error
// against run time) with its Pareto front drawn as a line, as SVG for pages and as an RGB image
// for a PNG that explains itself. Log axes where the values span decades.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace penumbra::report {

struct PlotPoint {
    double x = 0, y = 0;
    bool on_front = false;
    bool chosen = false;  // drawn larger, ringed and named in the legend (the winner)
    bool start = false;   // framed by a square and named in the legend (where the search began)
    std::string label;    // printed next to front points; empty: none
};

struct ScatterPlot {
    std::string title, x_label, y_label;
    bool log_x = false, log_y = false;  // values <= 0 are drawn at the axis' low end
    std::optional<double> x_limit;      // a vertical line (a constraint), labelled
    std::string x_limit_label;
    std::vector<PlotPoint> points;
};

std::string plot_svg(const ScatterPlot& plot, int width = 720, int height = 480);
// Linear RGB, row-major, 3 floats per pixel (for image_io's write_png).
std::vector<float> plot_rgb(const ScatterPlot& plot, int width = 720, int height = 480);

}  // namespace penumbra::report
