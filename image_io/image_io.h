// Image files in one place: the only code that links OpenImageIO. Each file is staged in an
// OutputTransaction, so it appears only when the transaction commits.
#pragma once

#include <cstdint>
#include <filesystem>
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

// An image as read from a file: every channel as float, row 0 at the top. Integer formats are
// normalised to [0, 1] by OpenImageIO (an 8-bit 255 reads as 1.0).
struct ImageFile {
    int width = 0, height = 0;
    std::vector<std::string> channel_names;  // as stored ("R", "G", "light0.V", "Z", ...)
    std::vector<std::vector<float>> channels;
    std::string format;     // "openexr", "png", ...
    int bits = 0;           // bits per channel of the stored data
    bool floating = false;  // stored as float or half (values are not normalised)
};

// Reads any format OpenImageIO reads (first subimage, first MIP level). Throws InputError naming
// the file when it is missing, unreadable, or deep/tiled beyond what OIIO reads as scanlines.
ImageFile read_image(const std::filesystem::path& file);

}  // namespace penumbra
