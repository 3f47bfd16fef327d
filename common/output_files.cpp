#include "common/output_files.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <stdio.h>  // renameat2
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>
#include <xxhash.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <climits>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <utility>

#include "common/errors.h"

namespace penumbra {
namespace fs = std::filesystem;

namespace {

// The interrupt cleanup's registry. A signal handler may only call async-signal-safe functions
// (POSIX.1-2017, 2.4.3): it cannot lock a mutex or walk a std::vector another thread is
// growing. So paths live in fixed slots whose state is a lock-free atomic: 0 free, 1 being
// filled, 2 a file to unlink, 3 a folder to rmdir. 512 slots of PATH_MAX bytes (2 MiB of
// zero pages, touched only as used) hold far more temporaries than any run stages at once.
constexpr int kSlots = 512;
enum SlotState : int { kFree = 0, kFilling = 1, kFile = 2, kFolder = 3 };
struct Slot {
    std::atomic<int> state{kFree};
    char path[PATH_MAX];
};
Slot g_slots[kSlots];
static_assert(std::atomic<int>::is_always_lock_free);

// Commits run with interrupts deferred: the handler then only records the signal, and the
// commit raises it once its files are all in place (or all back).
std::atomic<int> g_deferring{0};
std::atomic<int> g_pending_signal{0};

void remove_tracked_and_reraise(int sig) {
    for (Slot& s : g_slots)
        if (s.state.load() == kFile) ::unlink(s.path);
    for (int i = kSlots - 1; i >= 0; --i)  // folders after the files in them
        if (g_slots[i].state.load() == kFolder) ::rmdir(g_slots[i].path);
    ::signal(sig, SIG_DFL);
    ::raise(sig);
}

extern "C" void on_interrupt(int sig) {
    if (g_deferring.load() > 0) {
        g_pending_signal.store(sig);
        return;
    }
    remove_tracked_and_reraise(sig);
}

// Defers interrupts for a commit's duration; a signal that came meanwhile is raised at the end.
class InterruptsDeferred {
  public:
    InterruptsDeferred() { ++g_deferring; }
    ~InterruptsDeferred() {
        if (--g_deferring == 0)
            if (const int sig = g_pending_signal.exchange(0)) remove_tracked_and_reraise(sig);
    }
    InterruptsDeferred(const InterruptsDeferred&) = delete;
    InterruptsDeferred& operator=(const InterruptsDeferred&) = delete;
};

// renameat2(2) with RENAME_EXCHANGE swaps two names atomically. Replacing an earlier run's
// file this way keeps its name present throughout (a plain rename would too), and unlike a
// rename over it, it does not make ext4 write the new file's data out before returning (its
// auto_da_alloc safeguard: 0.2-0.3 s for a 200 MB file on this project's VM).
bool exchange(const fs::path& a, const fs::path& b, std::error_code& ec) {
    if (::renameat2(AT_FDCWD, a.c_str(), AT_FDCWD, b.c_str(), RENAME_EXCHANGE) == 0) return true;
    ec = std::error_code(errno, std::generic_category());
    return false;
}

// A file system without RENAME_EXCHANGE (some network and FUSE ones) answers EINVAL or ENOSYS.
bool exchange_unsupported(const std::error_code& ec) {
    return ec.value() == EINVAL || ec.value() == ENOSYS || ec.value() == EOPNOTSUPP;
}

}  // namespace

ExclusiveTemporary create_exclusive_temporary(const fs::path& dir, const std::string& name) {
    for (int attempt = 0; attempt < 32; ++attempt) {
        std::uint64_t random = 0;
        if (::getrandom(&random, sizeof random, 0) != sizeof random)
            random = static_cast<std::uint64_t>(::getpid()) << 32 ^ static_cast<std::uint64_t>(attempt) ^
                     static_cast<std::uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count());
        ExclusiveTemporary t;
        t.path = dir / fmt::format(".{}.tmp-{}-{:016x}", name, ::getpid(), random);
        // O_EXCL with O_NOFOLLOW: a name someone planted (a symbolic link, a file) is never
        // opened, let alone written through; 0666 leaves the permissions to the umask, as any
        // file the user creates.
        t.fd = ::open(t.path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
        if (t.fd < 0 && errno == EEXIST) continue;
        if (t.fd < 0)
            throw EnvironmentError(
                fmt::format("{}: cannot create a temporary file there: {}", dir.string(), std::strerror(errno)));
        struct stat st {};
        if (::fstat(t.fd, &st) != 0) {
            ::close(t.fd);
            throw EnvironmentError(fmt::format("{}: cannot create a temporary file there", dir.string()));
        }
        t.device = st.st_dev;
        t.inode = st.st_ino;
        return t;
    }
    throw EnvironmentError(fmt::format("{}: cannot create a temporary file there (every name taken)", dir.string()));
}

bool is_same_file(const fs::path& path, std::uint64_t device, std::uint64_t inode) {
    struct stat st {};
    return ::lstat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode) && st.st_dev == device && st.st_ino == inode;
}

void remove_if_same_file(const fs::path& path, std::uint64_t device, std::uint64_t inode) {
    if (is_same_file(path, device, inode)) ::unlink(path.c_str());
}

int open_staged_for_writing(const fs::path& path, std::uint64_t device, std::uint64_t inode) {
    const int fd = ::open(path.c_str(), O_WRONLY | O_TRUNC | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) return -1;
    struct stat st {};
    if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) || st.st_dev != device || st.st_ino != inode) {
        ::close(fd);
        errno = EEXIST;
        return -1;
    }
    return fd;
}

std::string replaceable_target_problem(const fs::path& target) {
    struct stat st {};
    if (::lstat(target.c_str(), &st) != 0) return {};  // nothing there (or not reachable: the rename says)
    if (S_ISREG(st.st_mode)) return {};
    const char* what = S_ISLNK(st.st_mode)    ? "a symbolic link"
                       : S_ISDIR(st.st_mode)  ? "a folder"
                       : S_ISFIFO(st.st_mode) ? "a FIFO"
                       : S_ISCHR(st.st_mode)  ? "a character device"
                       : S_ISBLK(st.st_mode)  ? "a block device"
                       : S_ISSOCK(st.st_mode) ? "a socket"
                                              : "not a regular file";
    return fmt::format("{}: is {}; penumbra replaces only regular files, so it is left as it is", target.string(),
                       what);
}

int track_for_interrupt(const fs::path& path, bool folder) {
    const std::string& p = path.native();
    if (p.size() >= PATH_MAX) return -1;
    for (int i = 0; i < kSlots; ++i) {
        int expected = kFree;
        if (!g_slots[i].state.compare_exchange_strong(expected, kFilling)) continue;
        std::memcpy(g_slots[i].path, p.c_str(), p.size() + 1);
        g_slots[i].state.store(folder ? kFolder : kFile);
        return i;
    }
    return -1;
}

void untrack_for_interrupt(int slot) {
    if (slot >= 0 && slot < kSlots) g_slots[slot].state.store(kFree);
}

void install_interrupt_cleanup() {
    for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
        struct sigaction old {};
        if (::sigaction(sig, nullptr, &old) == 0 && old.sa_handler == SIG_IGN) continue;  // nohup
        struct sigaction sa {};
        sa.sa_handler = on_interrupt;
        sigemptyset(&sa.sa_mask);
        sa.sa_flags = SA_RESTART;
        ::sigaction(sig, &sa, nullptr);
    }
}

OutputTransaction::OutputTransaction(fs::path dir) : dir_(std::move(dir)) {}

OutputTransaction::~OutputTransaction() {
    std::error_code ec;
    for (const Staged& f : files_) {
        if (!committed_) remove_if_same_file(f.tmp, f.device, f.inode);
        untrack_for_interrupt(f.tracked);
    }
    if (created_dir_ && !committed_) fs::remove(dir_, ec);  // only succeeds if empty
    untrack_for_interrupt(tracked_dir_);
}

fs::path OutputTransaction::stage(const std::string& name) {
    std::lock_guard lock(stage_mutex_);
    std::error_code ec;
    if (!fs::exists(dir_, ec)) {
        if (!fs::create_directories(dir_, ec) || ec)
            throw InputError(fmt::format("{}: cannot create output folder: {}", dir_.string(), ec.message()));
        created_dir_ = true;
        tracked_dir_ = track_for_interrupt(dir_, true);
    } else if (!fs::is_directory(dir_, ec)) {
        throw InputError(fmt::format("{}: output path exists and is not a folder", dir_.string()));
    }
    const fs::path final_path = dir_ / name;
    for (const Staged& f : files_)
        if (f.final_path == final_path) return f.tmp;  // staged twice: one temporary, moved once
    ExclusiveTemporary t = create_exclusive_temporary(dir_, name);
    ::close(t.fd);
    files_.push_back({t.path, final_path, track_for_interrupt(t.path, false), t.device, t.inode});
    return t.path;
}

void OutputTransaction::write_json(const std::string& name, const nlohmann::json& value) {
    // Paths and names from the command line may hold bytes that are not UTF-8 (a Latin-1
    // folder name): written as U+FFFD rather than failing the whole run.
    write_text(name, value.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
}

void OutputTransaction::write_text(const std::string& name, const std::string& text) {
    const fs::path tmp = stage(name);
    const int fd = open_staged(tmp);
    bool ok = fd >= 0;
    for (std::size_t done = 0; ok && done < text.size();) {
        const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
        if (n < 0 && errno == EINTR) continue;
        ok = n > 0;
        if (ok) done += static_cast<std::size_t>(n);
    }
    if (fd >= 0 && ::close(fd) != 0) ok = false;
    if (!ok) throw EnvironmentError(fmt::format("{}: cannot write", (dir_ / name).string()));
}

int OutputTransaction::open_staged(const fs::path& tmp) {
    std::lock_guard lock(stage_mutex_);
    for (const Staged& f : files_)
        if (f.tmp == tmp) return open_staged_for_writing(tmp, f.device, f.inode);
    errno = ENOENT;
    return -1;
}

std::string OutputTransaction::written_bytes(const std::string& name) const {
    for (const Staged& f : files_) {
        if (f.final_path.filename() != name) continue;
        // Only the file this transaction wrote, never what a link put at its name points to.
        if (!committed_ && !is_same_file(f.tmp, f.device, f.inode)) break;
        std::ifstream in(committed_ ? f.final_path : f.tmp, std::ios::binary);
        std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        if (!in && !in.eof()) break;
        return bytes;
    }
    throw EnvironmentError(fmt::format("{}: cannot read back {}", dir_.string(), name));
}

namespace {

// Why no file can be made in `dir`, the nearest existing folder at or above it ("" when one
// can): a file is created there and removed, since permission bits alone do not tell (root,
// read-only mounts, /proc).
std::string unwritable_problem(fs::path dir) {
    std::error_code ec;
    while (!dir.empty() && !fs::exists(dir, ec) && dir != dir.root_path()) dir = dir.parent_path();
    if (!fs::is_directory(dir, ec)) return fmt::format("{} is not a folder", dir.string());
    const fs::path probe = dir / fmt::format(".penumbra-write-check-{}", ::getpid());
    const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
    if (fd < 0) return fmt::format("cannot write into {}: {}", dir.string(), std::strerror(errno));
    ::close(fd);
    fs::remove(probe, ec);
    return {};
}

}  // namespace

void check_output_file(const fs::path& file, const fs::path& out_dir, const std::string& option) {
    auto bad = [&](const std::string& what) {
        throw InputError(fmt::format("{} {}: {}", option, file.string(), what));
    };
    if (!file.has_filename()) bad("names a folder, not a file");
    std::error_code ec;
    const fs::path target = fs::weakly_canonical(fs::absolute(file), ec);
    if (!ec && target == fs::weakly_canonical(fs::absolute(out_dir), ec)) bad("is the --out folder");
    if (fs::is_directory(fs::symlink_status(file, ec))) bad("is a folder");
    // Checked without following a link, as the final rename refuses one: a run must not do all
    // its work only to be refused its --junit file at the end (#50).
    if (std::string why = replaceable_target_problem(file); !why.empty())
        throw InputError(fmt::format("{} {}", option, why));
    // The file, and the folders missing on the way to it, are made in the nearest folder that
    // exists.
    if (std::string why = unwritable_problem(fs::absolute(file).parent_path()); !why.empty()) bad(why);
}

std::string output_folder_problem(const std::string& dir) {
    if (dir.empty()) return "the output folder is an empty path";
    std::error_code ec;
    const fs::path path(dir);
    const fs::file_status st = fs::status(path, ec);
    if (fs::exists(st) && !fs::is_directory(st)) return fmt::format("{}: exists and is not a folder", dir);
    if (std::string why = unwritable_problem(fs::absolute(path, ec)); !why.empty())
        return fmt::format("{}: {}", dir, why);
    return {};
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
    InterruptsDeferred deferred;
    std::error_code ec;
    // Every target is checked before the first move: a failure must not leave half the set
    // replaced.
    // Only a regular file (or nothing) is replaced: a symbolic link, folder, device or FIFO of
    // that name is the user's, and is refused before anything moves.
    for (const Staged& f : files_) {
        if (std::string why = replaceable_target_problem(f.final_path); !why.empty()) throw InputError(why);
        if (!is_same_file(f.tmp, f.device, f.inode))
            throw EnvironmentError(fmt::format("{}: was not written", f.final_path.string()));
    }
    struct Moved {
        const Staged* file;
        bool exchanged;  // the earlier run's file now sits at the temporary name
    };
    std::vector<Moved> moved;
    auto undo = [&] {
        std::error_code ignored;
        for (auto m = moved.rbegin(); m != moved.rend(); ++m) {
            if (m->exchanged)
                exchange(m->file->tmp, m->file->final_path, ignored);
            else
                fs::rename(m->file->final_path, m->file->tmp, ignored);
        }
    };
    for (const Staged& f : files_) {
        ec.clear();
        bool exchanged = false;
        if (std::string why = replaceable_target_problem(f.final_path); !why.empty()) {  // changed since
            undo();
            throw InputError(why);
        }
        if (fs::exists(fs::symlink_status(f.final_path, ec))) {
            exchanged = exchange(f.tmp, f.final_path, ec);
            if (!exchanged && exchange_unsupported(ec)) {
                ec.clear();
                fs::rename(f.tmp, f.final_path, ec);  // still atomic, only slower on ext4
            }
        } else {
            fs::rename(f.tmp, f.final_path, ec);
        }
        if (ec) {
            undo();
            throw EnvironmentError(fmt::format("{}: cannot move into place: {}", f.final_path.string(), ec.message()));
        }
        moved.push_back({&f, exchanged});
    }
    for (const Moved& m : moved)
        if (m.exchanged) fs::remove(m.file->tmp, ec);  // the earlier run's file
    for (Staged& f : files_) untrack_for_interrupt(std::exchange(f.tracked, -1));
    untrack_for_interrupt(std::exchange(tracked_dir_, -1));
    committed_ = true;
}

}  // namespace penumbra
