// Strict reading of user JSON: every value is checked for type and range, every key must be
// known, and every error names the file and the JSON path of the offending value.
#pragma once

#include <filesystem>
#include <glm/vec3.hpp>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>

namespace penumbra {

// Parses strict JSON: syntax errors, duplicate keys and non-finite numbers are InputErrors
// naming `file_label`.
nlohmann::json parse_json_strict(const std::string& text, const std::string& file_label);
nlohmann::json read_json_file(const std::filesystem::path& file);

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

    void finish() const;  // unknown keys are errors

  private:
    const nlohmann::json& value_;
    std::string file_;
    std::string path_;
    std::set<std::string> read_;
};

}  // namespace penumbra
