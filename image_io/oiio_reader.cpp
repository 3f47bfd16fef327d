// The OpenImageIO plugin (oiio_plugin.h): read_image's implementation, built as a module that
// image_io loads on the first read so that OIIO's libraries load only in processes that read.
#include <OpenImageIO/imageio.h>

#include <string>
#include <vector>

#include "image_io/oiio_plugin.h"

using penumbra::ImageFile;
using penumbra::OiioReadStatus;

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
            // Some readers (PNG, TIFF) fail a truncated file without a message of their own.
            std::string why = in->geterror();
            if (why.empty()) why = OIIO::geterror();
            if (why.empty()) why = "the file ends before its last pixel, or its data is damaged";
            while (!why.empty() && (why.back() == '\n' || why.back() == ' ')) why.pop_back();
            *error = "cannot read the pixels: " + why;
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
