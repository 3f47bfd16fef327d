#include "common/output_files.h"

#include <OpenImageIO/hash.h>
#include <OpenImageIO/imageio.h>
#include <OpenImageIO/strutil.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>

#include "common/errors.h"

namespace penumbra {
namespace fs = std::filesystem;

OutputTransaction::OutputTransaction(fs::path dir) : dir_(std::move(dir)) {}

OutputTransaction::~OutputTransaction() {
    if (committed_) return;
    std::error_code ec;
    for (auto& [tmp, final_path] : files_) fs::remove(tmp, ec);
    if (created_dir_) fs::remove(dir_, ec);  // only succeeds if empty
}

fs::path OutputTransaction::temporary(const std::string& name) {
    std::error_code ec;
    if (!fs::exists(dir_, ec)) {
        if (!fs::create_directories(dir_, ec) || ec)
            throw InputError(fmt::format("{}: cannot create output folder: {}", dir_.string(), ec.message()));
        created_dir_ = true;
    } else if (!fs::is_directory(dir_, ec)) {
        throw InputError(fmt::format("{}: output path exists and is not a folder", dir_.string()));
    }
    fs::path tmp = dir_ / fmt::format(".{}.tmp-{}", name, ::getpid());
    files_.emplace_back(tmp, dir_ / name);
    return tmp;
}

void OutputTransaction::write_exr(const std::string& name, int width, int height,
                                  const std::vector<ExrChannel>& channels) {
    fs::path tmp = temporary(name);
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
    auto out = OIIO::ImageOutput::create("openexr");
    if (!out || !out->open(tmp.string(), spec) || !out->write_image(OIIO::TypeUnknown, data.data()) || !out->close())
        throw EnvironmentError(
            fmt::format("{}: cannot write EXR: {}", (dir_ / name).string(), out ? out->geterror() : OIIO::geterror()));
}

void OutputTransaction::write_png(const std::string& name, int width, int height, const std::vector<float>& rgb) {
    fs::path tmp = temporary(name);
    std::vector<unsigned char> bytes(rgb.size());
    for (std::size_t i = 0; i < rgb.size(); ++i) {
        float v = std::clamp(rgb[i], 0.0f, 1.0f);
        float s = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
        bytes[i] = static_cast<unsigned char>(std::lround(s * 255.0f));
    }
    OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::UINT8);
    auto out = OIIO::ImageOutput::create("png");
    if (!out || !out->open(tmp.string(), spec) || !out->write_image(OIIO::TypeDesc::UINT8, bytes.data()) ||
        !out->close())
        throw EnvironmentError(
            fmt::format("{}: cannot write PNG: {}", (dir_ / name).string(), out ? out->geterror() : OIIO::geterror()));
}

void OutputTransaction::write_json(const std::string& name, const nlohmann::json& value) {
    // Paths and names from the command line may hold bytes that are not UTF-8 (a Latin-1
    // folder name): written as U+FFFD rather than failing the whole run.
    write_text(name, value.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
}

void OutputTransaction::write_text(const std::string& name, const std::string& text) {
    fs::path tmp = temporary(name);
    std::ofstream out(tmp, std::ios::binary);
    out << text;
    out.close();
    if (!out) throw EnvironmentError(fmt::format("{}: cannot write", (dir_ / name).string()));
}

std::string OutputTransaction::written_bytes(const std::string& name) const {
    for (const auto& [tmp, final_path] : files_) {
        if (final_path.filename() != name) continue;
        std::ifstream in(committed_ ? final_path : tmp, std::ios::binary);
        std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        if (!in && !in.eof()) break;
        return bytes;
    }
    throw EnvironmentError(fmt::format("{}: cannot read back {}", dir_.string(), name));
}

void check_output_file(const fs::path& file, const fs::path& out_dir, const std::string& option) {
    auto bad = [&](const std::string& what) {
        throw InputError(fmt::format("{} {}: {}", option, file.string(), what));
    };
    if (!file.has_filename()) bad("names a folder, not a file");
    std::error_code ec;
    const fs::path target = fs::weakly_canonical(fs::absolute(file), ec);
    if (!ec && target == fs::weakly_canonical(fs::absolute(out_dir), ec)) bad("is the --out folder");
    if (fs::is_directory(file, ec)) bad("is a folder");
    if (fs::exists(file, ec) && !fs::is_regular_file(file, ec)) bad("exists and is not a regular file");
    // The nearest folder that exists must be writable: the file, and the folders missing on the
    // way to it, are made there.
    fs::path dir = fs::absolute(file).parent_path();
    while (!dir.empty() && !fs::exists(dir, ec) && dir != dir.root_path()) dir = dir.parent_path();
    if (!fs::is_directory(dir, ec)) bad(fmt::format("{} is not a folder", dir.string()));
    // Create a file there and remove it: permission bits alone do not tell (root, read-only
    // mounts, /proc).
    const fs::path probe = dir / fmt::format(".penumbra-write-check-{}", ::getpid());
    const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
    if (fd < 0) bad(fmt::format("cannot write into {}: {}", dir.string(), std::strerror(errno)));
    ::close(fd);
    fs::remove(probe, ec);
}

std::string base64_encode(std::string_view bytes) {
    return OIIO::Strutil::base64_encode(bytes);
}

std::string content_fingerprint(std::string_view bytes) {
    const OIIO::farmhash::uint128_t h = OIIO::farmhash::Fingerprint128(bytes.data(), bytes.size());
    return fmt::format("{:016x}{:016x}", OIIO::farmhash::Uint128High64(h), OIIO::farmhash::Uint128Low64(h));
}

void OutputTransaction::commit() {
    for (auto& [tmp, final_path] : files_) {
        std::error_code ec;
        fs::rename(tmp, final_path, ec);
        if (ec)
            throw EnvironmentError(fmt::format("{}: cannot move into place: {}", final_path.string(), ec.message()));
    }
    committed_ = true;
}

}  // namespace penumbra
