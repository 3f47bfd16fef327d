// The OpenImageIO plugin (oiio_plugin.h): read_image's implementation, built as a module that
// image_io loads on the first read so that OIIO's libraries load only in processes that read.
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <string>
#include <vector>

#include "image_io/oiio_plugin.h"

using penumbra::AlphaTexture;
using penumbra::ImageFile;
using penumbra::OiioReadStatus;

namespace {

// Why read_image failed. Some readers (PNG, TIFF) fail a truncated file without a message of
// their own: `what` ("the file", "the data") then ends before its last pixel.
std::string pixels_unread(OIIO::ImageInput& in, const char* what) {
    std::string why = in.geterror();
    if (why.empty()) why = OIIO::geterror();
    if (why.empty()) why = std::string(what) + " ends before its last pixel, or its data is damaged";
    while (!why.empty() && (why.back() == '\n' || why.back() == ' ')) why.pop_back();
    return "cannot read the pixels: " + why;
}

}  // namespace

extern "C" __attribute__((visibility("default"))) OiioReadStatus penumbra_oiio_read_sized(const char* path, int width,
                                                                                          int height, ImageFile* image,
                                                                                          std::string* error) {
    try {
        auto in = OIIO::ImageInput::open(path);
        if (!in) {
            *error = "not an image OpenImageIO can read: " + OIIO::geterror();
            return OiioReadStatus::bad_input;
        }
        const OIIO::ImageSpec& spec = in->spec();
        if (spec.deep) {
            *error = "a deep image; expected a flat image";
            return OiioReadStatus::bad_input;
        }
        if (spec.depth > 1) {
            *error = "a volume image; expected a 2D image";
            return OiioReadStatus::bad_input;
        }
        ImageFile& img = *image;
        img.width = spec.width;
        img.height = spec.height;
        // From the header alone: nothing is decoded for an image of the wrong size.
        if (width > 0 && height > 0 && (img.width != width || img.height != height)) return OiioReadStatus::wrong_size;
        img.format = in->format_name();
        img.bits = static_cast<int>(spec.format.size() * 8);
        img.floating = spec.format.is_floating_point();
        const int nc = spec.nchannels;
        const std::size_t n = static_cast<std::size_t>(img.width) * img.height;
        if (nc <= 0 || n == 0) {
            *error = "an empty image";
            return OiioReadStatus::bad_input;
        }
        std::vector<float> data(n * nc);
        if (!in->read_image(0, 0, 0, nc, OIIO::TypeDesc::FLOAT, data.data())) {
            *error = pixels_unread(*in, "the file");
            return OiioReadStatus::bad_input;
        }
        in->close();
        img.channel_names.resize(nc);
        img.channels.assign(nc, std::vector<float>(n));
        for (int c = 0; c < nc; ++c) {
            img.channel_names[c] = c < static_cast<int>(spec.channelnames.size()) ? spec.channelnames[c] : "";
            for (std::size_t i = 0; i < n; ++i) img.channels[c][i] = data[i * nc + c];
        }
        return OiioReadStatus::ok;
    } catch (const std::exception& e) {
        *error = e.what();
        return OiioReadStatus::failed;
    }
}

extern "C" __attribute__((visibility("default"))) OiioReadStatus penumbra_oiio_read_alpha(
    const char* name, const void* data, std::size_t size, int max_side, std::uint64_t max_pixels, AlphaTexture* image,
    std::string* error) {
    try {
        OIIO::Filesystem::IOMemReader memory(data, data ? size : 0);
        auto in = data ? OIIO::ImageInput::open(name, nullptr, &memory) : OIIO::ImageInput::open(name);
        if (!in) {
            *error = "not an image OpenImageIO can read: " + OIIO::geterror();
            return OiioReadStatus::bad_input;
        }
        const OIIO::ImageSpec& spec = in->spec();
        if (spec.deep || spec.depth > 1 || spec.nchannels <= 0 || spec.width <= 0 || spec.height <= 0) {
            *error = "not a flat 2D image";
            return OiioReadStatus::bad_input;
        }
        image->width = spec.width;
        image->height = spec.height;
        if (spec.width > max_side || spec.height > max_side ||
            static_cast<std::uint64_t>(spec.width) * static_cast<std::uint64_t>(spec.height) > max_pixels)
            return OiioReadStatus::wrong_size;
        // The alpha channel, or the first one where there is none (its pixels are decoded all the
        // same, so that a damaged file is refused whatever it holds). 16-bit: 8-bit k reads k x 257.
        const int channel = spec.alpha_channel >= 0 ? spec.alpha_channel : 0;
        std::vector<std::uint16_t> pixels(static_cast<std::size_t>(spec.width) * static_cast<std::size_t>(spec.height));
        if (!in->read_image(0, 0, channel, channel + 1, OIIO::TypeDesc::UINT16, pixels.data())) {
            *error = pixels_unread(*in, "the data");
            return OiioReadStatus::bad_input;
        }
        in->close();
        if (spec.alpha_channel < 0) pixels.assign(pixels.size(), 65535);
        image->alpha = std::move(pixels);
        return OiioReadStatus::ok;
    } catch (const std::exception& e) {
        *error = e.what();
        return OiioReadStatus::failed;
    }
}
