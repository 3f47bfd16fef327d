// Writing results without ever leaving partial output: every file goes to a temporary name in
// the output folder and is renamed into place only when all of them were written.
#pragma once

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

    void commit();  // renames every temporary into place
    const std::filesystem::path& dir() const { return dir_; }

  private:
    std::filesystem::path dir_;
    bool created_dir_ = false;
    bool committed_ = false;
    std::vector<std::pair<std::filesystem::path, std::filesystem::path>> files_;  // temp, final
    std::mutex stage_mutex_;  // guards files_ and the folder's creation in stage()
};

// Checks, before any work starts, that a result file such as --junit can be written once the
// --out folder was: it is neither that folder nor a folder, and the folder it goes into exists
// and is writable (or can be created). Throws InputError naming `option`.
void check_output_file(const std::filesystem::path& file, const std::filesystem::path& out_dir,
                       const std::string& option);

// Standard base64 (RFC 4648), for data: URIs.
std::string base64_encode(std::string_view bytes);

// A 128-bit content fingerprint (XXH3-128: its output is stable across platforms and xxHash
// releases since 0.8) as 32 hex digits, for cache keys.
std::string content_fingerprint(std::string_view bytes);

}  // namespace penumbra
