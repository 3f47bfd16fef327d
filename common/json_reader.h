// Strict reading of user JSON: every value is checked for type and range, every key must be
// known, and every error names the file and the JSON path of the offending value.
#pragma once

#include <cstdint>
#include <filesystem>
#include <glm/vec3.hpp>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra {

// Deepest nesting of arrays and objects any JSON the program reads may have (scenario,
// technique, gate, glTF). nlohmann's dump() and copies and tinygltf's parser recurse once per
// level, so a deeper file would overflow the stack; no real file comes near this.
inline constexpr int kMaxJsonDepth = 64;
// The largest JSON file of each kind read (#50; glTF files have their own limit). A document of
// small objects costs about 45 bytes of memory and 65 ns per byte of its text once parsed (2-core
// VM: 16 MiB in 1.1 s and 0.7 GB, 64 MiB in 13 s and 2.8 GB), so each kind is held to what its
// largest real file needs, with room to spare, and a larger one is refused before it is read.
struct JsonKind {
    const char* name;  // for messages: "a scenario"
    std::uint64_t max_bytes;
};
// A 10,000-frame camera path's keys take ~3 MB, 4096 lights ~1 MB.
inline constexpr JsonKind kScenarioJson{"a scenario", 16ull << 20};
// report.json holds ~270 bytes a light and frame over a camera path: 10,000 frames of 6 lights.
inline constexpr JsonKind kReportJson{"a report", 16ull << 20};
// A sweep's --configs list: 100,000 configurations, beyond what sweep runs in its 12 hours.
inline constexpr JsonKind kSweepConfigsJson{"a sweep configuration list", 16ull << 20};
// Technique and gate files are a few kilobytes; per-light entries for 4096 lights stay far below.
inline constexpr JsonKind kTechniqueJson{"a technique", 1ull << 20};
inline constexpr JsonKind kGateJson{"a gate", 1ull << 20};

// Refuses JSON text nested deeper than kMaxJsonDepth, naming the JSON path where it goes too
// deep. Runs on the raw text, before any parser recurses.
void check_json_nesting(std::string_view text, const std::string& file_label);

// Reads a whole regular file of at most `max_bytes`; devices, FIFOs and folders are refused
// (they may never end). Throws InputError naming `file` (and `kind`, when given, for a file too
// large).
std::string read_regular_file(const std::filesystem::path& file, std::uint64_t max_bytes, const char* kind = nullptr);

// `file` opened for reading when it is a regular file of at most `max_bytes`, else InputError
// naming it: FIFOs, devices and folders are refused without blocking on them. Closes on
// destruction. read_regular_file and the scene loader's parallel read share it.
class RegularFile {
  public:
    RegularFile(const std::filesystem::path& file, std::uint64_t max_bytes, const char* kind = nullptr);
    ~RegularFile();
    RegularFile(const RegularFile&) = delete;
    RegularFile& operator=(const RegularFile&) = delete;
    int fd() const { return fd_; }
    std::size_t size() const { return size_; }

  private:
    int fd_ = -1;
    std::size_t size_ = 0;
};

// Parses strict JSON: syntax errors, NUL bytes, nesting beyond kMaxJsonDepth, duplicate keys
// and non-finite numbers are InputErrors naming `file_label`.
nlohmann::json parse_json_strict(const std::string& text, const std::string& file_label);
nlohmann::json read_json_file(const std::filesystem::path& file, const JsonKind& kind);

// `text` with every byte that is not part of valid UTF-8 written as \xNN: safe in messages
// and in JSON, whatever a path or option held.
std::string escape_non_utf8(std::string_view text);
bool is_valid_utf8(std::string_view text);
// A path as text for reports, JSON and messages: a path is any bytes, JSON must be UTF-8, so the
// bytes that are not are written as \xNN. The one conversion every shown path goes through.
std::string path_text(const std::filesystem::path& path);
// Command-line option checks (CLI11 ->check): an empty string when `text` is fine, else what
// is wrong. CLI::Range lets NaN through, since every comparison with NaN is false.
std::string finite_number_problem(const std::string& text);
std::string utf8_problem(const std::string& text);
// --set KEY.PATH=VALUE: UTF-8, and a key path of at most kMaxJsonDepth segments (each segment
// nests the technique one level deeper).
std::string set_assignment_problem(const std::string& text);
// A short, always printable rendering of a JSON value for messages (never throws).
std::string json_excerpt(const nlohmann::json& value, std::size_t max_chars = 60);
// Levenshtein distance between two names, for "did you mean" hints.
std::size_t edit_distance(std::string_view a, std::string_view b);

// A view of one JSON object at a known path. Reading a key marks it as known; finish()
// rejects the keys that nothing read.
class JsonObject {
  public:
    JsonObject(const nlohmann::json& value, std::string file_label, std::string path);

    [[noreturn]] void fail(const std::string& key, const std::string& what) const;
    [[noreturn]] void fail_here(const std::string& what) const;

    bool has(const std::string& key) const;
    const nlohmann::json& get(const std::string& key);  // required, any type
    std::string path_of(const std::string& key) const;
    const std::string& file_label() const { return file_; }

    double number(const std::string& key);
    double number(const std::string& key, double fallback);
    // Finite number inside [lo, hi]; `what` phrases the expectation in the error.
    double number_in(const std::string& key, double lo, double hi, const std::string& what);
    double number_in(const std::string& key, double fallback, double lo, double hi, const std::string& what);
    long long integer(const std::string& key, long long lo, long long hi);
    long long integer(const std::string& key, long long fallback, long long lo, long long hi);
    bool boolean(const std::string& key, bool fallback);
    std::string string(const std::string& key);
    std::string string(const std::string& key, const std::string& fallback);
    glm::dvec3 vec3(const std::string& key);
    glm::dvec3 nonzero_vec3(const std::string& key);
    JsonObject object(const std::string& key);

    // Unknown keys are errors, named before any missing required key is (a misspelt "fov" is
    // reported as unknown, with the known key it resembles, not as a missing "yfov_deg"). Call
    // before reading when the object's keys are known up front; finish() still checks at the end.
    void only_keys(std::initializer_list<std::string_view> known) const;
    void finish() const;                           // unknown keys are errors
    std::vector<std::string> unread_keys() const;  // what finish() would refuse, in the object's order

  private:
    const nlohmann::json& value_;
    std::string file_;
    std::string path_;
    std::set<std::string> read_;
};

// The enumerator `key` names (by its to_string, found by argument-dependent lookup), `fallback`
// when the key is absent; any other string fails naming the key and every value it may take.
template <typename E>
E pick_enum(JsonObject& o, const std::string& key, E fallback, std::initializer_list<E> values) {
    if (!o.has(key)) return fallback;
    const std::string s = o.string(key);
    std::string expected;
    for (E v : values) {
        if (s == to_string(v)) return v;
        expected += (expected.empty() ? "\"" : ", \"") + std::string(to_string(v)) + "\"";
    }
    o.fail(key, "\"" + s + "\" is not one of " + expected);
}

}  // namespace penumbra
