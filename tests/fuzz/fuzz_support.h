// Shared by the libFuzzer targets: a private scratch folder and the rule every target checks,
// that bad input ends as an InputError (exit 2) and never as anything else.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>

#include "common/alpha_coverage.h"
#include "common/errors.h"

namespace penumbra::fuzz {

// A cut-out's image is decoded by image_io (OpenImageIO, not fuzzed here; these targets link
// common alone): a stand-in decodes every image to one opaque texel, so that the loader's
// material, sampler, texture-transform and attribute checks are fuzzed through to the end.
inline AlphaTexture one_texel(const EncodedImage& e) {
    AlphaTexture t;
    t.width = t.height = 1;
    t.alpha = {65535};
    t.label = e.label;
    return t;
}
inline void stand_in_for_images() {
    set_alpha_image_decoder(&one_texel);
}

// Memory a fuzzed scene may ask for before it is refused: well under -rss_limit_mb.
inline constexpr std::uint64_t kMaxMemory = 1ull << 30;

// $PENUMBRA_FUZZ_SCRATCH when set (run.sh puts the seeds' external .bin buffers there), else a
// folder of this process under the system's temporary folder.
inline const std::filesystem::path& scratch() {
    static const std::filesystem::path dir = [] {
        const char* env = std::getenv("PENUMBRA_FUZZ_SCRATCH");
        auto d = env && *env ? std::filesystem::path(env)
                             : std::filesystem::temp_directory_path() / ("penumbra-fuzz-" + std::to_string(::getpid()));
        std::filesystem::create_directories(d);
        return d;
    }();
    return dir;
}

inline std::filesystem::path write_file(const std::string& name, const std::uint8_t* data, std::size_t size) {
    std::filesystem::path p = scratch() / name;
    std::ofstream(p, std::ios::binary | std::ios::trunc)
        .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    return p;
}

// Runs `f`: InputError is the expected answer to bad input; any other exception would reach
// the user as exit 3 or 4, so it is a finding and aborts.
template <class F>
void expect_input_errors_only(F&& f) {
    try {
        f();
    } catch (const InputError&) {
    } catch (const std::exception& e) {
        std::fprintf(stderr, "unexpected exception (not an InputError): %s\n", e.what());
        std::abort();
    }
}

}  // namespace penumbra::fuzz
