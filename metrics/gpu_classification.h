// The verdict per pixel on the GPU, for the hot loops (sweep, tune): the same classes, counts
// and sums as score_frames (metrics/classification.h, the reference), computed where the
// raster path left its output, with only the numbers read back (docs/metrics.md, "Scoring on
// the GPU"). What the oracle fixed per pixel is uploaded once per session; each render costs
// one compute pass over its lights, one workgroup per image row whose pixels are classified in
// parallel while every double sum runs in the CPU's order, and every float operation is the
// CPU's own: counts and sums are identical, not close. Images (class maps, errors, the
// perceptual error) are read back only when a light's ScoringOptions::perceptual or `images`
// asks for them.
#pragma once

#include <memory>
#include <optional>
#include <span>

#include "metrics/classification.h"
#include "metrics/perceptual.h"
#include "raster/raster.h"
#include "raster/vulkan_context.h"

namespace penumbra::metrics {

enum class Scorer : std::uint8_t { cpu, gpu };
std::string_view to_string(Scorer s);

// The scorer the hot loops use on this device: the GPU's where the device has shaderFloat64,
// except on a CPU device (lavapipe), where the CPU classifier measured faster (docs/sweep.md,
// "Scoring on the GPU"). $PENUMBRA_SCORER=cpu or gpu overrides (gpu still needs shaderFloat64).
Scorer preferred_scorer(const raster::VulkanContext& ctx);

// The perceptual error of a GpuScorer::score, computed apart (on the CPU, perceptual.h) so that
// the caller can overlap it with GPU work: sweep runs it while its timed renders draw.
class DeferredPerceptual {
  public:
    // Fills LightScore::perceptual and the images' perceptual error of `score`, the FrameScore
    // whose score() call filled this, before the scorer's next score() (it reads the scorer's
    // buffers). Then empty.
    void run(FrameScore& score);

  private:
    friend class GpuScorer;
    struct Light {
        std::size_t index = 0;
        // Both pictures, equal wherever the pixel is not scored: the scorer's, valid until its next score().
        const std::vector<float>* truth = nullptr;
        const float* shown = nullptr;
        double pixels_per_degree = 0;
        // The scorer's filtered truth, made on the first run() that needs it and kept for the
        // renders after it: the truth is the same for every render of the session.
        std::optional<PerceptualReference>* reference = nullptr;
    };
    const OracleFrame* oracle_ = nullptr;
    std::vector<Light> lights_;
};

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
    // With `deferred`, the perceptual error is left to deferred->run(score), and the images'
    // class maps and errors are left empty unless `images` asks for them.
    // A render made with RenderOptions::camera_images off is scored when the scorer knows its
    // camera pass (knows_camera), else nullopt.
    std::optional<FrameScore> score(const raster::RasterResult& rendered, std::span<const ScoringOptions> options,
                                    bool images = false, DeferredPerceptual* deferred = nullptr);

    // Whether a render's camera pass is the one the scorer last scored a render with images of:
    // a render of it may then leave the camera images out.
    bool knows_camera(const raster::RasterStats& stats) const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace penumbra::metrics
