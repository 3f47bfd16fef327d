// `compare`: validate with the raster frame replaced by an engine's own shadow image (docs/compare.md).
// The engine renders penumbra's view (`penumbra camera` prints it); penumbra decides which pixels
// show the surface the oracle traced (coverage, from the engine's depth buffer or, without one, by
// leaving out a band around the oracle's silhouettes), refuses a frame that does not line up with
// the scenario's camera, and scores the rest with the metrics' V-only classification
// (docs/metrics.md, "V only"). The result is a ValidateResult, so validate's report, gate, JUnit
// and files serve both commands.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "pipeline/validate.h"

namespace penumbra {

// How the engine's depth buffer stores depth.
enum class DepthSpace {
    linear,  // view depth in metres along the camera's forward axis (0, inf or >= zfar: no surface)
    ndc,     // depth-buffer value in [0, 1]: Vulkan's and D3D's NDC z, GL's window depth (1: no surface)
    ndc_gl,  // GL's NDC z in [-1, 1] (1: no surface)
};
const char* to_string(DepthSpace s);

// An engine's frame, rendered with the scenario's camera and image size (row 0 at the top).
struct EngineFrame {
    int width = 0, height = 0;
    std::vector<std::vector<float>> V;        // per scenario light: the engine's shadow factor, 1 lit, in [0, 1]
    std::optional<std::vector<float>> depth;  // the engine's depth buffer, when it gave one
    DepthSpace depth_space = DepthSpace::linear;
    std::string label = "engine frame";              // for messages: the image file
    std::string depth_label = "engine depth";        // the depth file
    nlohmann::json info = nlohmann::json::object();  // what the caller knows of it (files, channels), for reports
};

struct CompareOptions {
    ValidateOptions validate;                  // oracle, cache, tolerance (the raster fields are unused)
    std::optional<float> texel_footprint_m;    // the engine's shadow-map texel at the receivers, metres
    std::optional<int> shadow_map_resolution;  // or its map's texels per side: the footprint is derived
    std::optional<float> bias_reach_m;         // the engine's biases together, metres along the light ray
    float filter_reach_texels = 1.0f;          // the engine's filter reach (aliasing band), texels
    // The engine filters moments (VSM, ESM, EVSM, MSM): light in a true umbra beyond the filter's
    // reach is light_bleeding, as for penumbra's moment families (docs/metrics.md).
    bool moments = false;
    // Without depth: oracle pixels within this many pixels of a silhouette are left unscored.
    int silhouette_band_px = 1;
    // With depth: the engine saw the oracle's surface where the view depths agree to this fraction.
    double depth_tolerance = 0.01;
    // The least fraction of the oracle's surface pixels the engine must be seen to show (coverage):
    // below it the frame is refused (InputError), not scored (docs/compare.md, "Coverage").
    double min_scored_surface = 0.5;
};

// Coverage of the engine frame against the oracle's (what compare leaves unscored and why).
struct Coverage {
    std::string source;              // "depth" or "silhouette_band"
    std::vector<std::uint8_t> seen;  // 1 where the engine saw the oracle's surface (scored if lightable)
    std::uint64_t surface = 0;       // oracle surface pixels
    std::uint64_t mismatch = 0;      // of those, not seen by the engine (or left out in the band)
    double mismatch_fraction() const { return surface ? double(mismatch) / double(surface) : 0.0; }
};

// The oracle's view depth per pixel, rebuilt exactly from its triangle ids (the cached frame keeps
// none): the camera ray through the pixel centre meets the plane of the triangle it saw. NaN for
// background.
std::vector<double> oracle_view_depth(const Scenario& scenario, const OracleFrame& oracle);

// Which oracle pixels the engine frame shows (see CompareOptions). Throws InputError when the
// frame is misaligned: it matches the oracle much better shifted by a pixel or flipped vertically
// (the message says which, and how much coverage or shadow disagrees either way).
Coverage engine_coverage(const Scenario& scenario, const OracleFrame& oracle, const std::vector<double>& depth,
                         const EngineFrame& frame, const CompareOptions& options);

// Checks the frame against the scenario: size, one V per light, values in [0, 1], no NaN (InputError).
void check_engine_frame(const Scenario& scenario, const EngineFrame& frame);

// The oracle (cached), coverage, the metrics (V only), the gate. result.engine describes the
// frame and result.report has "coverage" and "engine". Throws InputError for a bad or misaligned
// frame, and for one whose coverage leaves less than min_scored_surface of the surface to score.
ValidateResult compare(const Scenario& scenario, const EngineFrame& frame, const CompareOptions& options = {},
                       const metrics::Gate& gate = {});

}  // namespace penumbra
