// Text drawn straight into report images (legends), so a PNG explains itself when it is
// looked at alone. A fixed 5x7 pixel font: no font files to find on a bare machine.
#pragma once

#include <glm/vec3.hpp>
#include <string_view>
#include <vector>

namespace penumbra::report {

inline constexpr int kGlyphWidth = 5, kGlyphHeight = 7, kGlyphAdvance = 6;

// Draws `text` with its top-left corner at (x, y) into a linear RGB image (row-major, 3 floats
// per pixel), each font pixel as a scale x scale block; clipped at the image's edges. Letters
// are drawn as capitals; characters the font lacks are drawn as '?'.
void draw_text(std::vector<float>& rgb, int width, int height, int x, int y, std::string_view text, glm::vec3 colour,
               int scale = 1);

inline int text_width(std::string_view text, int scale = 1) {
    return static_cast<int>(text.size()) * kGlyphAdvance * scale;
}

}  // namespace penumbra::report
