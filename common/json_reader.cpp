#include "common/json_reader.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "common/errors.h"

namespace penumbra {

using nlohmann::json;

namespace {

const char* type_name(const json& v) {
    return v.type_name();
}

// Length of the UTF-8 sequence starting at text[i], 0 when it is not a valid one (RFC 3629:
// no overlong forms, no surrogates, nothing beyond U+10FFFF).
std::size_t utf8_sequence(std::string_view text, std::size_t i) {
    auto byte = [&](std::size_t k) { return static_cast<unsigned char>(text[k]); };
    const unsigned char c = byte(i);
    if (c < 0x80) return 1;
    std::size_t n = c >= 0xC2 && c <= 0xDF ? 2 : c >= 0xE0 && c <= 0xEF ? 3 : c >= 0xF0 && c <= 0xF4 ? 4 : 0;
    if (n == 0 || i + n > text.size()) return 0;
    for (std::size_t k = 1; k < n; ++k)
        if ((byte(i + k) & 0xC0) != 0x80) return 0;
    const unsigned char c1 = byte(i + 1);
    if ((c == 0xE0 && c1 < 0xA0) || (c == 0xED && c1 > 0x9F) || (c == 0xF0 && c1 < 0x90) || (c == 0xF4 && c1 > 0x8F))
        return 0;
    return n;
}

}  // namespace

bool is_valid_utf8(std::string_view text) {
    for (std::size_t i = 0; i < text.size();) {
        std::size_t n = utf8_sequence(text, i);
        if (n == 0) return false;
        i += n;
    }
    return true;
}

std::string escape_non_utf8(std::string_view text) {
    std::string out;
    out.reserve(text.size());
    for (std::size_t i = 0; i < text.size();) {
        std::size_t n = utf8_sequence(text, i);
        if (n == 0) {
            out += fmt::format("\\x{:02X}", static_cast<unsigned char>(text[i]));
            ++i;
        } else {
            out.append(text.substr(i, n));
            i += n;
        }
    }
    return out;
}

std::string path_text(const std::filesystem::path& path) {
    return escape_non_utf8(path.native());
}

std::string finite_number_problem(const std::string& text) {
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    return end != text.c_str() && !std::isfinite(v) ? fmt::format("{} is not a finite number", text) : std::string();
}

std::string utf8_problem(const std::string& text) {
    return is_valid_utf8(text)
               ? std::string()
               : fmt::format("\"{}\" is not valid UTF-8 (names and keys must be)", escape_non_utf8(text));
}

std::string set_assignment_problem(const std::string& text) {
    if (std::string problem = utf8_problem(text); !problem.empty()) return problem;
    const std::string key = text.substr(0, text.find('='));
    const auto segments = static_cast<std::size_t>(std::count(key.begin(), key.end(), '.')) + 1;
    if (segments > static_cast<std::size_t>(kMaxJsonDepth))
        return fmt::format("the key path has {} segments, more than the {} levels a technique may nest", segments,
                           kMaxJsonDepth);
    return {};
}

std::string json_excerpt(const json& value, std::size_t max_chars) {
    // Values from parsed files are valid UTF-8 and nested at most kMaxJsonDepth levels, but
    // values built from options or paths may not be: replace, never throw.
    std::string text = value.dump(-1, ' ', false, json::error_handler_t::replace);
    if (text.size() > max_chars) text = text.substr(0, max_chars) + "...";
    return text;
}

void check_json_nesting(std::string_view text, const std::string& file_label) {
    // One frame per open array or object: its last key (objects) or element index (arrays).
    struct Frame {
        bool object;
        std::string key;
        std::size_t index = 0;
    };
    std::vector<Frame> open;
    std::string last_string;
    for (std::size_t i = 0; i < text.size(); ++i) {
        const char c = text[i];
        if (c == '"') {  // skip the string, remembering it in case it is a key
            std::size_t start = ++i;
            while (i < text.size() && text[i] != '"') i += text[i] == '\\' ? 2 : 1;
            last_string.assign(text.substr(start, std::min(i, text.size()) - start));
        } else if (c == ':') {
            if (!open.empty() && open.back().object) open.back().key = last_string;
        } else if (c == ',') {
            if (!open.empty() && !open.back().object) ++open.back().index;
        } else if (c == '[' || c == '{') {
            if (open.size() == static_cast<std::size_t>(kMaxJsonDepth)) {
                std::string path;
                for (const Frame& f : open) {
                    if (path.size() > 80) {
                        path += "...";
                        break;
                    }
                    path += f.object ? (path.empty() ? "" : ".") + escape_non_utf8(f.key.substr(0, 40))
                                     : fmt::format("[{}]", f.index);
                }
                throw InputError(fmt::format("{}: {}: nested deeper than {} levels of arrays and objects (at byte {})",
                                             file_label, path.empty() ? "(top level)" : path, kMaxJsonDepth, i));
            }
            open.push_back({c == '{', {}, 0});
        } else if (c == ']' || c == '}') {
            if (!open.empty()) open.pop_back();  // mismatches are the parser's to report
        }
    }
}

RegularFile::RegularFile(const std::filesystem::path& file, std::uint64_t max_bytes, const char* kind) {
    // O_NONBLOCK: opening a FIFO must not wait for a writer; fstat then refuses it.
    fd_ = ::open(file.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd_ < 0) throw InputError(fmt::format("{}: cannot open file: {}", file.string(), std::strerror(errno)));
    struct stat st {};
    if (::fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode)) {
        ::close(fd_);
        throw InputError(fmt::format("{}: not a regular file (devices, FIFOs and folders are refused)", file.string()));
    }
    if (static_cast<std::uint64_t>(st.st_size) > max_bytes) {
        ::close(fd_);
        throw InputError(fmt::format("{}: {} bytes exceeds the {} byte limit{}{}", file.string(), st.st_size, max_bytes,
                                     kind ? " of " : "", kind ? fmt::format("{} file", kind) : ""));
    }
    size_ = static_cast<std::size_t>(st.st_size);
}

RegularFile::~RegularFile() {
    ::close(fd_);
}

std::string read_regular_file(const std::filesystem::path& file, std::uint64_t max_bytes, const char* kind) {
    const RegularFile f(file, max_bytes, kind);
    const int fd = f.fd();
    std::string bytes(f.size(), '\0');
    std::size_t done = 0;
    while (done < bytes.size()) {
        ssize_t n = ::read(fd, bytes.data() + done, bytes.size() - done);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) throw InputError(fmt::format("{}: cannot read: {}", file.string(), std::strerror(errno)));
        if (n == 0) break;  // the file shrank while read: parse what is there
        done += static_cast<std::size_t>(n);
    }
    bytes.resize(done);
    return bytes;
}

namespace {

// Builds the document from nlohmann's SAX events, refusing duplicate keys on the way. Its own
// callback parser (json::parse with a callback) scans the enclosing array or object again at
// the end of every object, which made an array of N objects cost N^2 (#50); here every event
// is constant work (a key's check is one lookup in its object).
class StrictDomBuilder : public json::json_sax_t {
  public:
    bool null() override { return add(nullptr); }
    bool boolean(bool v) override { return add(v); }
    bool number_integer(number_integer_t v) override { return add(v); }
    bool number_unsigned(number_unsigned_t v) override { return add(v); }
    bool number_float(number_float_t v, const string_t&) override {
        if (!std::isfinite(v)) non_finite_ = true;
        return add(v);
    }
    bool string(string_t& v) override { return add(std::move(v)); }
    bool binary(binary_t& v) override { return add(std::move(v)); }
    bool start_object(std::size_t) override {
        open_.push_back(add(json::object()));
        return true;
    }
    bool key(string_t& k) override {
        auto [it, fresh] = open_.back()->get_ref<json::object_t&>().emplace(std::move(k), nullptr);
        if (!fresh && duplicate_.empty()) duplicate_ = it->first;
        member_ = &it->second;
        return true;
    }
    bool end_object() override {
        open_.pop_back();
        return true;
    }
    bool start_array(std::size_t) override {
        open_.push_back(add(json::array()));
        return true;
    }
    bool end_array() override {
        open_.pop_back();
        return true;
    }
    bool parse_error(std::size_t position, const std::string&, const json::exception& e) override {
        error_position_ = position;
        error_ = e.what();
        syntax_error_ = e.id >= 100 && e.id < 200;  // json::parse_error's ids
        return false;
    }

    json result;
    std::string duplicate_, error_;
    std::size_t error_position_ = 0;
    bool syntax_error_ = false, non_finite_ = false;

  private:
    template <class V>
    json* add(V&& v) {
        if (open_.empty()) {
            result = json(std::forward<V>(v));
            return &result;
        }
        json& parent = *open_.back();
        if (parent.is_array()) {
            parent.get_ref<json::array_t&>().emplace_back(std::forward<V>(v));
            return &parent.get_ref<json::array_t&>().back();
        }
        *member_ = json(std::forward<V>(v));
        return member_;
    }
    std::vector<json*> open_;  // the arrays and objects being filled, innermost last
    json* member_ = nullptr;   // the value the last key named
};

}  // namespace

json parse_json_strict(const std::string& text, const std::string& file_label) {
    // nlohmann stops at a NUL byte as if the text ended there; JSON text never contains one.
    if (auto nul = text.find('\0'); nul != std::string::npos)
        throw InputError(fmt::format("{}: invalid JSON at byte {}: a NUL byte", file_label, nul + 1));
    check_json_nesting(text, file_label);
    // Duplicate keys are silently merged by nlohmann; a strict reader refuses them, since
    // which of two "bias" objects the user meant cannot be guessed.
    StrictDomBuilder builder;
    if (!json::sax_parse(text, &builder, json::input_format_t::json, /*strict=*/true, /*ignore_comments=*/false)) {
        if (builder.syntax_error_)
            throw InputError(
                fmt::format("{}: invalid JSON at byte {}: {}", file_label, builder.error_position_, builder.error_));
        throw InputError(fmt::format("{}: invalid JSON: {}", file_label, builder.error_));  // e.g. 1e999
    }
    if (builder.non_finite_) throw InputError(fmt::format("{}: number out of range (not finite)", file_label));
    if (!builder.duplicate_.empty())
        throw InputError(fmt::format("{}: duplicate key \"{}\"", file_label, builder.duplicate_));
    return std::move(builder.result);
}

json read_json_file(const std::filesystem::path& file, const JsonKind& kind) {
    return parse_json_strict(read_regular_file(file, kind.max_bytes, kind.name), file.filename().string());
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
        fail(key, fmt::format("expected an integer in [{}, {}] (got {})", lo, hi, json_excerpt(v)));
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
    // A path would end at the NUL ("scene.glb\u0000.txt" opens scene.glb); no name needs one.
    if (v.get_ref<const std::string&>().find('\0') != std::string::npos) fail(key, "contains a NUL character");
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
    // A direction must survive normalisation in double without underflow or overflow.
    double len2 = v.x * v.x + v.y * v.y + v.z * v.z;
    if (!std::isfinite(len2))
        fail(key, fmt::format("length overflows a double ([{:g}, {:g}, {:g}]); scale the vector down", v.x, v.y, v.z));
    if (!(len2 > 1e-280)) fail(key, "zero vector");
    return v;
}

JsonObject JsonObject::object(const std::string& key) {
    const json& v = get(key);
    return JsonObject(v, file_, path_of(key));
}

// Levenshtein distance, for "did you mean": keys are short, so the plain O(nm) table is fine.
std::size_t edit_distance(std::string_view a, std::string_view b) {
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
        std::size_t diagonal = row[0];
        row[0] = i;
        for (std::size_t j = 1; j <= b.size(); ++j) {
            const std::size_t up = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] != b[j - 1] ? 1 : 0)});
            diagonal = up;
        }
    }
    return row[b.size()];
}

void JsonObject::only_keys(std::initializer_list<std::string_view> known) const {
    for (auto it = value_.begin(); it != value_.end(); ++it) {
        const std::string& key = it.key();
        if (std::find(known.begin(), known.end(), key) != known.end()) continue;
        // A known key it resembles: one containing it ("fov" in "yfov_deg") or two edits away.
        std::string_view like;
        for (std::string_view k : known)
            if (!value_.contains(std::string(k)) && key.size() >= 3 &&
                (k.find(key) != std::string_view::npos || edit_distance(key, k) <= 2)) {
                like = k;
                break;
            }
        fail(key, like.empty() ? "unknown key" : fmt::format("unknown key (did you mean \"{}\"?)", like));
    }
}

std::vector<std::string> JsonObject::unread_keys() const {
    std::vector<std::string> keys;
    for (auto it = value_.begin(); it != value_.end(); ++it)
        if (!read_.count(it.key())) keys.push_back(it.key());
    return keys;
}

void JsonObject::finish() const {
    for (auto it = value_.begin(); it != value_.end(); ++it)
        if (!read_.count(it.key())) fail(it.key(), "unknown key");
}

}  // namespace penumbra
