#include "common/json_reader.h"

#include <fmt/format.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <vector>

#include "common/errors.h"

namespace penumbra {

using nlohmann::json;

namespace {

const char* type_name(const json& v) {
    return v.type_name();
}

}  // namespace

json parse_json_strict(const std::string& text, const std::string& file_label) {
    // Duplicate keys are silently merged by nlohmann; a strict reader refuses them, since
    // which of two "bias" objects the user meant cannot be guessed.
    std::vector<std::set<std::string>> open_objects;
    std::string duplicate;
    auto callback = [&](int, json::parse_event_t event, json& parsed) {
        switch (event) {
            case json::parse_event_t::object_start: open_objects.emplace_back(); break;
            case json::parse_event_t::object_end: open_objects.pop_back(); break;
            case json::parse_event_t::key:
                if (!open_objects.empty() && !open_objects.back().insert(parsed.get<std::string>()).second &&
                    duplicate.empty())
                    duplicate = parsed.get<std::string>();
                break;
            case json::parse_event_t::value:
                if (parsed.is_number_float() && !std::isfinite(parsed.get<double>()))
                    throw InputError(fmt::format("{}: number out of range (not finite)", file_label));
                break;
            default: break;
        }
        return true;
    };
    json result;
    try {
        result = json::parse(text, callback, /*allow_exceptions=*/true, /*ignore_comments=*/false);
    } catch (const json::parse_error& e) {
        throw InputError(fmt::format("{}: invalid JSON at byte {}: {}", file_label, e.byte, e.what()));
    } catch (const json::exception& e) {  // e.g. out_of_range for 1e999
        throw InputError(fmt::format("{}: invalid JSON: {}", file_label, e.what()));
    }
    if (!duplicate.empty()) throw InputError(fmt::format("{}: duplicate key \"{}\"", file_label, duplicate));
    return result;
}

json read_json_file(const std::filesystem::path& file) {
    std::ifstream in(file, std::ios::binary);
    if (!in) throw InputError(fmt::format("{}: cannot open file", file.string()));
    std::ostringstream text;
    text << in.rdbuf();
    return parse_json_strict(text.str(), file.filename().string());
}

JsonObject::JsonObject(const json& value, std::string file_label, std::string path)
    : value_(value), file_(std::move(file_label)), path_(std::move(path)) {
    if (!value_.is_object()) fail_here(fmt::format("expected an object, got {}", type_name(value_)));
}

std::string JsonObject::path_of(const std::string& key) const {
    return path_.empty() ? key : path_ + "." + key;
}

void JsonObject::fail(const std::string& key, const std::string& what) const {
    throw InputError(fmt::format("{}: {}: {}", file_, path_of(key), what));
}

void JsonObject::fail_here(const std::string& what) const {
    throw InputError(fmt::format("{}: {}: {}", file_, path_.empty() ? "(top level)" : path_, what));
}

bool JsonObject::has(const std::string& key) const {
    return value_.contains(key);
}

const json& JsonObject::get(const std::string& key) {
    read_.insert(key);
    auto it = value_.find(key);
    if (it == value_.end()) fail(key, "missing required key");
    return *it;
}

double JsonObject::number(const std::string& key) {
    const json& v = get(key);
    if (!v.is_number()) fail(key, fmt::format("expected a number, got {}", type_name(v)));
    double d = v.get<double>();
    if (!std::isfinite(d)) fail(key, "expected a finite number");
    return d;
}

double JsonObject::number(const std::string& key, double fallback) {
    read_.insert(key);
    return has(key) ? number(key) : fallback;
}

double JsonObject::number_in(const std::string& key, double lo, double hi, const std::string& what) {
    double d = number(key);
    if (!(d >= lo && d <= hi)) fail(key, fmt::format("{} (got {})", what, d));
    return d;
}

double JsonObject::number_in(const std::string& key, double fallback, double lo, double hi, const std::string& what) {
    read_.insert(key);
    return has(key) ? number_in(key, lo, hi, what) : fallback;
}

long long JsonObject::integer(const std::string& key, long long lo, long long hi) {
    const json& v = get(key);
    if (!v.is_number_integer()) fail(key, fmt::format("expected an integer, got {}", type_name(v)));
    // Unsigned values beyond int64 come back as number_unsigned; compare in that domain.
    if (v.is_number_unsigned() && v.get<unsigned long long>() > static_cast<unsigned long long>(hi))
        fail(key, fmt::format("expected an integer in [{}, {}] (got {})", lo, hi, v.dump()));
    long long i = v.get<long long>();
    if (i < lo || i > hi) fail(key, fmt::format("expected an integer in [{}, {}] (got {})", lo, hi, i));
    return i;
}

long long JsonObject::integer(const std::string& key, long long fallback, long long lo, long long hi) {
    read_.insert(key);
    return has(key) ? integer(key, lo, hi) : fallback;
}

bool JsonObject::boolean(const std::string& key, bool fallback) {
    read_.insert(key);
    if (!has(key)) return fallback;
    const json& v = get(key);
    if (!v.is_boolean()) fail(key, fmt::format("expected true or false, got {}", type_name(v)));
    return v.get<bool>();
}

std::string JsonObject::string(const std::string& key) {
    const json& v = get(key);
    if (!v.is_string()) fail(key, fmt::format("expected a string, got {}", type_name(v)));
    return v.get<std::string>();
}

std::string JsonObject::string(const std::string& key, const std::string& fallback) {
    read_.insert(key);
    return has(key) ? string(key) : fallback;
}

glm::dvec3 JsonObject::vec3(const std::string& key) {
    const json& v = get(key);
    if (!v.is_array() || v.size() != 3) fail(key, "expected an array of 3 numbers");
    glm::dvec3 out;
    for (int i = 0; i < 3; ++i) {
        if (!v[i].is_number()) fail(key, fmt::format("element {} is not a number", i));
        out[i] = v[i].get<double>();
        if (!std::isfinite(out[i])) fail(key, fmt::format("element {} is not finite", i));
    }
    return out;
}

glm::dvec3 JsonObject::nonzero_vec3(const std::string& key) {
    glm::dvec3 v = vec3(key);
    // A direction must survive normalisation in double without underflow.
    double len2 = v.x * v.x + v.y * v.y + v.z * v.z;
    if (!(len2 > 1e-280) || !std::isfinite(len2)) fail(key, "zero vector");
    return v;
}

JsonObject JsonObject::object(const std::string& key) {
    const json& v = get(key);
    return JsonObject(v, file_, path_of(key));
}

void JsonObject::finish() const {
    for (auto it = value_.begin(); it != value_.end(); ++it)
        if (!read_.count(it.key())) fail(it.key(), "unknown key");
}

}  // namespace penumbra
