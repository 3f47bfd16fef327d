// The averaged-hard-shadows family (reference 001; raster/area_lights.h): each area light is
// drawn as technique.area_samples point lights spread over it by the depth-map family, and
// their verdicts are averaged. Punctual lights pass through unchanged.
#include "raster/area_lights.h"
#include "raster/technique_family.h"

namespace penumbra::raster {

namespace {

class AveragedAreaFamily final : public TechniqueFamily {
  public:
    explicit AveragedAreaFamily(const SceneOnGpu& scene) : depth_maps_(make_depth_map_family(scene)) {}

    void render(const Technique& t, std::span<const Light> lights, const RenderOptions& options, RasterFrame& frame,
                RasterStats& stats) override {
        const ExpandedLights expanded = expand_area_lights({lights.begin(), lights.end()}, t);
        RasterResult drawn;
        drawn.stats = std::move(stats);
        depth_maps_->render(expand_light_overrides(expanded, t), expanded.lights, options, drawn.frame, drawn.stats);
        RasterResult folded = fold_area_lights(expanded, std::move(drawn));
        for (auto& img : folded.frame.lights) frame.lights.push_back(std::move(img));
        stats = std::move(folded.stats);
    }

  private:
    std::unique_ptr<TechniqueFamily> depth_maps_;
};

}  // namespace

std::unique_ptr<TechniqueFamily> make_averaged_area_family(const SceneOnGpu& scene) {
    return std::make_unique<AveragedAreaFamily>(scene);
}

}  // namespace penumbra::raster
