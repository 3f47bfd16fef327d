// Reading images goes through OpenImageIO in a plugin that is loaded on the first read: OIIO
// brings ~260 shared libraries whose relocation costs every process ~0.25 s at start-up
// (docs/oracle.md section 9), and most runs only write EXR and PNG, which image_io does with
// OpenEXR and libpng directly.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "common/alpha_coverage.h"
#include "image_io/image_io.h"

namespace penumbra {

enum class OiioReadStatus : int {
    ok,
    bad_input,   // the file is not an image OIIO reads as a flat 2D picture (an InputError)
    failed,      // OIIO failed for another reason
    wrong_size,  // the header's size is not the one asked for: image's width and height say it, no pixels read
};

// The plugin's one entry point, `penumbra_oiio_read_sized`: fills `image` or writes `error`.
// width, height > 0: refuse another size from the header, before decoding (wrong_size).
using OiioReadFn = OiioReadStatus (*)(const char* path, int width, int height, ImageFile* image, std::string* error);

// `penumbra_oiio_read_alpha`: an image's alpha (1 where it has none), from `data` (size bytes,
// `name`'s extension naming the format) or, where data is null, from the file `name`. Refuses
// (wrong_size, image's width and height set, nothing decoded) an image whose header declares
// more than max_side pixels a side or max_pixels in all.
using OiioReadAlphaFn = OiioReadStatus (*)(const char* name, const void* data, std::size_t size, int max_side,
                                           std::uint64_t max_pixels, AlphaTexture* image, std::string* error);

struct OiioPlugin {
    OiioReadFn read = nullptr;
    OiioReadAlphaFn read_alpha = nullptr;
};

// Loads the plugin on first use (thread-safe). Throws EnvironmentError naming where it looked
// when it cannot be found or loaded.
const OiioPlugin& oiio_plugin();

}  // namespace penumbra
