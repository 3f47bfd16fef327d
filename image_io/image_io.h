// Image files in one place: the only code that links OpenImageIO. Each file is staged in an
// OutputTransaction, so it appears only when the transaction commits.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
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

// How a channel is stored in the file.
enum class ExrStorage {
    f32,   // 32-bit float
    u32,   // 32-bit unsigned int
    half,  // 16-bit float, for masks and flags whose values (0, 1) half holds exactly
};

// A channel read in place from the caller's memory (no copy): pixel i's value is at
// `data + i * stride` (in elements: a float or uint32 each). `half` channels read floats.
struct ExrChannelView {
    std::string name;
    ExrStorage storage = ExrStorage::f32;
    const void* data = nullptr;
    std::size_t stride = 1;
    // Every row reads row 0's pixels (`data` holds one row): a placeholder channel whose
    // pixels patch_exr_channels writes later (oracle.exr written during the boundary phase, #39).
    bool same_row = false;
};

enum class ExrCompression {
    zip,   // deflate, 16 scanlines per block: about 5x smaller, ~3 CPU-s per 250 MB on the dev VM
    none,  // uncompressed: for large frames whose write time matters (docs/oracle.md section 9)
};

// A zip-compressed EXR of float and uint channels, bit-identical from run to run.
void write_exr(OutputTransaction& out, const std::string& name, int width, int height,
               const std::vector<ExrChannel>& channels);
// The same from views, written in strips of scanlines: no copy of the whole image is made.
void write_exr(OutputTransaction& out, const std::string& name, int width, int height,
               const std::vector<ExrChannelView>& channels, ExrCompression compression = ExrCompression::zip);
// Overwrites in place, in the uncompressed EXR `name` that write_exr staged in `out`
// (ExrCompression::none), the pixels of the channels named in `channels` from those views: the
// file becomes byte for byte what write_exr writes with them. The layout (channel order and
// types, the size, each line's offset) is read from the file's header and line offset table;
// a file of another layout is an internal error (std::logic_error: exit 4), a failed read or
// write an EnvironmentError. Lines are patched on the command's threads.
void patch_exr_channels(OutputTransaction& out, const std::string& name, int width, int height,
                        const std::vector<ExrChannelView>& channels);
// 8-bit sRGB-encoded RGB image, linear input in [0, 1] per channel, row-major.
void write_png(OutputTransaction& out, const std::string& name, int width, int height, const std::vector<float>& rgb);
// Fills row y (0 at the top) of linear RGB: `width` pixels, 3 floats each.
using PngRowSource = std::function<void(int y, float* rgb)>;
// How write_png asks for rows: `serial`, each once, top to bottom, on the calling thread;
// `parallel`, each once, a block of rows at a time on the command's threads (tbb), so the source
// must be safe to call for different rows at once. The file's bytes are the same either way.
// `parallel_deflate`: the rows as `parallel`, and the zlib stream too is made in pieces on the
// command's threads (as pigz does): its bytes differ from the other two's (the stream is cut
// differently; the pixels are the same) and are the same at every thread count.
enum class PngRows { serial, parallel, parallel_deflate };
// The same, one row at a time: for large previews, whose whole float image would be fresh
// memory (50 MB at 2048^2) that the kernel must fault in and zero (docs/oracle.md section 9).
void write_png(OutputTransaction& out, const std::string& name, int width, int height, const PngRowSource& rows,
               PngRows order = PngRows::serial);

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

// The size a caller needs. It is checked against the file's header before any pixel is decoded:
// a file of a few bytes may declare an image of billions of pixels.
struct ExpectedImageSize {
    int width = 0, height = 0;
    std::string what;  // for the message: "{file}: WxH pixels; expected {what}"
};

// Reads any format OpenImageIO reads (first subimage, first MIP level). Throws InputError naming
// the file when it is missing, not a regular file (saying what it is), unreadable, deep or a
// volume, or, given `expected`, of another size.
ImageFile read_image(const std::filesystem::path& file, const ExpectedImageSize* expected = nullptr);

}  // namespace penumbra
