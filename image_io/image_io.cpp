#include "image_io/image_io.h"

#include <Imath/half.h>
#include <OpenImageIO/imageio.h>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include "common/errors.h"

namespace penumbra {
namespace fs = std::filesystem;

namespace {

std::size_t storage_bytes(ExrStorage s) {
    return s == ExrStorage::half ? 2 : 4;
}

OIIO::TypeDesc storage_type(ExrStorage s) {
    switch (s) {
        case ExrStorage::u32: return OIIO::TypeDesc::UINT;
        case ExrStorage::half: return OIIO::TypeDesc::HALF;
        case ExrStorage::f32: break;
    }
    return OIIO::TypeDesc::FLOAT;
}

// The sRGB transfer function (IEC 61966-2-1) of a linear value in [0, 1], as an 8-bit code.
unsigned char srgb_byte_exact(float linear) {
    float v = std::clamp(linear, 0.0f, 1.0f);
    float s = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
    return static_cast<unsigned char>(std::lround(s * 255.0f));
}

// The same by table. Code k starts at the smallest float whose exact code is k (found once by
// bisection over the float bit patterns of [0, 1], where the code does not decrease). A value's
// upper 16 bits pick the code at the start of its bucket; a bucket spans less than one code
// step (2^-7 relative where the code grows by at most 255 * 1.055 / 2.4 per unit), so at most
// one more threshold can lie inside it.
struct SrgbTable {
    std::array<float, 257> start{};  // start[256] = +inf
    std::vector<unsigned char> bucket = std::vector<unsigned char>((0x3F800000u >> 16) + 1);
    SrgbTable() {
        for (int k = 1; k < 256; ++k) {
            std::uint32_t lo = 0, hi = 0x3F800000u;  // bit patterns of 0.0f and 1.0f
            while (lo < hi) {
                const std::uint32_t mid = lo + (hi - lo) / 2;
                if (srgb_byte_exact(std::bit_cast<float>(mid)) >= k)
                    hi = mid;
                else
                    lo = mid + 1;
            }
            start[k] = std::bit_cast<float>(lo);
        }
        start[256] = std::numeric_limits<float>::infinity();
        for (std::size_t b = 0; b < bucket.size(); ++b)
            bucket[b] = srgb_byte_exact(std::bit_cast<float>(std::uint32_t(b << 16)));
    }
};

unsigned char srgb_byte(float linear) {
    static const SrgbTable table;
    const float v = std::min(linear, 1.0f);
    if (!(v > 0.0f)) return srgb_byte_exact(linear);  // 0, -0 (whose bits index no bucket), negatives, NaN
    unsigned code = table.bucket[std::bit_cast<std::uint32_t>(v) >> 16];
    while (v >= table.start[code + 1]) ++code;
    return static_cast<unsigned char>(code);
}

}  // namespace

void write_exr(OutputTransaction& out, const std::string& name, int width, int height,
               const std::vector<ExrChannelView>& channels, ExrCompression compression) {
    const fs::path tmp = out.stage(name);
    OIIO::ImageSpec spec(width, height, static_cast<int>(channels.size()), OIIO::TypeDesc::FLOAT);
    spec.channelnames.clear();
    spec.channelformats.clear();
    std::size_t pixel_bytes = 0;
    for (const ExrChannelView& c : channels) {
        spec.channelnames.push_back(c.name);
        spec.channelformats.push_back(storage_type(c.storage));
        pixel_bytes += storage_bytes(c.storage);
    }
    spec.attribute("compression", compression == ExrCompression::zip ? "zip" : "none");
    // OIIO stamps the write time unless told a date; a fixed one keeps files bit-identical.
    spec.attribute("DateTime", "1970:01:01 00:00:00");
    auto file = OIIO::ImageOutput::create("openexr");
    auto fail = [&] {
        throw EnvironmentError(fmt::format("{}: cannot write EXR: {}", (out.dir() / name).string(),
                                           file ? file->geterror() : OIIO::geterror()));
    };
    if (!file || !file->open(tmp.string(), spec)) fail();
    // Interleave a strip of scanlines at a time, in each channel's stored format (OIIO's
    // TypeUnknown convention), and hand it to OpenEXR: memory stays at one strip, not a second
    // copy of the frame.
    constexpr int kStripRows = 16;  // a strip of a 2048-wide frame stays in cache while it is interleaved
    std::vector<unsigned char> strip(static_cast<std::size_t>(std::min(kStripRows, std::max(height, 1))) * width *
                                     pixel_bytes);
    for (int y0 = 0; y0 < height; y0 += kStripRows) {
        const int y1 = std::min(height, y0 + kStripRows);
        const std::size_t first = static_cast<std::size_t>(y0) * width, last = static_cast<std::size_t>(y1) * width;
        std::size_t offset = 0;
        for (const ExrChannelView& c : channels) {
            unsigned char* dst = strip.data() + offset;
            const std::size_t bytes = storage_bytes(c.storage);
            offset += bytes;
            if (c.storage == ExrStorage::half) {
                const float* src = static_cast<const float*>(c.data);
                for (std::size_t i = first; i < last; ++i, dst += pixel_bytes) {
                    const Imath::half h(src[i * c.stride]);
                    const std::uint16_t bits = h.bits();
                    std::memcpy(dst, &bits, 2);
                }
            } else {
                const auto* src = static_cast<const unsigned char*>(c.data);
                for (std::size_t i = first; i < last; ++i, dst += pixel_bytes)
                    std::memcpy(dst, src + 4 * i * c.stride, 4);
            }
        }
        if (!file->write_scanlines(y0, y1, 0, OIIO::TypeUnknown, strip.data())) fail();
    }
    if (!file->close()) fail();
}

void write_exr(OutputTransaction& out, const std::string& name, int width, int height,
               const std::vector<ExrChannel>& channels) {
    std::vector<ExrChannelView> views;
    for (const ExrChannel& c : channels) {
        if (c.u32.empty())
            views.push_back({c.name, ExrStorage::f32, c.f32.data(), 1});
        else
            views.push_back({c.name, ExrStorage::u32, c.u32.data(), 1});
    }
    write_exr(out, name, width, height, views);
}

void write_png(OutputTransaction& out, const std::string& name, int width, int height, const std::vector<float>& rgb) {
    const fs::path tmp = out.stage(name);
    std::vector<unsigned char> bytes(rgb.size());
    for (std::size_t i = 0; i < rgb.size(); ++i) bytes[i] = srgb_byte(rgb[i]);
    OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::UINT8);
    // A preview: zlib's fastest level is 3-4x faster than the default (6) and the file only
    // slightly larger.
    spec.attribute("png:compressionLevel", 1);
    spec.attribute("png:filter", 0x10);  // libpng's PNG_FILTER_SUB alone, not a trial of all five per row
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
