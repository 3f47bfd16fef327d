#include "image_io/image_io.h"

#include <Imath/half.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfThreading.h>
#include <fmt/format.h>
#include <png.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <csetjmp>
#include <cstdio>
#include <limits>
#include <memory>
#include <mutex>
#include <thread>

#include "common/errors.h"
#include "common/json_reader.h"
#include "image_io/oiio_plugin.h"

namespace penumbra {
namespace fs = std::filesystem;

namespace {

Imf::PixelType pixel_type(ExrStorage s) {
    switch (s) {
        case ExrStorage::u32: return Imf::UINT;
        case ExrStorage::half: return Imf::HALF;
        case ExrStorage::f32: break;
    }
    return Imf::FLOAT;
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
    const unsigned code = table.bucket[std::bit_cast<std::uint32_t>(v) >> 16];
    // The one threshold a bucket can hold, added without a branch: where it falls is data, and a
    // preview's smooth shading mispredicts a branch on it about half the time.
    return static_cast<unsigned char>(code + (v >= table.start[code + 1]));
}

}  // namespace

void write_exr(OutputTransaction& out, const std::string& name, int width, int height,
               const std::vector<ExrChannelView>& channels, ExrCompression compression) {
    const fs::path tmp = out.stage(name);
    // OpenEXR's pool compresses line blocks in parallel; it is created once, like OIIO did.
    static std::once_flag threads_once;
    std::call_once(threads_once, [] {
        Imf::setGlobalThreadCount(static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
    });
    try {
        Imf::Header header(width, height);
        header.compression() = compression == ExrCompression::zip ? Imf::ZIP_COMPRESSION : Imf::NO_COMPRESSION;
        for (const ExrChannelView& c : channels) header.channels().insert(c.name, Imf::Channel(pixel_type(c.storage)));
        Imf::OutputFile file(tmp.c_str(), header);
        // OpenEXR reads float and uint channels where they lie (strided views, no copy). A
        // half channel must be handed over as half: converted a strip of scanlines at a time
        // (Imath's round to nearest even), so memory stays at one strip.
        // The conversion runs on the command's threads (tbb, row by row): done serially it was
        // ~0.02 s of a 2048^2 oracle frame's write, one of the parts that did not scale (#39).
        constexpr int kStripRows = 64;
        const std::size_t w = static_cast<std::size_t>(width);
        std::vector<const ExrChannelView*> halves;
        for (const ExrChannelView& c : channels)
            if (c.storage == ExrStorage::half) halves.push_back(&c);
        std::vector<Imath::half> strip(halves.size() * kStripRows * w);
        for (int y0 = 0; y0 < height; y0 += kStripRows) {
            const int rows = std::min(kStripRows, height - y0);
            tbb::parallel_for(tbb::blocked_range<std::size_t>(0, halves.size() * static_cast<std::size_t>(rows)),
                              [&](const tbb::blocked_range<std::size_t>& r) {
                                  const auto n = static_cast<std::size_t>(rows);
                                  for (std::size_t k = r.begin(); k != r.end(); ++k) {
                                      const std::size_t h = k / n, y = k % n;
                                      const ExrChannelView& c = *halves[h];
                                      Imath::half* dst = strip.data() + (h * kStripRows + y) * w;
                                      const float* src = static_cast<const float*>(c.data) +
                                                         (static_cast<std::size_t>(y0) + y) * w * c.stride;
                                      for (std::size_t x = 0; x < w; ++x) dst[x] = Imath::half(src[x * c.stride]);
                                  }
                              });
            Imf::FrameBuffer frame;
            std::size_t h = 0;
            for (const ExrChannelView& c : channels) {
                const std::size_t x_stride = 4 * c.stride;
                auto* base = static_cast<char*>(const_cast<void*>(c.data));
                if (c.storage != ExrStorage::half) {
                    frame.insert(c.name, Imf::Slice(pixel_type(c.storage), base, x_stride, x_stride * w));
                    continue;
                }
                Imath::half* dst = strip.data() + h++ * kStripRows * w;
                // The slice's origin is pixel (0, 0): this strip's buffer shifted back by y0 rows.
                frame.insert(c.name,
                             Imf::Slice(Imf::HALF, reinterpret_cast<char*>(dst - static_cast<std::ptrdiff_t>(y0) * w),
                                        sizeof(Imath::half), sizeof(Imath::half) * w));
            }
            file.setFrameBuffer(frame);
            file.writePixels(rows);
        }
    } catch (const std::exception& e) {
        throw EnvironmentError(fmt::format("{}: cannot write EXR: {}", (out.dir() / name).string(), e.what()));
    }
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

namespace {

// libpng reports errors by longjmp back into this frame; the frames it skips are libpng's own.
// Rows are made (the source, then sRGB bytes) a block at a time, on the command's threads where
// `order` allows; libpng's filter and zlib take them in order, serially.
bool write_png_file(FILE* file, int width, int height, const PngRowSource& rows, PngRows order, char (&error)[256]) {
    png_structp png = png_create_write_struct(
        PNG_LIBPNG_VER_STRING, error,
        [](png_structp p, png_const_charp message) {
            std::snprintf(static_cast<char*>(png_get_error_ptr(p)), 256, "%s", message);
            png_longjmp(p, 1);
        },
        nullptr);
    if (!png) return false;
    png_infop info = png_create_info_struct(png);
    // Made before setjmp, so that a longjmp lands where they are already whole.
    const std::size_t row_size = static_cast<std::size_t>(width) * 3;
    const int block_rows = order == PngRows::parallel ? 32 : 1;
    std::vector<unsigned char> bytes(row_size * static_cast<std::size_t>(block_rows));
    std::vector<float> linear(row_size);
    if (!info || setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        return false;
    }
    png_init_io(png, file);
    // A preview: zlib's fastest level is 3-4x faster than the default (6) and the file only
    // slightly larger; the SUB filter alone, not a trial of all five per row.
    png_set_compression_level(png, 1);
    png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
    png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_write_info(png, info);
    auto make_row = [&](int y, std::vector<float>& rgb) {
        rows(y, rgb.data());
        unsigned char* out = bytes.data() + static_cast<std::size_t>(y % block_rows) * row_size;
        for (std::size_t i = 0; i < row_size; ++i) out[i] = srgb_byte(rgb[i]);
    };
    for (int y0 = 0; y0 < height; y0 += block_rows) {
        const int y1 = std::min(height, y0 + block_rows);
        if (order == PngRows::parallel)
            tbb::parallel_for(tbb::blocked_range<int>(y0, y1, 4), [&](const tbb::blocked_range<int>& r) {
                std::vector<float> scratch(row_size);
                for (int y = r.begin(); y != r.end(); ++y) make_row(y, scratch);
            });
        else
            for (int y = y0; y < y1; ++y) make_row(y, linear);
        for (int y = y0; y < y1; ++y) png_write_row(png, bytes.data() + static_cast<std::size_t>(y - y0) * row_size);
    }
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    return true;
}

}  // namespace

void write_png(OutputTransaction& out, const std::string& name, int width, int height, const PngRowSource& rows,
               PngRows order) {
    const fs::path tmp = out.stage(name);
    char error[256] = "cannot open the file";
    std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(tmp.c_str(), "wb"), &std::fclose);
    bool ok = file && write_png_file(file.get(), width, height, rows, order, error);
    if (ok && std::fclose(file.release()) != 0) {
        ok = false;
        std::snprintf(error, sizeof error, "%s", "cannot finish writing the file");
    }
    if (!ok) throw EnvironmentError(fmt::format("{}: cannot write PNG: {}", (out.dir() / name).string(), error));
}

void write_png(OutputTransaction& out, const std::string& name, int width, int height, const std::vector<float>& rgb) {
    const std::size_t row = static_cast<std::size_t>(width) * 3;
    write_png(out, name, width, height,
              [&](int y, float* dst) { std::copy_n(rgb.data() + static_cast<std::size_t>(y) * row, row, dst); });
}

namespace {

// What a path that is not a regular file is, for the message.
std::string not_an_image_file(const fs::path& file) {
    std::error_code ec;
    switch (fs::status(file, ec).type()) {
        case fs::file_type::not_found: return "no such image file";
        case fs::file_type::directory: return "a folder, not an image file";
        case fs::file_type::fifo: return "a FIFO (named pipe), not an image file";
        case fs::file_type::character:
        case fs::file_type::block: return "a device, not an image file";
        case fs::file_type::socket: return "a socket, not an image file";
        default: break;
    }
    return ec ? fmt::format("cannot be read: {}", ec.message()) : "not a regular file, not an image file";
}

}  // namespace

ImageFile read_image(const fs::path& file, const ExpectedImageSize* expected) {
    const std::string name = path_text(file);
    std::error_code ec;
    if (!fs::is_regular_file(file, ec)) throw InputError(fmt::format("{}: {}", name, not_an_image_file(file)));
    ImageFile img;
    std::string error;
    const int w = expected ? expected->width : 0, h = expected ? expected->height : 0;
    switch (oiio_plugin().read(file.c_str(), w, h, &img, &error)) {
        case OiioReadStatus::ok: return img;
        case OiioReadStatus::bad_input: throw InputError(fmt::format("{}: {}", name, error));
        case OiioReadStatus::wrong_size:
            throw InputError(fmt::format("{}: {}x{} pixels; expected {}", name, img.width, img.height,
                                         expected ? expected->what : std::string("another size")));
        case OiioReadStatus::failed: break;
    }
    throw EnvironmentError(fmt::format("{}: {}", name, error));
}

}  // namespace penumbra
