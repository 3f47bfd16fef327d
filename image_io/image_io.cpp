#include "image_io/image_io.h"

#include <Imath/half.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfThreading.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <png.h>
#include <sys/stat.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <cmath>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>

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

// A row's values as sRGB codes, by the table, looked up once a row (a per-value function with
// the table as a function-local static, and a branch on v > 0, was 38% of validate's writing).
void srgb_bytes(const float* linear, unsigned char* out, std::size_t n) {
    static const SrgbTable table;
    const std::uint8_t* bucket = table.bucket.data();
    const float* start = table.start.data();
    for (std::size_t i = 0; i < n; ++i) {
        // 0, -0 (whose bits would index no bucket), negatives and NaN take code 0, as the exact
        // function gives them (NaN: lround's unspecified answer, LONG_MIN on x86-64, whose low
        // byte is 0); selected, not branched on: black pixels come and go along a row.
        const float v = linear[i] > 0.0f ? std::min(linear[i], 1.0f) : 0.0f;
        const unsigned code = bucket[std::bit_cast<std::uint32_t>(v) >> 16];
        // The one threshold a bucket can hold, added without a branch: where it falls is data, and a
        // preview's smooth shading mispredicts a branch on it about half the time.
        out[i] = static_cast<unsigned char>(code + (v >= start[code + 1]));
    }
}

}  // namespace

namespace {

// OpenEXR's output through a file descriptor: the temporary stage() created, opened without
// following a symbolic link (OpenEXR's own file stream opens by name). Buffered, since OpenEXR
// writes a line block in several small pieces.
class FdOStream : public Imf::OStream {
  public:
    FdOStream(int fd, const char* name) : Imf::OStream(name), fd_(fd) {}
    ~FdOStream() override {
        if (fd_ >= 0) ::close(fd_);
    }
    void write(const char c[], int n) override {
        buffer_.append(c, static_cast<std::size_t>(n));
        if (buffer_.size() >= (1u << 20)) flush();
    }
    std::uint64_t tellp() override { return position_ + buffer_.size(); }
    void seekp(std::uint64_t pos) override {
        flush();
        if (::lseek(fd_, static_cast<off_t>(pos), SEEK_SET) < 0) throw std::runtime_error(std::strerror(errno));
        position_ = pos;
    }
    // Writes what is buffered and closes the file; false when any write or the close failed.
    bool finish() {
        try {
            flush();
        } catch (const std::exception&) {
            return false;
        }
        const int fd = std::exchange(fd_, -1);
        return ::close(fd) == 0;
    }

  private:
    void flush() {
        for (std::size_t done = 0; done < buffer_.size();) {
            const ssize_t n = ::write(fd_, buffer_.data() + done, buffer_.size() - done);
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) throw std::runtime_error(std::strerror(n < 0 ? errno : ENOSPC));
            done += static_cast<std::size_t>(n);
        }
        position_ += buffer_.size();
        buffer_.clear();
    }
    int fd_;
    std::uint64_t position_ = 0;
    std::string buffer_;
};

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
        const int fd = out.open_staged(tmp);
        if (fd < 0) throw std::runtime_error(std::strerror(errno));
        FdOStream stream(fd, tmp.c_str());
        {
            Imf::OutputFile file(stream, header);
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
                                          const float* src =
                                              static_cast<const float*>(c.data) +
                                              (c.same_row ? 0 : (static_cast<std::size_t>(y0) + y) * w * c.stride);
                                          for (std::size_t x = 0; x < w; ++x) dst[x] = Imath::half(src[x * c.stride]);
                                      }
                                  });
                Imf::FrameBuffer frame;
                std::size_t h = 0;
                for (const ExrChannelView& c : channels) {
                    const std::size_t x_stride = 4 * c.stride;
                    auto* base = static_cast<char*>(const_cast<void*>(c.data));
                    if (c.storage != ExrStorage::half) {
                        // A y stride of 0 reads row 0 for every row (an x stride of 0 would never end
                        // OpenEXR's copy loop, which steps by it).
                        frame.insert(c.name,
                                     Imf::Slice(pixel_type(c.storage), base, x_stride, c.same_row ? 0 : x_stride * w));
                        continue;
                    }
                    Imath::half* dst = strip.data() + h++ * kStripRows * w;
                    // The slice's origin is pixel (0, 0): this strip's buffer shifted back by y0 rows.
                    frame.insert(c.name, Imf::Slice(Imf::HALF,
                                                    reinterpret_cast<char*>(dst - static_cast<std::ptrdiff_t>(y0) * w),
                                                    sizeof(Imath::half), sizeof(Imath::half) * w));
                }
                file.setFrameBuffer(frame);
                file.writePixels(rows);
            }
        }  // the file's destructor writes the line offsets: before the stream finishes
        if (!stream.finish()) throw std::runtime_error("cannot finish writing the file");
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

// The EXR's own numbers (OpenEXR's file layout): all little-endian, as x86 and ARM hosts store
// them, so rows are copied as they lie in memory.
static_assert(std::endian::native == std::endian::little, "patch_exr_channels copies pixels as EXR's little-endian");
constexpr std::int32_t kExrMagic = 20000630;
constexpr std::uint32_t kExrLongNames = 0x400;  // the only version flag write_exr's files may carry

[[noreturn]] void unexpected_exr(const fs::path& file, const std::string& what) {
    throw std::logic_error(
        fmt::format("{}: not the uncompressed scanline EXR that write_exr writes: {}", file.string(), what));
}

// A file descriptor, closed when it goes.
struct Fd {
    int fd = -1;
    ~Fd() {
        if (fd >= 0) ::close(fd);
    }
};

// The bytes from the file's start, read as far as the header's parser asks.
class FileStart {
  public:
    FileStart(int fd, std::size_t file_size, const fs::path& file) : fd_(fd), size_(file_size), file_(file) {}
    // `n` bytes at `pos`; past the file's end is an error.
    const unsigned char* at(std::size_t pos, std::size_t n) {
        if (pos + n > size_) unexpected_exr(file_, "the header runs past the end of the file");
        if (pos + n > bytes_.size()) {
            const std::size_t want = std::min(size_, std::max(pos + n, 2 * bytes_.size() + 65536));
            const std::size_t had = bytes_.size();
            bytes_.resize(want);
            const ssize_t got = ::pread(fd_, bytes_.data() + had, want - had, static_cast<off_t>(had));
            if (got != static_cast<ssize_t>(want - had))
                throw EnvironmentError(fmt::format("{}: cannot read back the EXR's header", file_.string()));
        }
        return bytes_.data() + pos;
    }

  private:
    int fd_;
    std::size_t size_;
    const fs::path& file_;
    std::vector<unsigned char> bytes_;
};

template <class T>
T little_endian(const unsigned char* p) {
    T v;
    std::memcpy(&v, p, sizeof v);
    return v;
}

std::size_t exr_pixel_bytes(std::int32_t type) {
    return type == 1 ? 2 : 4;
}  // HALF : UINT, FLOAT

}  // namespace

void patch_exr_channels(OutputTransaction& out, const std::string& name, int width, int height,
                        const std::vector<ExrChannelView>& channels) {
    const fs::path file = out.stage(name);  // the temporary write_exr wrote (stage gives it again)
    Fd fd{::open(file.c_str(), O_RDWR | O_NOFOLLOW | O_CLOEXEC)};
    struct stat st {};
    if (fd.fd < 0 || ::fstat(fd.fd, &st) != 0)
        throw EnvironmentError(
            fmt::format("{}: cannot open the EXR to fill in its channels", (out.dir() / name).string()));
    const auto file_size = static_cast<std::size_t>(st.st_size);
    FileStart bytes(fd.fd, file_size, file);

    // ---- the header: magic, version, then attributes (name, type, size, value) until an empty name ----
    std::size_t pos = 0;
    auto i32 = [&] {
        const auto v = little_endian<std::int32_t>(bytes.at(pos, 4));
        pos += 4;
        return v;
    };
    auto text = [&] {  // a NUL-terminated name, at most 255 bytes
        std::string s;
        while (const char c = static_cast<char>(*bytes.at(pos++, 1))) {
            s += c;
            if (s.size() > 255) unexpected_exr(file, "a name longer than 255 bytes");
        }
        return s;
    };
    if (i32() != kExrMagic) unexpected_exr(file, "no EXR magic number");
    const auto version = static_cast<std::uint32_t>(i32());
    if ((version & 0xFFu) != 2 || (version & ~0xFFu & ~kExrLongNames) != 0)
        unexpected_exr(file, fmt::format("version field {:#x} (tiled, deep or multi-part)", version));
    struct FileChannel {
        std::string name;
        std::int32_t type = 0;   // 0 UINT, 1 HALF, 2 FLOAT
        std::size_t offset = 0;  // bytes from the start of a line's pixels
    };
    std::vector<FileChannel> file_channels;
    bool have_channels = false, have_compression = false, have_window = false, have_order = false;
    for (;;) {
        const std::string attr = text();
        if (attr.empty()) break;
        const std::string type = text();
        const std::int32_t size = i32();
        if (size < 0) unexpected_exr(file, fmt::format("attribute {} of size {}", attr, size));
        const std::size_t value = pos, end = pos + static_cast<std::size_t>(size);
        bytes.at(value, static_cast<std::size_t>(size));
        if (attr == "channels") {
            if (type != "chlist") unexpected_exr(file, "channels of type " + type);
            // name, pixel type, pLinear and 3 reserved bytes, x and y sampling; an empty name ends it
            std::size_t line_offset = 0;
            for (;;) {
                FileChannel c;
                c.name = text();
                if (c.name.empty()) break;
                c.type = i32();
                pos += 4;
                const std::int32_t xs = i32(), ys = i32();
                if (c.type < 0 || c.type > 2 || xs != 1 || ys != 1)
                    unexpected_exr(file, fmt::format("channel {}: type {}, sampling {}x{}", c.name, c.type, xs, ys));
                c.offset = line_offset;
                line_offset += exr_pixel_bytes(c.type) * static_cast<std::size_t>(width);
                file_channels.push_back(std::move(c));
            }
            if (pos != end) unexpected_exr(file, "a channel list of another size than its attribute's");
            have_channels = true;
        } else if (attr == "compression") {
            if (size != 1 || *bytes.at(value, 1) != 0) unexpected_exr(file, "compressed");
            have_compression = true;
        } else if (attr == "dataWindow") {
            if (size != 16) unexpected_exr(file, "a data window of another size than a box2i's");
            const unsigned char* b = bytes.at(value, 16);
            if (little_endian<std::int32_t>(b) != 0 || little_endian<std::int32_t>(b + 4) != 0 ||
                little_endian<std::int32_t>(b + 8) != width - 1 || little_endian<std::int32_t>(b + 12) != height - 1)
                unexpected_exr(file, fmt::format("a data window other than {}x{} from (0, 0)", width, height));
            have_window = true;
        } else if (attr == "lineOrder") {
            if (size != 1 || *bytes.at(value, 1) != 0) unexpected_exr(file, "lines not in increasing y");
            have_order = true;
        }
        pos = end;
    }
    if (!have_channels || !have_compression || !have_window || !have_order)
        unexpected_exr(file, "no channels, compression, dataWindow or lineOrder attribute");
    std::size_t line_bytes = 0;
    for (const FileChannel& c : file_channels) line_bytes += exr_pixel_bytes(c.type) * static_cast<std::size_t>(width);

    // ---- the line offset table: one block per line (uncompressed), each `y, byte count, pixels` ----
    const auto lines = static_cast<std::size_t>(height);
    std::vector<std::uint64_t> offsets(lines);
    std::memcpy(offsets.data(), bytes.at(pos, 8 * lines), 8 * lines);
    const std::size_t table_end = pos + 8 * lines;
    for (std::size_t y = 0; y < lines; ++y)
        if (offsets[y] < table_end || offsets[y] > file_size || file_size - offsets[y] < 8 + line_bytes)
            unexpected_exr(file, fmt::format("line {} at offset {} in a file of {} bytes", y, offsets[y], file_size));

    struct Patch {
        const ExrChannelView* view;
        std::size_t offset, bytes;  // in the line's pixels
    };
    std::vector<Patch> patches;
    for (const ExrChannelView& v : channels) {
        auto c = std::find_if(file_channels.begin(), file_channels.end(),
                              [&](const FileChannel& fc) { return fc.name == v.name; });
        if (c == file_channels.end()) unexpected_exr(file, "no channel " + v.name);
        if (pixel_type(v.storage) != static_cast<Imf::PixelType>(c->type))
            unexpected_exr(file, fmt::format("channel {} of pixel type {}", v.name, c->type));
        patches.push_back({&v, c->offset, exr_pixel_bytes(c->type) * static_cast<std::size_t>(width)});
    }

    // ---- each line's channels, converted and written in place, lines on the command's threads ----
    const std::size_t w = static_cast<std::size_t>(width);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, lines, 16), [&](const tbb::blocked_range<std::size_t>& r) {
        std::vector<unsigned char> row(4 * w);
        for (std::size_t y = r.begin(); y != r.end(); ++y) {
            unsigned char block[8];
            if (::pread(fd.fd, block, 8, static_cast<off_t>(offsets[y])) != 8)
                throw EnvironmentError(fmt::format("{}: cannot read back the EXR's line {}", file.string(), y));
            if (little_endian<std::int32_t>(block) != static_cast<std::int32_t>(y) ||
                little_endian<std::int32_t>(block + 4) != static_cast<std::int32_t>(line_bytes))
                unexpected_exr(file,
                               fmt::format("the block at line {}'s offset is line {} of {} bytes", y,
                                           little_endian<std::int32_t>(block), little_endian<std::int32_t>(block + 4)));
            for (const Patch& p : patches) {
                const ExrChannelView& v = *p.view;
                const std::size_t first = (v.same_row ? 0 : y * w) * v.stride;
                if (v.storage == ExrStorage::half) {
                    const float* src = static_cast<const float*>(v.data) + first;
                    for (std::size_t x = 0; x < w; ++x) {
                        const std::uint16_t h = Imath::half(src[x * v.stride]).bits();
                        std::memcpy(row.data() + 2 * x, &h, 2);
                    }
                } else {
                    const auto* src = static_cast<const std::uint32_t*>(v.data) + first;  // float or uint32 bits
                    if (v.stride == 1)
                        std::memcpy(row.data(), src, 4 * w);
                    else
                        for (std::size_t x = 0; x < w; ++x) std::memcpy(row.data() + 4 * x, src + x * v.stride, 4);
                }
                const auto at = static_cast<off_t>(offsets[y] + 8 + p.offset);
                if (::pwrite(fd.fd, row.data(), p.bytes, at) != static_cast<ssize_t>(p.bytes))
                    throw EnvironmentError(fmt::format("{}: cannot write EXR: line {} of channel {}",
                                                       (out.dir() / name).string(), y, v.name));
            }
        }
    });
    if (::close(std::exchange(fd.fd, -1)) != 0)
        throw EnvironmentError(fmt::format("{}: cannot write EXR: closing it failed", (out.dir() / name).string()));
}

namespace {

// A libpng writer whose errors land in `error` and longjmp back to the caller's setjmp.
png_structp png_writer(char (&error)[256]) {
    return png_create_write_struct(
        PNG_LIBPNG_VER_STRING, error,
        [](png_structp p, png_const_charp message) {
            std::snprintf(static_cast<char*>(png_get_error_ptr(p)), 256, "%s", message);
            png_longjmp(p, 1);
        },
        nullptr);
}

// libpng reports errors by longjmp back into this frame; the frames it skips are libpng's own.
// Rows are made (the source, then sRGB bytes) a block at a time, on the command's threads where
// `order` allows; libpng's filter and zlib take them in order, serially.
bool write_png_file(FILE* file, int width, int height, const PngRowSource& rows, PngRows order, char (&error)[256]) {
    png_structp png = png_writer(error);
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
        srgb_bytes(rgb.data(), out, row_size);
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

// The zlib stream of a PNG's image data made in pieces on the command's threads, as pigz does
// (#39: at 16 threads oracle.png's serial zlib, ~0.06 s at 2048^2, bounded the write phase once
// oracle.exr was written during the boundary phase). The filtered rows are cut into pieces of a
// whole number of rows, at least kPngPieceBytes each but the last: a function of the width alone,
// never of the thread count, so the file is the same at any. Each piece is raw deflate, with the
// last 32 KiB before it as its dictionary (so its matches reach back as zlib's own would), ended
// by a sync flush (an empty stored block: the next piece starts on a byte), the last by the
// final block. The pieces follow one zlib header; the stream's Adler-32 is the pieces' combined.
constexpr std::size_t kPngPieceBytes = 256 * 1024;
constexpr std::size_t kDeflateWindow = 32768;

struct DeflatedPiece {
    std::size_t begin = 0, size = 0;  // in the filtered rows
    std::vector<unsigned char> data;  // raw deflate
    uLong adler = 0;                  // of the piece's filtered rows
};

// The rows (sRGB bytes) PNG-filtered with SUB, as libpng's png_set_filter(PNG_FILTER_SUB)
// filters them: a filter byte (1), then each byte less the one a pixel (3 bytes) before it.
// Not zero-filled first: every byte is written.
struct FilteredRows {
    std::unique_ptr<unsigned char[]> bytes;
    std::size_t size = 0;
};

FilteredRows sub_filtered_rows(int width, int height, const PngRowSource& rows) {
    const std::size_t row_size = static_cast<std::size_t>(width) * 3, line = row_size + 1;
    FilteredRows f{std::make_unique_for_overwrite<unsigned char[]>(line * static_cast<std::size_t>(height)),
                   line * static_cast<std::size_t>(height)};
    tbb::parallel_for(tbb::blocked_range<int>(0, height, 4), [&](const tbb::blocked_range<int>& r) {
        std::vector<float> rgb(row_size);
        std::vector<unsigned char> raw(row_size);
        for (int y = r.begin(); y != r.end(); ++y) {
            rows(y, rgb.data());
            srgb_bytes(rgb.data(), raw.data(), row_size);
            unsigned char* out = f.bytes.get() + static_cast<std::size_t>(y) * line;
            out[0] = PNG_FILTER_VALUE_SUB;
            for (std::size_t i = 0; i < row_size; ++i)
                out[1 + i] = static_cast<unsigned char>(i < 3 ? raw[i] : raw[i] - raw[i - 3]);
        }
    });
    return f;
}

// A thread's zlib stream and output buffer, reset for each piece it deflates (a fresh stream
// and buffer per piece cost ~10% of a 2048^2 preview's time on one thread).
struct Deflater {
    z_stream z{};
    bool started = false;
    std::vector<unsigned char> out;
    Deflater() = default;
    Deflater(const Deflater&) = delete;
    Deflater& operator=(const Deflater&) = delete;
    ~Deflater() {
        if (started) deflateEnd(&z);
    }
};

// Throws EnvironmentError where zlib fails (out of memory).
std::vector<DeflatedPiece> deflate_pieces(const FilteredRows& filtered, std::size_t line) {
    const std::size_t rows_per_piece = std::max<std::size_t>(1, (kPngPieceBytes + line - 1) / line);
    const std::size_t piece_bytes = rows_per_piece * line;
    std::vector<DeflatedPiece> pieces((filtered.size + piece_bytes - 1) / piece_bytes);
    tbb::enumerable_thread_specific<Deflater> deflaters;
    tbb::parallel_for(std::size_t(0), pieces.size(), [&](std::size_t k) {
        DeflatedPiece& p = pieces[k];
        p.begin = k * piece_bytes;
        p.size = std::min(piece_bytes, filtered.size - p.begin);
        const unsigned char* in = filtered.bytes.get() + p.begin;
        p.adler = adler32_z(adler32_z(0, nullptr, 0), in, p.size);
        Deflater& d = deflaters.local();
        z_stream& z = d.z;
        // libpng's settings for filtered rows: Z_FILTERED (no effect at level 1, zlib's fast
        // path), a 32 KiB window, memLevel 8; negative window bits: raw deflate, no header.
        if (!d.started) {
            if (deflateInit2(&z, 1, Z_DEFLATED, -15, 8, Z_FILTERED) != Z_OK)
                throw EnvironmentError("zlib could not start a stream (out of memory)");
            d.started = true;
        } else if (deflateReset(&z) != Z_OK) {
            throw EnvironmentError("zlib could not reset a stream");
        }
        const std::size_t dict = std::min(p.begin, kDeflateWindow);
        if (dict > 0 && deflateSetDictionary(&z, in - dict, static_cast<uInt>(dict)) != Z_OK)
            throw EnvironmentError("zlib refused a piece's dictionary");
        const bool last = k + 1 == pieces.size();
        const int flush = last ? Z_FINISH : Z_SYNC_FLUSH;
        z.next_in = const_cast<unsigned char*>(in);
        z.avail_in = static_cast<uInt>(p.size);
        d.out.resize(std::max<std::size_t>(d.out.size(), deflateBound(&z, static_cast<uLong>(p.size)) + 64));
        std::size_t used = 0;
        for (;;) {
            z.next_out = d.out.data() + used;
            z.avail_out = static_cast<uInt>(d.out.size() - used);
            const int rc = deflate(&z, flush);
            used = d.out.size() - z.avail_out;
            if (rc == Z_STREAM_END) break;
            if (rc != Z_OK && rc != Z_BUF_ERROR) throw EnvironmentError(fmt::format("zlib failed ({})", rc));
            if (!last && z.avail_in == 0 && z.avail_out != 0) break;  // flushed to the end
            d.out.resize(2 * d.out.size());
        }
        p.data.assign(d.out.begin(), d.out.begin() + static_cast<std::ptrdiff_t>(used));
    });
    return pieces;
}

// libpng writes the signature, IHDR, sRGB and, through png_write_chunk, the IDAT chunks (one
// per piece) and IEND: png_write_row would deflate the rows itself, serially, and png_write_end
// refuses a stream that libpng did not deflate ("No IDATs written"), so IEND is written as a
// plain chunk too. The pieces are made before libpng's setjmp: a longjmp skips no destructor.
bool write_png_pieces(FILE* file, int width, int height, const std::vector<DeflatedPiece>& pieces, char (&error)[256]) {
    png_structp png = png_writer(error);
    if (!png) return false;
    png_infop info = png_create_info_struct(png);
    if (!info || setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        return false;
    }
    png_init_io(png, file);
    png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_write_info(png, info);
    // The zlib header: CM 8 (deflate), CINFO 7 (a 32 KiB window); FLEVEL 0, what zlib writes at
    // level 1; no FDICT (the pieces' dictionaries are the stream's own bytes); FCHECK makes the
    // two bytes a multiple of 31.
    const unsigned header = (0x78u << 8) + (31 - (0x78u << 8) % 31);
    const unsigned char zlib_header[2] = {static_cast<unsigned char>(header >> 8),
                                          static_cast<unsigned char>(header & 0xFF)};
    uLong adler = adler32_z(0, nullptr, 0);
    for (const DeflatedPiece& p : pieces) adler = adler32_combine(adler, p.adler, static_cast<z_off_t>(p.size));
    const unsigned char adler_bytes[4] = {static_cast<unsigned char>(adler >> 24),
                                          static_cast<unsigned char>(adler >> 16),
                                          static_cast<unsigned char>(adler >> 8), static_cast<unsigned char>(adler)};
    const auto* idat = reinterpret_cast<png_const_bytep>("IDAT");
    for (std::size_t k = 0; k < pieces.size(); ++k) {
        const bool first = k == 0, last = k + 1 == pieces.size();
        const std::size_t size = pieces[k].data.size() + (first ? 2 : 0) + (last ? 4 : 0);
        png_write_chunk_start(png, idat, static_cast<png_uint_32>(size));
        if (first) png_write_chunk_data(png, zlib_header, 2);
        png_write_chunk_data(png, pieces[k].data.data(), pieces[k].data.size());
        if (last) png_write_chunk_data(png, adler_bytes, 4);
        png_write_chunk_end(png);
    }
    png_write_chunk(png, reinterpret_cast<png_const_bytep>("IEND"), nullptr, 0);
    png_destroy_write_struct(&png, &info);
    return true;
}

}  // namespace

void write_png(OutputTransaction& out, const std::string& name, int width, int height, const PngRowSource& rows,
               PngRows order) {
    const fs::path tmp = out.stage(name);
    char error[256] = "cannot open the file";
    // Through the file stage() created, never a symbolic link put at its name since.
    const int fd = out.open_staged(tmp);
    std::unique_ptr<FILE, int (*)(FILE*)> file(fd >= 0 ? ::fdopen(fd, "wb") : nullptr, &std::fclose);
    if (fd >= 0 && !file) ::close(fd);
    bool ok = false;
    if (file && order == PngRows::parallel_deflate) {
        const std::size_t line = static_cast<std::size_t>(width) * 3 + 1;
        std::vector<DeflatedPiece> pieces;
        try {
            pieces = deflate_pieces(sub_filtered_rows(width, height, rows), line);
        } catch (const EnvironmentError& e) {
            throw EnvironmentError(fmt::format("{}: cannot write PNG: {}", (out.dir() / name).string(), e.what()));
        }
        ok = write_png_pieces(file.get(), width, height, pieces, error);
    } else if (file) {
        ok = write_png_file(file.get(), width, height, rows, order, error);
    }
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

// A cut-out's image (common/alpha_coverage.h), decoded with the limits checked from its header.
AlphaTexture decode_alpha_image(const EncodedImage& e) {
    std::string name;
    if (e.bytes.data() == nullptr) {
        std::error_code ec;
        if (!fs::is_regular_file(e.file, ec))
            throw InputError(fmt::format("{}: {}: {}", e.label, path_text(e.file), not_an_image_file(e.file)));
        name = e.file.string();
    } else {
        // The format by its mimeType (glTF 2.0 allows image/png and image/jpeg; extensions add
        // more): OpenImageIO picks its reader by the name's extension, then tries the others.
        const std::string& mime = e.mime_type;
        name = mime == "image/jpeg" ? "image.jpg" : mime == "image/webp" ? "image.webp" : "image.png";
    }
    AlphaTexture t;
    std::string error;
    switch (oiio_plugin().read_alpha(name.c_str(), e.bytes.data(), e.bytes.size(), kMaxTextureSide, kMaxTexturePixels,
                                     &t, &error)) {
        case OiioReadStatus::ok: return t;
        case OiioReadStatus::bad_input: throw InputError(fmt::format("{}: {}", e.label, error));
        case OiioReadStatus::wrong_size:
            throw InputError(
                fmt::format("{}: {}x{} pixels declared; a cut-out's image may have at most {} a side and {} "
                            "Mpixels",
                            e.label, t.width, t.height, kMaxTextureSide, kMaxTexturePixels >> 20));
        case OiioReadStatus::failed: break;
    }
    throw EnvironmentError(fmt::format("{}: {}", e.label, error));
}

// Registered before main: the loader (common) decodes through it wherever this module is linked.
[[maybe_unused]] const bool alpha_decoder_registered = (set_alpha_image_decoder(&decode_alpha_image), true);

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
