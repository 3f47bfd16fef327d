// Writing results without ever leaving partial output: every file goes to a temporary name in
// the output folder and is moved into place only when all of them were written, all or none
// (docs/outputs.md). Temporaries and a folder the run made are removed when it is interrupted.
#pragma once

#include <cstdint>
#include <filesystem>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra {

class OutputTransaction {
  public:
    explicit OutputTransaction(std::filesystem::path dir);
    ~OutputTransaction();  // removes temporaries (and the folder if it made it) unless committed
    OutputTransaction(const OutputTransaction&) = delete;
    OutputTransaction& operator=(const OutputTransaction&) = delete;

    // A temporary path in the folder for `name`, renamed to `name` on commit: for writers
    // elsewhere (image_io/image_io.h writes EXR and PNG files through it). Thread-safe, so that
    // files can be written side by side.
    std::filesystem::path stage(const std::string& name);
    void write_json(const std::string& name, const nlohmann::json& value);
    void write_text(const std::string& name, const std::string& text);
    // The bytes of a file this transaction wrote (before or after commit), e.g. to embed an
    // image into a report.
    std::string written_bytes(const std::string& name) const;

    // Moves every temporary into place, all or none: every target is checked first (a folder in
    // the way is an InputError, before anything moves), an earlier run's file is swapped with
    // the new one atomically (the name never goes missing), and a failure part-way swaps back
    // what had moved. Interrupts wait until the set is in place.
    void commit();
    const std::filesystem::path& dir() const { return dir_; }
    // The temporary stage() gave, opened for writing (truncated) only while it is still the file
    // stage() created (not a symbolic link or another file put there since): a file descriptor,
    // or -1 with errno set. The caller closes it.
    int open_staged(const std::filesystem::path& tmp);

  private:
    std::filesystem::path dir_;
    bool created_dir_ = false;
    bool committed_ = false;
    struct Staged {
        std::filesystem::path tmp, final_path;
        int tracked = -1;                     // its slot in the interrupt cleanup's registry
        std::uint64_t device = 0, inode = 0;  // the file stage() created there
    };
    std::vector<Staged> files_;
    int tracked_dir_ = -1;
    std::mutex stage_mutex_;  // guards files_ and the folder's creation in stage()
};

// A temporary made for `name` in `dir`: `.NAME.tmp-PID-<16 random hex digits>`, created with
// O_CREAT|O_EXCL|O_NOFOLLOW, so that nothing already at that name (a symbolic link someone
// planted) is opened or followed. Every file penumbra writes starts as one (docs/outputs.md).
// Throws EnvironmentError when none can be made. The caller closes `fd`.
struct ExclusiveTemporary {
    std::filesystem::path path;
    int fd = -1;
    std::uint64_t device = 0, inode = 0;
};
ExclusiveTemporary create_exclusive_temporary(const std::filesystem::path& dir, const std::string& name);
// Whether `path` is (without following a symbolic link) the regular file device:inode.
bool is_same_file(const std::filesystem::path& path, std::uint64_t device, std::uint64_t inode);
// Removes `path` only while it is that file: what a process removes is what it created.
void remove_if_same_file(const std::filesystem::path& path, std::uint64_t device, std::uint64_t inode);
// `path` opened O_WRONLY|O_TRUNC|O_NOFOLLOW when it is still the file device:inode, else -1.
int open_staged_for_writing(const std::filesystem::path& path, std::uint64_t device, std::uint64_t inode);
// Why a result may not be moved onto `target` ("" when it may): penumbra renames only over a
// regular file or nothing, never over a symbolic link, folder, device, FIFO or socket.
std::string replaceable_target_problem(const std::filesystem::path& target);

// Checks, before any work starts, that a result file such as --junit can be written once the
// --out folder was: it is neither that folder nor a folder, and the folder it goes into exists
// and is writable (or can be created). Throws InputError naming `option`.
void check_output_file(const std::filesystem::path& file, const std::filesystem::path& out_dir,
                       const std::string& option);

// Why `dir` cannot be an output folder ("" when it can): empty, not a folder, or no file can be
// made in it (or, when it does not exist yet, in the nearest folder above it). For --out, checked
// as the command line is parsed, before any work.
std::string output_folder_problem(const std::string& dir);

// Removes, on SIGINT, SIGTERM or SIGHUP, every temporary file an OutputTransaction or the
// oracle cache has staged and not yet moved into place, and every output folder a run made that
// is then empty; the signal then ends the process as it would have. main() calls it once. A
// signal ignored when it is called stays ignored.
void install_interrupt_cleanup();

// A path the interrupt cleanup removes until untrack(): a file (unlink) or a folder (rmdir,
// only when empty). Returns a slot for untrack(), or -1 when not tracked (registry full).
int track_for_interrupt(const std::filesystem::path& path, bool folder);
void untrack_for_interrupt(int slot);

// Standard base64 (RFC 4648), for data: URIs.
std::string base64_encode(std::string_view bytes);

// A 128-bit content fingerprint (XXH3-128: its output is stable across platforms and xxHash
// releases since 0.8) as 32 hex digits, for cache keys.
std::string content_fingerprint(std::string_view bytes);

}  // namespace penumbra
