// image_io: EXR and PNG written through OpenEXR and libpng read back exactly, through the
// OpenImageIO plugin (read_image) and, for the stored pixel types and uint values, through
// OpenEXR itself.
#include "image_io/image_io.h"

#include <Imath/half.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <vector>

#include "common/errors.h"
#include "common/output_files.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

namespace fs = std::filesystem;

// Width and height that are not multiples of the writer's strips (64 rows) or of 16.
constexpr int kW = 37, kH = 70;

const std::vector<float>& channel(const ImageFile& img, const std::string& name) {
    for (std::size_t c = 0; c < img.channel_names.size(); ++c)
        if (img.channel_names[c] == name) return img.channels[c];
    ADD_FAILURE() << "no channel " << name;
    static const std::vector<float> none;
    return none;
}

class ImageIo : public ::testing::TestWithParam<ExrCompression> {};

TEST_P(ImageIo, ExrViewsReadBackExactlyWithTheirStoredTypes) {
    const std::size_t n = static_cast<std::size_t>(kW) * kH;
    // An interleaved xyz array read as three strided views, a uint channel, and a mask of
    // values half holds exactly.
    std::vector<float> xyz(3 * n);
    std::vector<std::uint32_t> ids(n);
    std::vector<float> mask(n);
    for (std::size_t i = 0; i < n; ++i) {
        xyz[3 * i] = 0.1f * static_cast<float>(i);
        xyz[3 * i + 1] = -1e7f + static_cast<float>(i);
        xyz[3 * i + 2] = i % 5 ? std::ldexp(1.0f, -static_cast<int>(i % 40)) : std::numeric_limits<float>::infinity();
        ids[i] = i % 7 ? static_cast<std::uint32_t>(i * 2654435761u) : 0xFFFFFFFFu;
        mask[i] = static_cast<float>(i % 3) * 0.5f;  // 0, 0.5, 1
    }
    const test::TempDir tmp;
    const fs::path dir = tmp.path() / "out";
    {
        OutputTransaction out(dir);
        write_exr(out, "views.exr", kW, kH,
                  {{"P.X", ExrStorage::f32, xyz.data(), 3},
                   {"P.Y", ExrStorage::f32, xyz.data() + 1, 3},
                   {"P.Z", ExrStorage::f32, xyz.data() + 2, 3},
                   {"prim", ExrStorage::u32, ids.data(), 1},
                   {"mask", ExrStorage::half, mask.data(), 1}},
                  GetParam());
        out.commit();
    }
    const ImageFile img = read_image(dir / "views.exr");
    EXPECT_EQ(img.format, "openexr");
    ASSERT_EQ(img.width, kW);
    ASSERT_EQ(img.height, kH);
    const auto& x = channel(img, "P.X");
    const auto& y = channel(img, "P.Y");
    const auto& z = channel(img, "P.Z");
    const auto& m = channel(img, "mask");
    ASSERT_EQ(x.size(), n);
    for (std::size_t i = 0; i < n; ++i) {
        ASSERT_EQ(x[i], xyz[3 * i]) << i;
        ASSERT_EQ(y[i], xyz[3 * i + 1]) << i;
        ASSERT_EQ(z[i], xyz[3 * i + 2]) << i;
        ASSERT_EQ(m[i], mask[i]) << i;
    }
    // The types stored, seen by OpenEXR itself.
    Imf::InputFile file((dir / "views.exr").c_str());
    const Imf::ChannelList& channels = file.header().channels();
    EXPECT_EQ(channels.findChannel("P.X")->type, Imf::FLOAT);
    EXPECT_EQ(channels.findChannel("prim")->type, Imf::UINT);
    EXPECT_EQ(channels.findChannel("mask")->type, Imf::HALF);
    EXPECT_EQ(file.header().compression(),
              GetParam() == ExrCompression::zip ? Imf::ZIP_COMPRESSION : Imf::NO_COMPRESSION);
    // The uint channel exactly (OIIO would normalise it to [0, 1]).
    std::vector<std::uint32_t> read_ids(n);
    Imf::FrameBuffer frame;
    frame.insert("prim", Imf::Slice(Imf::UINT, reinterpret_cast<char*>(read_ids.data()), sizeof(std::uint32_t),
                                    sizeof(std::uint32_t) * kW));
    file.setFrameBuffer(frame);
    file.readPixels(0, kH - 1);
    EXPECT_EQ(read_ids, ids);
}

INSTANTIATE_TEST_SUITE_P(Compression, ImageIo, ::testing::Values(ExrCompression::zip, ExrCompression::none),
                         [](const auto& param_info) {
                             return param_info.param == ExrCompression::zip ? "zip" : "none";
                         });

// IEC 61966-2-1, in double: the code a linear value should get.
int srgb_code(double linear) {
    const double v = std::clamp(linear, 0.0, 1.0);
    const double s = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
    return static_cast<int>(std::lround(s * 255.0));
}

TEST(ImageIoPng, RgbIsSrgbEncodedAndReadsBack) {
    const std::size_t n = static_cast<std::size_t>(kW) * kH;
    std::vector<float> rgb(3 * n);
    for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] = static_cast<float>(i % 1000) / 999.0f;
    rgb[0] = -0.5f;  // clamped
    rgb[1] = 2.0f;
    const test::TempDir tmp;
    const fs::path dir = tmp.path() / "out";
    {
        OutputTransaction out(dir);
        write_png(out, "rgb.png", kW, kH, rgb);
        out.commit();
    }
    const ImageFile img = read_image(dir / "rgb.png");
    EXPECT_EQ(img.format, "png");
    EXPECT_EQ(img.bits, 8);
    ASSERT_EQ(img.channels.size(), 3u);
    ASSERT_EQ(img.width, kW);
    ASSERT_EQ(img.height, kH);
    int off_by_one = 0;
    for (std::size_t i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) {
            const int got = static_cast<int>(std::lround(img.channels[c][i] * 255.0f));
            const int want = srgb_code(rgb[3 * i + c]);
            // The writer decides in float, the reference in double: they may differ by one
            // code exactly at a threshold, never more.
            ASSERT_LE(std::abs(got - want), 1) << "pixel " << i << " channel " << c;
            off_by_one += got != want;
        }
    EXPECT_LT(off_by_one, 10);
    EXPECT_EQ(std::lround(img.channels[0][0] * 255.0f), 0);
    EXPECT_EQ(std::lround(img.channels[1][0] * 255.0f), 255);
}

// The writer's sRGB code of a float, the transfer function evaluated in float as the writer's
// exact reference does (its table must give this code for every float).
int srgb_code_in_float(float linear) {
    const float v = std::clamp(linear, 0.0f, 1.0f);
    const float s = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
    return static_cast<int>(std::lround(s * 255.0f));
}

// At every code's threshold (the smallest float of code k, found by bisection over the float
// bits) and one float below it, the PNG holds the formula's code exactly: the table's bucket and
// its one in-bucket threshold, where an off-by-one would change a pixel, are right at the edges.
// Zero, -0, negatives, NaN and values above 1 too.
TEST(ImageIoPng, SrgbCodesAreTheFormulasAtEveryThreshold) {
    std::vector<float> values = {0.0f,
                                 -0.0f,
                                 -1.0f,
                                 std::numeric_limits<float>::quiet_NaN(),
                                 1.0f,
                                 2.0f,
                                 std::numeric_limits<float>::infinity(),
                                 std::numeric_limits<float>::denorm_min()};
    for (int k = 1; k < 256; ++k) {
        std::uint32_t lo = 0, hi = 0x3F800000u;  // the bits of 0.0f and 1.0f
        while (lo < hi) {
            const std::uint32_t mid = lo + (hi - lo) / 2;
            if (srgb_code_in_float(std::bit_cast<float>(mid)) >= k)
                hi = mid;
            else
                lo = mid + 1;
        }
        values.push_back(std::bit_cast<float>(lo));
        values.push_back(std::bit_cast<float>(lo - 1));
        values.push_back(std::bit_cast<float>(lo + 1));
    }
    const int w = static_cast<int>(values.size());  // one row, grey: R = G = B
    std::vector<float> rgb;
    for (float v : values) rgb.insert(rgb.end(), {v, v, v});
    const test::TempDir tmp;
    const fs::path dir = tmp.path() / "out";
    {
        OutputTransaction out(dir);
        write_png(out, "edges.png", w, 1, rgb);
        out.commit();
    }
    const ImageFile img = read_image(dir / "edges.png");
    ASSERT_EQ(img.width, w);
    for (int i = 0; i < w; ++i) {
        // NaN takes code 0, as the formula gives it on x86-64 (lround's LONG_MIN).
        const int want = std::isnan(values[i]) ? 0 : srgb_code_in_float(values[i]);
        EXPECT_EQ(std::lround(img.channels[0][i] * 255.0f), want) << "value " << values[i] << " (#" << i << ")";
    }
}

// Rows asked for one at a time land where they belong: row y holds code y in every channel
// (codes 0..69, each at the centre of its interval), and each row is asked for once, top to bottom.
TEST(ImageIoPng, RowSourceRowsLandInOrder) {
    std::vector<int> asked;
    const test::TempDir tmp;
    const fs::path dir = tmp.path() / "out";
    {
        OutputTransaction out(dir);
        write_png(out, "rows.png", kW, kH, [&](int y, float* rgb) {
            asked.push_back(y);
            // The linear value at the centre of code y's interval (whose ends are y ± 0.5).
            const double s = y / 255.0;
            const double lin = s <= 0.04045 ? s / 12.92 : std::pow((s + 0.055) / 1.055, 2.4);
            for (int i = 0; i < 3 * kW; ++i) rgb[i] = static_cast<float>(lin);
        });
        out.commit();
    }
    ASSERT_EQ(asked.size(), static_cast<std::size_t>(kH));
    for (int y = 0; y < kH; ++y) EXPECT_EQ(asked[static_cast<std::size_t>(y)], y);
    const ImageFile img = read_image(dir / "rows.png");
    ASSERT_EQ(img.channels.size(), 3u);
    for (int y = 0; y < kH; ++y)
        for (int c = 0; c < 3; ++c)
            for (int x = 0; x < kW; x += 9)
                ASSERT_EQ(std::lround(img.channels[c][static_cast<std::size_t>(y) * kW + x] * 255.0f), y)
                    << "row " << y << " x " << x << " channel " << c;
}

std::vector<char> file_bytes(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Rows made on several threads (PngRows::parallel, 4 threads) give the serial writer's bytes,
// and every row is asked for exactly once (issue #39: the preview's rows no longer on one thread).
TEST(ImageIoPng, ParallelRowsGiveTheSerialBytes) {
    constexpr int kWide = 301, kTall = 211;  // not multiples of the writer's blocks of rows
    auto pattern = [](int y, float* rgb) {
        for (int i = 0; i < 3 * kWide; ++i) rgb[i] = static_cast<float>((y * 7 + i * 13) % 257) / 256.0f;
    };
    std::vector<std::atomic<int>> asked(kTall);
    const test::TempDir tmp;
    const fs::path dir = tmp.path() / "out";
    {
        OutputTransaction out(dir);
        write_png(out, "serial.png", kWide, kTall, pattern);
        tbb::task_arena(4).execute([&] {
            write_png(
                out, "parallel.png", kWide, kTall,
                [&](int y, float* rgb) {
                    ++asked[static_cast<std::size_t>(y)];
                    pattern(y, rgb);
                },
                PngRows::parallel);
        });
        out.commit();
    }
    for (int y = 0; y < kTall; ++y) ASSERT_EQ(asked[static_cast<std::size_t>(y)].load(), 1) << "row " << y;
    const std::vector<char> serial = file_bytes(dir / "serial.png");
    ASSERT_GT(serial.size(), 100u);
    EXPECT_EQ(file_bytes(dir / "parallel.png"), serial);
}

// Half channels, converted on the command's threads, give the same file whatever their number.
TEST(ImageIoExr, HalfChannelsGiveTheSameBytesOnOneThreadAndOnFour) {
    constexpr int kWide = 53, kTall = 150;  // three strips of the writer's 64 rows, the last short
    const std::size_t n = static_cast<std::size_t>(kWide) * kTall;
    std::vector<float> flags(2 * n), depth(n);
    for (std::size_t i = 0; i < n; ++i) {
        flags[2 * i] = static_cast<float>(i % 3) * 0.5f;
        flags[2 * i + 1] = static_cast<float>((i * 2654435761u) % 1000) / 7.0f;  // rounded to half
        depth[i] = 0.25f * static_cast<float>(i);
    }
    const std::vector<ExrChannelView> channels = {{"a", ExrStorage::half, flags.data(), 2},
                                                  {"b", ExrStorage::half, flags.data() + 1, 2},
                                                  {"depth", ExrStorage::f32, depth.data(), 1}};
    const test::TempDir tmp;
    const fs::path dir = tmp.path() / "out";
    {
        OutputTransaction out(dir);
        tbb::task_arena(1).execute([&] { write_exr(out, "one.exr", kWide, kTall, channels, ExrCompression::none); });
        tbb::task_arena(4).execute([&] { write_exr(out, "four.exr", kWide, kTall, channels, ExrCompression::none); });
        out.commit();
    }
    const std::vector<char> one = file_bytes(dir / "one.exr");
    ASSERT_GT(one.size(), n * 8);
    EXPECT_EQ(file_bytes(dir / "four.exr"), one);
    const ImageFile img = read_image(dir / "four.exr");
    const auto& b = channel(img, "b");
    ASSERT_EQ(b.size(), n);
    for (std::size_t i = 0; i < n; i += 17) ASSERT_EQ(b[i], static_cast<float>(Imath::half(flags[2 * i + 1]))) << i;
}

// oracle.exr's early write (#39): channels written as placeholders (one row for every row) and
// patched in place afterwards give the file written with them in one go, byte for byte: float,
// half and uint channels, strided views, channels on both sides of unpatched ones.
TEST(ImageIoExr, PatchedChannelsGiveTheFileWrittenWithThem) {
    constexpr int kWide = 53, kTall = 150;
    const std::size_t n = static_cast<std::size_t>(kWide) * kTall;
    std::vector<float> xyz(3 * n), mask(n), dist(n);
    std::vector<std::uint32_t> ids(n);
    for (std::size_t i = 0; i < n; ++i) {
        for (int c = 0; c < 3; ++c) xyz[3 * i + c] = 0.37f * static_cast<float>(i) - static_cast<float>(c);
        mask[i] = static_cast<float>(i % 3 == 0);
        dist[i] = i % 11 ? 0.001f * static_cast<float>(i) : std::numeric_limits<float>::infinity();
        ids[i] = static_cast<std::uint32_t>(i * 2654435761u);
    }
    const std::vector<ExrChannelView> final_views = {
        {"P.X", ExrStorage::f32, xyz.data(), 3},         {"P.Y", ExrStorage::f32, xyz.data() + 1, 3},
        {"U", ExrStorage::half, mask.data(), 1},         {"V", ExrStorage::f32, dist.data(), 1},
        {"boundary_m", ExrStorage::f32, dist.data(), 1}, {"prim", ExrStorage::u32, ids.data(), 1}};
    const std::vector<float> zeros(kWide, 0.0f);
    std::vector<ExrChannelView> placeholders = final_views, patched;
    for (ExrChannelView& c : placeholders)
        if (c.name == "U" || c.name == "boundary_m" || c.name == "P.Y" || c.name == "prim") {
            patched.push_back(c);
            c = {c.name, c.storage, zeros.data(), 1, true};
        }
    const test::TempDir tmp;
    const fs::path dir = tmp.path() / "out";
    {
        OutputTransaction out(dir);
        write_exr(out, "direct.exr", kWide, kTall, final_views, ExrCompression::none);
        write_exr(out, "patched.exr", kWide, kTall, placeholders, ExrCompression::none);
        tbb::task_arena(4).execute([&] { patch_exr_channels(out, "patched.exr", kWide, kTall, patched); });
        out.commit();
    }
    const std::vector<char> direct = file_bytes(dir / "direct.exr");
    ASSERT_GT(direct.size(), n * 20);
    EXPECT_TRUE(file_bytes(dir / "patched.exr") == direct);
}

// A file of another layout is refused as an internal error (exit 4), before any byte is written:
// compressed, another size, a channel it does not have or of another type.
TEST(ImageIoExr, PatchRefusesAFileOfAnotherLayout) {
    constexpr int kWide = 20, kTall = 10;
    std::vector<float> v(static_cast<std::size_t>(kWide) * kTall, 0.5f);
    const std::vector<ExrChannelView> channels = {{"a", ExrStorage::f32, v.data(), 1},
                                                  {"b", ExrStorage::half, v.data(), 1}};
    const test::TempDir tmp;
    OutputTransaction out(tmp.path() / "out");
    write_exr(out, "zip.exr", kWide, kTall, channels, ExrCompression::zip);
    write_exr(out, "none.exr", kWide, kTall, channels, ExrCompression::none);
    const std::vector<char> none = file_bytes(out.stage("none.exr"));
    auto refused = [&](const std::string& name, int w, int h, const std::vector<ExrChannelView>& views,
                       const std::string& why) {
        try {
            patch_exr_channels(out, name, w, h, views);
            ADD_FAILURE() << why << ": not refused";
        } catch (const std::logic_error& e) {
            EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
        }
    };
    refused("zip.exr", kWide, kTall, {channels[0]}, "compressed");
    refused("none.exr", kWide, kTall + 1, {channels[0]}, "data window");
    refused("none.exr", kWide, kTall, {{"c", ExrStorage::f32, v.data(), 1}}, "no channel c");
    refused("none.exr", kWide, kTall, {{"b", ExrStorage::f32, v.data(), 1}}, "channel b of pixel type 1");
    EXPECT_TRUE(file_bytes(out.stage("none.exr")) == none);
}

// The PNG's zlib stream made in pieces (PngRows::parallel_deflate, oracle.png, #39): the same
// bytes on 1 thread and on 4, several IDAT pieces (each with its dictionary), and the serial
// writer's pixels when read back.
TEST(ImageIoPng, ZlibStreamInPiecesIsTheSameAtEveryThreadCountAndDecodesToTheSerialPixels) {
    constexpr int kWide = 301, kTall = 1000;  // 904 filtered bytes a row: 4 pieces, the last short
    auto pattern = [](int y, float* rgb) {
        for (int i = 0; i < 3 * kWide; ++i) {
            // Smooth areas and edges, repeating with a period that reaches across pieces.
            const int x = i / 3, c = i % 3;
            rgb[i] = ((x / 17 + y / 23 + c) % 5) * 0.2f + static_cast<float>((x * y) % 7) * 0.01f;
        }
    };
    const test::TempDir tmp;
    const fs::path dir = tmp.path() / "out";
    {
        OutputTransaction out(dir);
        write_png(out, "serial.png", kWide, kTall, pattern);
        tbb::task_arena(1).execute(
            [&] { write_png(out, "one.png", kWide, kTall, pattern, PngRows::parallel_deflate); });
        tbb::task_arena(4).execute(
            [&] { write_png(out, "four.png", kWide, kTall, pattern, PngRows::parallel_deflate); });
        out.commit();
    }
    const std::vector<char> one = file_bytes(dir / "one.png");
    EXPECT_TRUE(file_bytes(dir / "four.png") == one);
    const std::string bytes(one.begin(), one.end());
    std::size_t idat = 0;
    for (std::size_t at = bytes.find("IDAT"); at != std::string::npos; at = bytes.find("IDAT", at + 4)) ++idat;
    EXPECT_EQ(idat, 4u);
    const ImageFile serial = read_image(dir / "serial.png");
    const ImageFile pieces = read_image(dir / "four.png");
    ASSERT_EQ(pieces.width, kWide);
    ASSERT_EQ(pieces.height, kTall);
    ASSERT_EQ(pieces.channels.size(), 3u);
    for (int c = 0; c < 3; ++c) EXPECT_TRUE(pieces.channels[c] == serial.channels[c]) << "channel " << c;
}

// read_image(file) throws an InputError whose message names the file.
void expect_input_error_naming(const fs::path& file) {
    try {
        read_image(file);
        ADD_FAILURE() << file << ": no error";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find(file.filename().string()), std::string::npos) << e.what();
    }
}

TEST(ImageIoRead, MissingAndNonImageFilesAreInputErrorsNamingTheFile) {
    const test::TempDir tmp;
    expect_input_error_naming(tmp / "absent.exr");
    std::ofstream(tmp / "notes.png") << "not a picture\n";
    expect_input_error_naming(tmp / "notes.png");
}

}  // namespace
}  // namespace penumbra
