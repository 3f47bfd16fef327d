// A perceptual error in the spirit of NVIDIA FLIP (Andersson et al. 2020, "FLIP: A Difference
// Evaluator for Alternating Images"), restricted to what a visibility image is: luminance only.
// Kept from FLIP: the achromatic contrast-sensitivity filter (a Gaussian of variance
// b1/(2 pi^2) deg^2, b1 = 0.0047) before the colour difference; the difference in CIE L*
// raised to 0.7 (FLIP's q_c); edge and point features from first and second Gaussian
// derivatives (width 0.082 deg) and their difference raised to 0.5 (q_f); the combination
// e = e_c^(1 - e_f). Left out: the chromatic channels and Hunt adjustment (V has no colour),
// and FLIP's colour-difference compression above p_c (the achromatic range is normalised
// to [0, 1] instead). The displayed image is luminance Y = V.
#pragma once

#include <memory>
#include <vector>

namespace penumbra::metrics {

// Per-pixel error in [0, 1] between two visibility images (row-major, width x height),
// viewed at `pixels_per_degree` (67: a 0.7 m distance from a 24" 4K screen, FLIP's default).
std::vector<float> perceptual_error(const std::vector<float>& reference, const std::vector<float>& test, int width,
                                    int height, double pixels_per_degree);

// One reference picture scored against many test pictures (sweep scores every configuration's
// render against the same oracle picture): the reference's half of the work (its filtered
// lightness and features) is done once, over the whole image, on the first error(). error(test)
// equals perceptual_error(picture, test, ...) bit for bit: every row it keeps is filtered from
// the same rows in the same order.
class PerceptualReference {
  public:
    PerceptualReference(std::vector<float> picture, int width, int height, double pixels_per_degree);
    ~PerceptualReference();
    PerceptualReference(PerceptualReference&&) noexcept;
    PerceptualReference& operator=(PerceptualReference&&) = delete;

    std::vector<float> error(const std::vector<float>& test);
    double pixels_per_degree() const { return pixels_per_degree_; }

  private:
    struct Filters;
    std::vector<float> picture_;
    int width_, height_;
    double pixels_per_degree_;
    std::unique_ptr<Filters> filters_;
};

}  // namespace penumbra::metrics
