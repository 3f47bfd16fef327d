// Image files in one place: the only code that links OpenImageIO. Each file is staged in an
// OutputTransaction, so it appears only when the transaction commits.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/output_files.h"

namespace penumbra {

// One named channel of an EXR image; exactly one of the two vectors is filled.
struct ExrChannel {
    std::string name;
    std::vector<float> f32;
    std::vector<std::uint32_t> u32;
};

// A zip-compressed EXR of float and uint channels, bit-identical from run to run.
void write_exr(OutputTransaction& out, const std::string& name, int width, int height,
               const std::vector<ExrChannel>& channels);
// 8-bit sRGB-encoded RGB image, linear input in [0, 1] per channel, row-major.
void write_png(OutputTransaction& out, const std::string& name, int width, int height, const std::vector<float>& rgb);

}  // namespace penumbra
