#include "raster/raster_output.h"

#include <initializer_list>

#include "raster/technique_family.h"

namespace penumbra::raster {

namespace {

nlohmann::json matrix_json(const glm::dmat4& m) {
    nlohmann::json rows = nlohmann::json::array();
    for (int r = 0; r < 4; ++r) rows.push_back({m[0][r], m[1][r], m[2][r], m[3][r]});
    return rows;
}

// A pass list as {name: ms}, with `always` present (0 when the pass did not run).
nlohmann::json pass_json(const PassTimes& times, std::initializer_list<const char*> always) {
    nlohmann::json j = nlohmann::json::object();
    for (const char* name : always) j[name] = times[name];
    for (const auto& [name, ms] : times.entries) j[name] = ms;
    return j;
}

const char* projection_name(const Light& l) {
    return l.type == LightType::directional ? "orthographic" : l.type == LightType::spot ? "perspective" : "cube";
}

}  // namespace

nlohmann::json timestamps_json(const DeviceInfo& device) {
    nlohmann::json j = {{"period_ns", device.timestamp_period_ns},
                        {"calibration", device.calibration.empty() ? "none" : device.calibration},
                        {"time_domains", device.time_domains}};
    if (device.calibration_deviation_ns >= 0) j["calibration_deviation_ns"] = device.calibration_deviation_ns;
    return j;
}

nlohmann::json raster_json(const Scenario& scenario, const Technique& technique, const RasterResult& result,
                           const RasterTimings& timings) {
    const RasterStats& s = result.stats;
    const RasterFrame& f = result.frame;
    const FamilyEntry& family = family_of(technique);
    nlohmann::json lights = nlohmann::json::array();
    for (std::size_t li = 0; li < s.lights.size(); ++li) {
        const RasterLightStats& l = s.lights[li];
        const Light& light = scenario.lights[li];
        // The light's first view stands for it in the keys older than the view list.
        const ShadowView first = l.views.empty() ? ShadowView{} : l.views[0];
        nlohmann::json layers = nlohmann::json::array();
        for (std::size_t k = 0; k < l.views.size(); ++k) {
            const ShadowView& v = l.views[k];
            nlohmann::json layer = {{"view_proj", matrix_json(v.view_proj)},
                                    {"rendered", (l.layers_sampled >> k & 1u) != 0},
                                    {"kind", to_string(v.kind)},
                                    {"axis", {v.axis.x, v.axis.y, v.axis.z}},
                                    {"near", v.near},
                                    {"far", v.far}};
            if (v.kind == ViewKind::cube_face) layer["face"] = v.name;
            if (v.kind == ViewKind::cascade) {
                layer["cascade"] = k;
                layer["split"] = {{"near_m", v.split_near}, {"far_m", v.split_far}};
                layer["half_extent"] = {v.half_extent.x, v.half_extent.y};
            }
            if (v.kind == ViewKind::ortho || v.kind == ViewKind::cascade)
                layer["metres_per_texel"] = v.metres_per_texel;
            else
                layer["metres_per_texel_per_metre"] = v.metres_per_texel_per_metre;
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
                            {"projection", first.kind == ViewKind::cascade ? "cascades" : projection_name(light)},
                            {"near", first.near},
                            {"far", first.far},
                            {"layers", layers},
                            {"layers_rendered", l.layers_rendered},
                            {"map_reused", l.map_reused},
                            {"map_triangle_ids", l.map_triangle_ids},
                            {"pixels", {{"surface", surface}, {"fully_lit", lit}, {"outside_map", outside}}},
                            {"gpu_ms", pass_json(l.gpu_ms, {"shadow", "lookup"})}};
        // What the family says of the light (the depth maps: how an area light was drawn).
        if (family.describe_light) j.update(family.describe_light(technique, light, l));
        if (first.kind == ViewKind::ortho || first.kind == ViewKind::cascade) {
            j["metres_per_texel"] = first.metres_per_texel;
            j["half_extent"] = {first.half_extent.x, first.half_extent.y};
        } else {
            j["metres_per_texel_per_metre"] = first.metres_per_texel_per_metre;
        }
        lights.push_back(j);
    }
    // Every pass the family timed, and the keys readers know even when a pass did not run.
    nlohmann::json gpu_ms = pass_json(s.gpu_ms, {"shadow", "lookup", "layer_mask"});
    gpu_ms["camera_raster"] = s.camera_ms;
    gpu_ms["camera"] = s.camera_ms + s.gpu_ms["lookup"];
    // What each figure of gpu_ms includes, as the family said it.
    nlohmann::json gpu_passes = nlohmann::json::object();
    for (const auto& [name, what] : s.gpu_ms.includes) gpu_passes[name] = what;
    gpu_passes["camera_raster"] = "the session's camera pass (triangle id per pixel), drawn once per session";
    gpu_passes["camera"] = "camera_raster + lookup";
    nlohmann::json j = {
        {"scenario", scenario.file.string()},
        {"scene", scene_files_json(scenario)},
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
          {"vulkan", s.device.api_version},
          {"timestamps", timestamps_json(s.device)}}},
        {"gpu_ms", gpu_ms},
        {"gpu_passes", gpu_passes},
        {"seconds",
         {{"load", timings.load_s}, {"device", timings.device_s}, {"setup", s.setup_s}, {"render", s.render_s}}},
        {"lights", lights},
        {"warnings", s.warnings},
    };
    if (timings.threads > 0) j["threads"] = timings.threads;
    return j;
}

}  // namespace penumbra::raster
