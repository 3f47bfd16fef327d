#include "common/output_files.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>
#include <xxhash.h>

#include <cerrno>
#include <cstdint>
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

fs::path OutputTransaction::stage(const std::string& name) {
    std::lock_guard lock(stage_mutex_);
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

void OutputTransaction::write_json(const std::string& name, const nlohmann::json& value) {
    // Paths and names from the command line may hold bytes that are not UTF-8 (a Latin-1
    // folder name): written as U+FFFD rather than failing the whole run.
    write_text(name, value.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
}

void OutputTransaction::write_text(const std::string& name, const std::string& text) {
    fs::path tmp = stage(name);
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
    static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    out.reserve((bytes.size() + 2) / 3 * 4);
    std::size_t i = 0;
    for (; i + 3 <= bytes.size(); i += 3) {
        const std::uint32_t v = std::uint32_t(std::uint8_t(bytes[i])) << 16 |
                                std::uint32_t(std::uint8_t(bytes[i + 1])) << 8 | std::uint8_t(bytes[i + 2]);
        for (int shift : {18, 12, 6, 0}) out += kAlphabet[v >> shift & 63];
    }
    if (const std::size_t rest = bytes.size() - i; rest > 0) {
        std::uint32_t v = std::uint32_t(std::uint8_t(bytes[i])) << 16;
        if (rest == 2) v |= std::uint32_t(std::uint8_t(bytes[i + 1])) << 8;
        out += kAlphabet[v >> 18 & 63];
        out += kAlphabet[v >> 12 & 63];
        out += rest == 2 ? kAlphabet[v >> 6 & 63] : '=';
        out += '=';
    }
    return out;
}

std::string content_fingerprint(std::string_view bytes) {
    const XXH128_hash_t h = XXH3_128bits(bytes.data(), bytes.size());
    return fmt::format("{:016x}{:016x}", h.high64, h.low64);
}

void OutputTransaction::commit() {
    for (auto& [tmp, final_path] : files_) {
        std::error_code ec;
        // A rename over an existing file makes ext4 write the new file's data out before it
        // returns (its auto_da_alloc heuristic): 0.2-0.27 s for a 2048^2 oracle.exr, a tenth of
        // the run, at every run into the same folder. The old file is removed first instead.
        if (fs::is_regular_file(fs::symlink_status(final_path, ec))) fs::remove(final_path, ec);
        fs::rename(tmp, final_path, ec);
        if (ec)
            throw EnvironmentError(fmt::format("{}: cannot move into place: {}", final_path.string(), ec.message()));
    }
    committed_ = true;
}

}  // namespace penumbra
