#include "pipeline/facing.h"

#include <fmt/format.h>

#include <algorithm>
#include <unordered_map>

namespace penumbra {

FacingReport facing_of(const Scenario& scenario, const OracleFrame& frame, const nlohmann::json& oracle_info) {
    FacingReport r;
    const Scene& scene = scenario.scene;
    r.frame_px = frame.pixel_count();
    std::unordered_map<std::uint32_t, MeshFacing> by_node;
    const auto culled = oracle_info.find("culled_by_node");
    if (culled == oracle_info.end() || !culled->is_array()) return r;  // an oracle.json without it
    for (const nlohmann::json& e : *culled) {
        const auto node = e.value("node", std::uint32_t{0});
        const auto n = e.value("pixels", std::uint64_t{0});
        by_node[node].from_behind += n;
        r.from_behind += n;
    }
    if (r.from_behind == 0) return r;
    for (const std::uint32_t t : frame.prim) {
        if (t == kNoPrimitive || t >= scene.triangle_node.size()) continue;
        if (const auto it = by_node.find(scene.triangle_node[t]); it != by_node.end()) ++it->second.seen;
    }
    for (auto& [node, m] : by_node)
        if (m.share() >= kFacingWarnShare && double(m.from_behind) >= kFacingMinShare * double(r.frame_px)) {
            m.mesh = scene.node_label(node);
            r.meshes.push_back(m);
        }
    std::sort(r.meshes.begin(), r.meshes.end(), [](const MeshFacing& a, const MeshFacing& b) {
        return a.from_behind != b.from_behind ? a.from_behind > b.from_behind : a.mesh < b.mesh;
    });
    if (r.meshes.size() > kFacingMeshes) r.meshes.resize(kFacingMeshes);
    return r;
}

std::vector<std::string> facing_warnings(const FacingReport& report) {
    std::vector<std::string> out;
    for (const MeshFacing& m : report.meshes)
        out.push_back(fmt::format(
            "{}: {:.0f}% of its {} pixels meet the back of single-sided triangles, which the camera culls and "
            "sees through (inverted winding, or an open mesh seen from inside); the verdict judges the scene as it "
            "is: fix the winding, or make its material doubleSided",
            m.mesh, 100.0 * m.share(), m.pixels()));
    return out;
}

nlohmann::json to_json(const FacingReport& report) {
    nlohmann::json meshes = nlohmann::json::array();
    for (const MeshFacing& m : report.meshes)
        meshes.push_back(
            {{"mesh", m.mesh}, {"pixels", m.pixels()}, {"from_behind_px", m.from_behind}, {"share", m.share()}});
    return {{"frame_px", report.frame_px},
            {"from_behind_px", report.from_behind},
            {"share", report.share()},
            {"meshes", std::move(meshes)}};
}

}  // namespace penumbra
