// Which side of the surface the camera sees (docs/metrics.md, "Facing"). Both paths cull the
// back of a single-sided triangle for the camera, as a rasteriser does (docs/design.md): a mesh
// with inverted winding, or an open mesh seen from inside, is then seen through, and the pixel
// shows what lies behind it. The verdict judges the scene as it is; these diagnostics say when a
// mesh was seen so, from the oracle's count of the back faces its primary rays met first
// (oracle.json's culled_by_node) and the pixels each node shows.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/frames.h"
#include "common/scenario.h"

namespace penumbra {

struct MeshFacing {
    std::string mesh;               // Scene::node_label
    std::uint64_t seen = 0;         // pixels showing its front (or either side, double-sided)
    std::uint64_t from_behind = 0;  // pixels whose ray met its back first, and went through
    std::uint64_t pixels() const { return seen + from_behind; }
    double share() const { return pixels() ? double(from_behind) / double(pixels()) : 0.0; }
};

struct FacingReport {
    std::uint64_t frame_px = 0;      // the image's pixels
    std::uint64_t from_behind = 0;   // of those, rays that met a single-sided back face first
    std::vector<MeshFacing> meshes;  // the nodes seen mostly from behind, most such pixels first
    double share() const { return frame_px ? double(from_behind) / double(frame_px) : 0.0; }
};

// A node is named when at least kFacingWarnShare of its pixels meet its back and those pixels are
// at least kFacingMinShare of the frame: a closed mesh's silhouette never is, a terrain with
// inverted winding always. At most kFacingMeshes nodes are named.
inline constexpr double kFacingWarnShare = 0.5, kFacingMinShare = 0.01;
inline constexpr std::size_t kFacingMeshes = 5;

// From the oracle's frame and its oracle.json (a cached run's too).
FacingReport facing_of(const Scenario& scenario, const OracleFrame& frame, const nlohmann::json& oracle_info);

// One warning per named node, e.g. `terrain.glb: nodes[0] "Ground": 97% of its 41230 pixels
// meet the back of single-sided triangles ...`.
std::vector<std::string> facing_warnings(const FacingReport& report);

// report.json's "facing": {"frame_px", "from_behind_px", "share", "meshes": [...]}.
nlohmann::json to_json(const FacingReport& report);

}  // namespace penumbra
