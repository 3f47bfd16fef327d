// Technique families as plug-ins (docs/raster.md, "Adding a technique family"). A family is
// one way of turning the scene into a shadow factor per pixel and light (depth maps with
// their filters and biases; averaged hard shadows for area lights; next: cascades, moment
// maps, shadow volumes). It owns its passes, GPU resources, lookup and diagnostics, builds
// them on first use and keeps them for the session's next render, redoing only what a new
// technique changes. The session owns what every family shares (SceneOnGpu).
#pragma once

#include <deque>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/frames.h"
#include "common/json_reader.h"
#include "common/memory_estimate.h"
#include "common/scene.h"
#include "raster/gpu_passes.h"
#include "raster/knobs.h"
#include "raster/raster.h"
#include "raster/technique.h"

namespace penumbra::raster {

// What every family draws from, made once per session: the scene in the camera-centred frame
// on the GPU and the camera pass (the triangle seen per pixel) that the lookups start from.
struct SceneOnGpu {
    const Scenario& scenario;
    const VulkanContext& ctx;
    Camera camera;                                     // what the camera pass drew: the scenario's, or a path's frame
    glm::dvec3 origin{0.0};                            // world position of the frame (the camera eye)
    Precision precision = Precision::camera_relative;  // of the uploaded positions (Technique::precision)
    std::uint32_t width = 0, height = 0;
    std::size_t pixels = 0;
    // The positions as uploaded (raster/surface_seen.h, drawn_positions): camera-relative floats;
    // world_float32 rounds to float in world space first. For the families' CPU passes.
    std::vector<glm::vec3> drawn_positions;
    // drawn_positions, uint3 per triangle, bits
    GpuBuffer positions, indices, double_sided;
    std::uint32_t index_count = 0;
    // Consecutive triangles of one doubleSided value, in triangle order: what a shadow pass with
    // cull material draws one by one (a glTF primitive's triangles are one run).
    // Where the scene has cut-outs, runs are of one cut-out-or-not value too (draw_casters draws
    // the cut-outs' runs with the alpha test).
    struct SidedRun {
        std::uint32_t first = 0, count = 0;  // triangles
        bool double_sided = false;
        AlphaMode alpha = AlphaMode::opaque;  // MASK and BLEND runs: the technique's alpha rules
    };
    std::vector<SidedRun> sided_runs;
    // Cut-outs (raster/cutouts.h, shaders/cutout.glsl): set only where the scene has them.
    bool has_cutouts = false;  // MASK or BLEND materials (their buffers and set are made)
    bool has_masks = false;    // MASK materials
    GpuBuffer cutout_uv, cutout_alpha, cutout_of_triangle, cutout_materials, cutout_texels;
    std::unique_ptr<DescriptorSets> cutout_set;  // one set: the cut-out bindings, vertex and fragment stages
    GpuImage gbuffer_prim;                       // R32_UINT, GENERAL layout after the camera pass: triangle per pixel
    glm::mat4 camera_view_proj{1.0f};  // the camera pass's clip space (reversed depth), for families that redraw it
    std::vector<float> A;              // 1 where a triangle covers the pixel
    std::vector<std::uint32_t> prim;
    double camera_ms = 0;           // GPU time of the camera pass
    std::uint64_t camera_pass = 0;  // RasterStats::camera_pass of this pass
};

class TechniqueFamily {
  public:
    virtual ~TechniqueFamily() = default;
    // Draws every light of `lights` (the scenario's, in order) with `technique` into
    // frame.lights and stats.lights (one entry per light each), adding GPU times to `stats`.
    virtual void render(const Technique& technique, std::span<const Light> lights, const RenderOptions& options,
                        RasterFrame& frame, RasterStats& stats) = 0;
};

// What the metrics need to know of a technique to judge its pixels (docs/metrics.md).
struct ScoringHints {
    double filter_reach_texels = 1;  // aliasing band: texel footprints around a true boundary
    double depth_quantum = 0;        // acne: depth differences below this are rounding (depth units)
    bool light_bleeding = false;     // a moment family: a lit true umbra is light_bleeding (docs/metrics.md)
    // No texels and no bias (shadow volumes, planar projection): V-only scoring is given a
    // footprint and a bias reach of 0, so no wrong pixel is excused as aliasing or peter-panning
    // (docs/metrics.md).
    bool exact = false;
    // A layered family whose lookups record the layer each pixel read (cascades): report.json's
    // light gets the pixels and error rates of each layer under this key (docs/raster.md,
    // "Cascaded shadow maps"); empty: none.
    std::string layer_report;
    // The usual causes of missing shadows (false_lit) under this family, for the verdict's hint
    // ("shadows missing: " + this); empty: a shadow map's (casters clipped, culled or outside the
    // map). A family without a map names its own, never a map's.
    std::string false_lit_cure;
};

// A registered family (pbrt-v4's `Create` is the model): everything the rest of penumbra asks of
// a technique goes through its family's entry, so that validate, the memory estimate,
// raster.json, tune and sweep do not read one family's fields. Picked by the technique's
// "family" key (parse_technique), never by trying each in turn.
struct FamilyEntry {
    std::string name;  // the "family" key's value
    std::string description;
    // Capabilities, said rather than inferred from a technique's fields: the family draws shadow
    // maps (resolution, depth_format, fit and the map's bias mean something; shadow volumes and
    // planar projection draw none).
    bool draws_maps = true;
    // Reads the family's keys (every key but "preset", "family" and "precision") from `o` into
    // `t`, checked: bad values fail through `o` (InputError, exit 2, naming the key path). Keys
    // it does not read are refused as unknown afterwards.
    std::function<void(JsonObject& o, Technique& t)> parse;
    // Writes the keys `parse` reads, every one resolved, into `j`: parse(write(t)) == t.
    std::function<void(const Technique& t, nlohmann::json& j)> write;
    std::function<ScoringHints(const Technique& t)> hints;
    // The plain numbers of common/memory_estimate.h for this technique.
    std::function<RasterMemory(const Technique& t)> memory;
    // Keys the family adds to light `light`'s object in raster.json (may be unset: none).
    std::function<nlohmann::json(const Technique& t, const Light& light, const RasterLightStats& stats)> describe_light;
    // The knobs tune searches (raster/knobs.h: name, technique key, range, unit, scale, how the
    // value is read and written), declared by the family: tune has no list of its own.
    std::vector<KnobDecl> knobs;
    // Technique keys (dotted paths) sweep may vary besides the knobs' keys, for help and docs;
    // sweep_keys_of gives both.
    std::vector<std::string> sweep_keys;
    std::function<std::unique_ptr<TechniqueFamily>(const SceneOnGpu&)> make;
};

// Every family, the built-in ones (depth_map, averaged_area) first, then those registered.
// References stay valid for the program's life.
const std::deque<FamilyEntry>& technique_families();
// Every technique key sweep may vary for `family`: its knobs' keys, then its sweep_keys.
std::vector<std::string> sweep_keys_of(const FamilyEntry& family);
// The family called `name`, or null.
const FamilyEntry* find_technique_family(std::string_view name);
// The family of `t` (its `family` must be registered: parse_technique makes sure of that).
const FamilyEntry& family_of(const Technique& t);
// Adds a family that techniques can then name in "family" (docs/raster.md, "Adding a technique
// family"). Register before parsing techniques; not thread-safe. Throws std::invalid_argument
// for an empty or taken name or a missing parse, write, hints, memory or make.
void register_technique_family(FamilyEntry entry);

// The built-in families (each in its own file), and their drawing alone.
FamilyEntry depth_map_family_entry();
FamilyEntry averaged_area_family_entry();
FamilyEntry cascaded_family_entry();           // raster/cascades.cpp: draws with make_depth_map_family
FamilyEntry planar_projection_family_entry();  // raster/planar_projection.cpp
std::unique_ptr<TechniqueFamily> make_depth_map_family(const SceneOnGpu& scene);
std::unique_ptr<TechniqueFamily> make_averaged_area_family(const SceneOnGpu& scene);
void add_filterable_families(std::deque<FamilyEntry>& families);  // vsm, esm, evsm2, evsm4, msm (raster/filterable.cpp)
FamilyEntry shadow_volume_family_entry();                         // raster/shadow_volume.cpp

}  // namespace penumbra::raster
