// The verdict per pixel on the GPU, for the hot loops (sweep, tune): the same classes, counts
// and sums as score_frames (metrics/classification.h, the reference), computed where the
// raster path left its output, with only the numbers read back (docs/metrics.md, "Scoring on
// the GPU"). What the oracle fixed per pixel is uploaded once per session; each render costs
// one compute pass over its lights, one invocation per image row, so every sum runs in the
// CPU's order and in double, and every float operation is the CPU's own: counts and sums are
// identical, not close. Images (class maps, errors, the perceptual error) are read back only
// when a light's ScoringOptions::perceptual or `images` asks for them.
#pragma once

#include <memory>
#include <optional>
#include <span>

#include "metrics/classification.h"
#include "raster/raster.h"
#include "raster/vulkan_context.h"

namespace penumbra::metrics {

enum class Scorer : std::uint8_t { cpu, gpu };
std::string_view to_string(Scorer s);

// The scorer the hot loops use on this device: the GPU's where the device has shaderFloat64,
// except on a CPU device (lavapipe), where the CPU classifier measured faster (docs/sweep.md,
// "Scoring on the GPU"). $PENUMBRA_SCORER=cpu or gpu overrides (gpu still needs shaderFloat64).
Scorer preferred_scorer(const raster::VulkanContext& ctx);

class GpuScorer {
  public:
    // `oracle` and `camera` (any frame of the session whose renders will be scored: its A and
    // prim are the session's camera pass) must describe the same image; `oracle` must outlive
    // the scorer. Throws std::invalid_argument when they differ, EnvironmentError when the
    // device lacks shaderFloat64 or a Vulkan call fails.
    GpuScorer(const raster::VulkanContext& ctx, const OracleFrame& oracle, const RasterFrame& camera);
    ~GpuScorer();
    GpuScorer(const GpuScorer&) = delete;
    GpuScorer& operator=(const GpuScorer&) = delete;

    // Scores a render made with RenderOptions::read_back off, like score_frames. nullopt when it
    // cannot: a light whose output was read back instead of left on the device, or a V-only
    // light without both scales given (their estimation sorts samples: the CPU's work). The
    // caller then renders with read-back and calls score_frames. FrameScore::images are filled
    // for the lights whose options ask for the perceptual error, or for all with `images`.
    std::optional<FrameScore> score(const raster::RasterResult& rendered, std::span<const ScoringOptions> options,
                                    bool images = false);

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace penumbra::metrics
