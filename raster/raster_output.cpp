#include "raster/raster_output.h"

namespace penumbra::raster {

namespace {

nlohmann::json matrix_json(const glm::dmat4& m) {
    nlohmann::json rows = nlohmann::json::array();
    for (int r = 0; r < 4; ++r) rows.push_back({m[0][r], m[1][r], m[2][r], m[3][r]});
    return rows;
}

const char* projection_name(const Light& l) {
    return l.type == LightType::directional ? "orthographic" : l.type == LightType::spot ? "perspective" : "cube";
}

}  // namespace

nlohmann::json raster_json(const Scenario& scenario, const Technique& technique, const RasterResult& result,
                           const RasterTimings& timings) {
    const RasterStats& s = result.stats;
    const RasterFrame& f = result.frame;
    static const char* kFaces[] = {"+x", "-x", "+y", "-y", "+z", "-z"};
    nlohmann::json lights = nlohmann::json::array();
    for (std::size_t li = 0; li < s.lights.size(); ++li) {
        const RasterLightStats& l = s.lights[li];
        const Light& light = scenario.lights[li];
        nlohmann::json layers = nlohmann::json::array();
        for (std::size_t k = 0; k < l.projection.view_proj.size(); ++k) {
            nlohmann::json layer = {{"view_proj", matrix_json(l.projection.view_proj[k])},
                                    {"rendered", (l.layers_sampled >> k & 1u) != 0}};
            if (l.projection.view_proj.size() == 6) layer["face"] = kFaces[k];
            layers.push_back(layer);
        }
        std::size_t surface = 0, lit = 0, outside = 0;
        const RasterLightImage& img = f.lights[li];
        for (std::size_t i = 0; i < f.pixel_count(); ++i) {
            if (f.A[i] == 0) continue;
            ++surface;
            lit += img.V[i] >= 1.0f;
            outside += img.lookups && (img.lookups->flags[i] & kRasterOutsideMap) != 0;
        }
        nlohmann::json j = {{"index", li},
                            {"type", to_string(light.type)},
                            {"source", light.origin},
                            {"projection", projection_name(light)},
                            {"near", l.projection.near},
                            {"far", l.projection.far},
                            {"layers", layers},
                            {"layers_rendered", l.layers_rendered},
                            {"map_reused", l.map_reused},
                            {"pixels", {{"surface", surface}, {"fully_lit", lit}, {"outside_map", outside}}},
                            {"gpu_ms", {{"shadow", l.shadow_ms}, {"lookup", l.lookup_ms}}}};
        if (is_area_light(light.type)) {
            // Which soft-shadow method drew it, and from how many cube maps (raster/area_lights.h).
            const bool averaged = technique.area_samples > 0;
            j["area"] = {{"method", averaged                                    ? "averaged_hard_shadows"
                                    : technique.filter.type == FilterType::pcss ? "pcss"
                                                                                : "centre_point"},
                         {"maps", averaged ? technique.area_samples : 1}};
        }
        if (l.projection.perspective)
            j["metres_per_texel_per_metre"] = l.projection.metres_per_texel_per_metre;
        else {
            j["metres_per_texel"] = l.projection.metres_per_texel;
            j["half_extent"] = {l.projection.half_extent.x, l.projection.half_extent.y};
        }
        lights.push_back(j);
    }
    return {
        {"scenario", scenario.file.string()},
        {"scene", scenario.scene_file.string()},
        {"image", {{"width", f.width}, {"height", f.height}}},
        {"triangles", scenario.scene.triangle_count()},
        {"technique", technique.to_json()},
        {"family", s.family},
        {"hw2x2", s.hw2x2},
        {"frame_origin", {f.frame_origin.x, f.frame_origin.y, f.frame_origin.z}},
        {"matrices_note", "view_proj maps world positions minus frame_origin to Vulkan clip space (depth 0..1)"},
        {"device",
         {{"name", s.device.name},
          {"type", s.device.type},
          {"driver", s.device.driver},
          {"vulkan", s.device.api_version}}},
        {"gpu_ms",
         {{"shadow", s.shadow_ms},
          {"camera", s.camera_ms + s.lookup_ms},
          {"camera_raster", s.camera_ms},
          {"lookup", s.lookup_ms},
          {"layer_mask", s.mask_ms}}},
        {"seconds",
         {{"load", timings.load_s}, {"device", timings.device_s}, {"setup", s.setup_s}, {"render", s.render_s}}},
        {"lights", lights},
        {"warnings", s.warnings},
    };
}

}  // namespace penumbra::raster
