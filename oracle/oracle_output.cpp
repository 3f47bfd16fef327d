#include "oracle/oracle_output.h"

#include <algorithm>

namespace penumbra {

namespace {
constexpr std::size_t kCulledNodesListed = 64;  // of oracle.json's culled_by_node
}  // namespace

nlohmann::json oracle_json(const Scenario& scenario, const OracleResult& result, const OracleTimings& timings) {
    const OracleFrame& f = result.frame;
    const OracleStats& s = result.stats;
    nlohmann::json write_seconds = {{"exr", timings.write_exr_s}, {"png", timings.write_png_s}};
    if (timings.write_exr_early_s) write_seconds["exr_early"] = *timings.write_exr_early_s;

    nlohmann::json lights = nlohmann::json::array();
    for (std::size_t li = 0; li < s.lights.size(); ++li) {
        const auto& l = s.lights[li];
        nlohmann::json light = {{"index", li},
                                {"type", to_string(scenario.lights[li].type)},
                                {"source", scenario.lights[li].origin},
                                {"pixels",
                                 {{"surface", l.surface},
                                  {"lightable", l.lightable},
                                  {"shadowed", l.shadowed},
                                  {"uncertain", l.uncertain}}}};
        if (const double diameter = scenario.lights[li].angular_diameter_rad; diameter > 0)
            light["angular_diameter_deg"] = diameter * 180 / M_PI;
        if (l.area) {
            const OracleAreaStats& a = l.sampling;
            nlohmann::json curve = nlohmann::json::array();
            for (const ConvergencePoint& p : a.convergence)
                curve.push_back({{"rays", p.rays}, {"sampling", p.sampling}, {"mean_E", p.mean_e}, {"max_E", p.max_e}});
            light["sampling"] = {{"rays", a.rays},
                                 {"rays_per_pixel", {{"mean", a.rays_per_pixel_mean}, {"max", a.rays_per_pixel_max}}},
                                 {"refined_pixels", a.refined},
                                 {"capped_pixels", a.capped},
                                 {"convergence", curve}};
        }
        lights.push_back(light);
    }
    const OracleSettings& settings = result.settings;
    nlohmann::json sampling = {{"seed", settings.seed},
                               {"target_E", settings.area_target},
                               {"max_rays", settings.area_max_rays},
                               {"uniform_rays", settings.area_uniform_rays}};
    double trace_total = s.trace_s + s.area_s + s.boundary_s;
    // The nodes the camera saw most from behind (pipeline/facing.h reads them back), at most
    // kCulledNodesListed; the cache keeps them with the frame.
    auto culled = s.culled_by_node;
    std::sort(culled.begin(), culled.end(), [](const auto& a, const auto& b) {
        return a.second != b.second ? a.second > b.second : a.first < b.first;
    });
    if (culled.size() > kCulledNodesListed) culled.resize(kCulledNodesListed);
    nlohmann::json culled_nodes = nlohmann::json::array();
    for (const auto& [node, n] : culled) culled_nodes.push_back({{"node", node}, {"pixels", n}});
    std::uint64_t rays = s.primary_rays + s.shadow_rays + s.boundary_rays + s.verified_retraces + s.culled_retraces;
    nlohmann::json j = {
        {"scenario", scenario.file.string()},
        {"scene", scene_files_json(scenario)},
        {"image", {{"width", f.width}, {"height", f.height}}},
        {"triangles", scenario.scene.triangle_count()},
        {"frame_origin", {f.frame_origin.x, f.frame_origin.y, f.frame_origin.z}},
        {"rays",
         {{"primary", s.primary_rays},
          {"shadow", s.shadow_rays},
          {"boundary", s.boundary_rays},
          {"verified_retraces", s.verified_retraces},
          {"culled_retraces", s.culled_retraces}}},
        {"culled_by_node", std::move(culled_nodes)},
        {"mrays_per_s", trace_total > 0 ? rays / trace_total * 1e-6 : 0.0},
        {"seconds",
         {{"load", timings.load_s},
          {"build", s.build_s},
          {"frame", s.frame_s},
          {"trace", s.trace_s},
          {"area", s.area_s},
          {"boundary", s.boundary_s},
          {"write", timings.write_s}}},
        {"boundary_seconds",
         {{"locate", s.boundary_parts.locate_s},
          {"merge", s.boundary_parts.merge_s},
          {"grid", s.boundary_parts.grid_s},
          {"sweeps", s.boundary_parts.sweeps_s},
          {"lists", s.boundary_parts.lists_s},
          {"pixels", s.boundary_parts.pixels_s}}},
        {"write_seconds", write_seconds},
        {"threads", s.threads},
        {"embree", s.embree_version},
        {"lights", lights},
        {"area_sampling", sampling},
        {"warnings", scenario.scene.warnings},
    };
    return j;
}

}  // namespace penumbra
