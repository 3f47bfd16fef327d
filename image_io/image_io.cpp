#include "image_io/image_io.h"

#include <OpenImageIO/imageio.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "common/errors.h"

namespace penumbra {
namespace fs = std::filesystem;

void write_exr(OutputTransaction& out, const std::string& name, int width, int height,
               const std::vector<ExrChannel>& channels) {
    const fs::path tmp = out.stage(name);
    OIIO::ImageSpec spec(width, height, static_cast<int>(channels.size()), OIIO::TypeDesc::FLOAT);
    spec.channelnames.clear();
    spec.channelformats.clear();
    std::size_t pixel_bytes = 0;
    for (const ExrChannel& c : channels) {
        spec.channelnames.push_back(c.name);
        spec.channelformats.push_back(c.u32.empty() ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT);
        pixel_bytes += 4;
    }
    spec.attribute("compression", "zip");
    // OIIO stamps the write time unless told a date; a fixed one keeps files bit-identical.
    spec.attribute("DateTime", "1970:01:01 00:00:00");
    // Interleave per pixel in each channel's native format (OIIO's TypeUnknown convention).
    const std::size_t n = static_cast<std::size_t>(width) * height;
    std::vector<unsigned char> data(n * pixel_bytes);
    for (std::size_t i = 0; i < n; ++i) {
        unsigned char* p = data.data() + i * pixel_bytes;
        for (const ExrChannel& c : channels) {
            std::memcpy(p, c.u32.empty() ? static_cast<const void*>(&c.f32[i]) : static_cast<const void*>(&c.u32[i]),
                        4);
            p += 4;
        }
    }
    auto file = OIIO::ImageOutput::create("openexr");
    if (!file || !file->open(tmp.string(), spec) || !file->write_image(OIIO::TypeUnknown, data.data()) ||
        !file->close())
        throw EnvironmentError(fmt::format("{}: cannot write EXR: {}", (out.dir() / name).string(),
                                           file ? file->geterror() : OIIO::geterror()));
}

void write_png(OutputTransaction& out, const std::string& name, int width, int height, const std::vector<float>& rgb) {
    const fs::path tmp = out.stage(name);
    std::vector<unsigned char> bytes(rgb.size());
    for (std::size_t i = 0; i < rgb.size(); ++i) {
        float v = std::clamp(rgb[i], 0.0f, 1.0f);
        float s = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
        bytes[i] = static_cast<unsigned char>(std::lround(s * 255.0f));
    }
    OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::UINT8);
    auto file = OIIO::ImageOutput::create("png");
    if (!file || !file->open(tmp.string(), spec) || !file->write_image(OIIO::TypeDesc::UINT8, bytes.data()) ||
        !file->close())
        throw EnvironmentError(fmt::format("{}: cannot write PNG: {}", (out.dir() / name).string(),
                                           file ? file->geterror() : OIIO::geterror()));
}

ImageFile read_image(const fs::path& file) {
    std::error_code ec;
    if (!fs::is_regular_file(file, ec)) throw InputError(fmt::format("{}: no such image file", file.string()));
    auto in = OIIO::ImageInput::open(file.string());
    if (!in)
        throw InputError(fmt::format("{}: not an image OpenImageIO can read: {}", file.string(), OIIO::geterror()));
    const OIIO::ImageSpec& spec = in->spec();
    if (spec.deep) throw InputError(fmt::format("{}: a deep image; expected a flat image", file.string()));
    if (spec.depth > 1) throw InputError(fmt::format("{}: a volume image; expected a 2D image", file.string()));
    ImageFile img;
    img.width = spec.width;
    img.height = spec.height;
    img.format = in->format_name();
    img.bits = static_cast<int>(spec.format.size() * 8);
    img.floating = spec.format.is_floating_point();
    const int nc = spec.nchannels;
    const std::size_t n = static_cast<std::size_t>(img.width) * img.height;
    if (nc <= 0 || n == 0) throw InputError(fmt::format("{}: an empty image", file.string()));
    std::vector<float> data(n * nc);
    if (!in->read_image(0, 0, 0, nc, OIIO::TypeDesc::FLOAT, data.data()))
        throw InputError(fmt::format("{}: cannot read the pixels: {}", file.string(), in->geterror()));
    in->close();
    img.channel_names.resize(nc);
    img.channels.assign(nc, std::vector<float>(n));
    for (int c = 0; c < nc; ++c) {
        img.channel_names[c] = c < static_cast<int>(spec.channelnames.size()) ? spec.channelnames[c] : "";
        for (std::size_t i = 0; i < n; ++i) img.channels[c][i] = data[i * nc + c];
    }
    return img;
}

}  // namespace penumbra
