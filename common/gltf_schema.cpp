#include "common/gltf_schema.h"

#include <fmt/format.h>

#include <vector>

#include "common/errors.h"
#include "common/json_reader.h"

namespace penumbra {

namespace {

using nlohmann::json;

enum class Kind {
    uint,
    number,
    string,
    boolean,
    object,
    uint_array,
    number_array,
    string_array,
    object_array,
    uint_map
};

struct Schema;
struct Field {
    const char* name;
    Kind kind;
    const Schema* child = nullptr;  // for object and object_array
    bool required = false;
};
struct Schema {
    std::vector<Field> fields;
};

const Schema kAny{};
const Schema kTextureInfo{{{"index", Kind::uint, nullptr, true},
                           {"texCoord", Kind::uint},
                           {"scale", Kind::number},
                           {"strength", Kind::number}}};
const Schema kPbr{{{"baseColorFactor", Kind::number_array},
                   {"baseColorTexture", Kind::object, &kTextureInfo},
                   {"metallicFactor", Kind::number},
                   {"roughnessFactor", Kind::number},
                   {"metallicRoughnessTexture", Kind::object, &kTextureInfo}}};
const Schema kMaterial{{{"pbrMetallicRoughness", Kind::object, &kPbr},
                        {"normalTexture", Kind::object, &kTextureInfo},
                        {"occlusionTexture", Kind::object, &kTextureInfo},
                        {"emissiveTexture", Kind::object, &kTextureInfo},
                        {"emissiveFactor", Kind::number_array},
                        {"alphaMode", Kind::string},
                        {"alphaCutoff", Kind::number},
                        {"doubleSided", Kind::boolean}}};
const Schema kPrimitive{{{"attributes", Kind::uint_map, nullptr, true},
                         {"indices", Kind::uint},
                         {"material", Kind::uint},
                         {"mode", Kind::uint},
                         {"targets", Kind::object_array, &kAny}}};
const Schema kMesh{{{"primitives", Kind::object_array, &kPrimitive, true}, {"weights", Kind::number_array}}};
const Schema kNode{{{"camera", Kind::uint},
                    {"children", Kind::uint_array},
                    {"skin", Kind::uint},
                    {"matrix", Kind::number_array},
                    {"mesh", Kind::uint},
                    {"rotation", Kind::number_array},
                    {"scale", Kind::number_array},
                    {"translation", Kind::number_array},
                    {"weights", Kind::number_array}}};
const Schema kScene{{{"nodes", Kind::uint_array}}};
const Schema kAccessor{{{"bufferView", Kind::uint},
                        {"byteOffset", Kind::uint},
                        {"componentType", Kind::uint, nullptr, true},
                        {"normalized", Kind::boolean},
                        {"count", Kind::uint, nullptr, true},
                        {"type", Kind::string, nullptr, true},
                        {"max", Kind::number_array},
                        {"min", Kind::number_array},
                        {"sparse", Kind::object, &kAny}}};
const Schema kBufferView{{{"buffer", Kind::uint, nullptr, true},
                          {"byteOffset", Kind::uint},
                          {"byteLength", Kind::uint, nullptr, true},
                          {"byteStride", Kind::uint},
                          {"target", Kind::uint}}};
const Schema kBuffer{{{"uri", Kind::string}, {"byteLength", Kind::uint, nullptr, true}}};
const Schema kPerspective{{{"aspectRatio", Kind::number},
                           {"yfov", Kind::number, nullptr, true},
                           {"zfar", Kind::number},
                           {"znear", Kind::number, nullptr, true}}};
const Schema kOrthographic{{{"xmag", Kind::number, nullptr, true},
                            {"ymag", Kind::number, nullptr, true},
                            {"zfar", Kind::number, nullptr, true},
                            {"znear", Kind::number, nullptr, true}}};
const Schema kCamera{{{"type", Kind::string, nullptr, true},
                      {"perspective", Kind::object, &kPerspective},
                      {"orthographic", Kind::object, &kOrthographic}}};
const Schema kImage{{{"uri", Kind::string}, {"mimeType", Kind::string}, {"bufferView", Kind::uint}}};
const Schema kTexture{{{"sampler", Kind::uint}, {"source", Kind::uint}}};
const Schema kSampler{
    {{"magFilter", Kind::uint}, {"minFilter", Kind::uint}, {"wrapS", Kind::uint}, {"wrapT", Kind::uint}}};
const Schema kAsset{{{"version", Kind::string, nullptr, true},
                     {"minVersion", Kind::string},
                     {"generator", Kind::string},
                     {"copyright", Kind::string}}};
const Schema kRoot{{{"asset", Kind::object, &kAsset, true},
                    {"scene", Kind::uint},
                    {"scenes", Kind::object_array, &kScene},
                    {"nodes", Kind::object_array, &kNode},
                    {"meshes", Kind::object_array, &kMesh},
                    {"materials", Kind::object_array, &kMaterial},
                    {"accessors", Kind::object_array, &kAccessor},
                    {"bufferViews", Kind::object_array, &kBufferView},
                    {"buffers", Kind::object_array, &kBuffer},
                    {"cameras", Kind::object_array, &kCamera},
                    {"images", Kind::object_array, &kImage},
                    {"textures", Kind::object_array, &kTexture},
                    {"samplers", Kind::object_array, &kSampler},
                    {"animations", Kind::object_array, &kAny},
                    {"skins", Kind::object_array, &kAny},
                    {"extensionsUsed", Kind::string_array},
                    {"extensionsRequired", Kind::string_array}}};

bool is_uint(const json& v) {
    return v.is_number_unsigned() || (v.is_number_integer() && v.get<long long>() >= 0);
}

const char* expectation(Kind k) {
    switch (k) {
        case Kind::uint: return "a non-negative integer";
        case Kind::number: return "a number";
        case Kind::string: return "a string";
        case Kind::boolean: return "true or false";
        case Kind::object: return "an object";
        case Kind::uint_array: return "an array of non-negative integers";
        case Kind::number_array: return "an array of numbers";
        case Kind::string_array: return "an array of strings";
        case Kind::object_array: return "an array of objects";
        case Kind::uint_map: return "an object of non-negative integers";
    }
    return "?";
}

struct Checker {
    const std::string& label;

    [[noreturn]] void fail(const std::string& path, const std::string& what) const {
        throw InputError(fmt::format("{}: {}: {}", label, path, what));
    }

    void value(const json& v, const Field& f, const std::string& path) const {
        auto all = [&](auto pred) {
            if (!v.is_array()) return false;
            for (const auto& e : v)
                if (!pred(e)) return false;
            return true;
        };
        bool ok = false;
        switch (f.kind) {
            case Kind::uint: ok = is_uint(v); break;
            case Kind::number: ok = v.is_number(); break;
            case Kind::string: ok = v.is_string(); break;
            case Kind::boolean: ok = v.is_boolean(); break;
            case Kind::object: ok = v.is_object(); break;
            case Kind::uint_array: ok = all(is_uint); break;
            case Kind::number_array: ok = all([](const json& e) { return e.is_number(); }); break;
            case Kind::string_array: ok = all([](const json& e) { return e.is_string(); }); break;
            case Kind::object_array: ok = all([](const json& e) { return e.is_object(); }); break;
            case Kind::uint_map:
                ok = v.is_object();
                for (auto it = v.begin(); ok && it != v.end(); ++it) ok = is_uint(*it);
                break;
        }
        if (!ok) fail(path, fmt::format("expected {}, got {}", expectation(f.kind), json_excerpt(v)));
        if (f.kind == Kind::object) object(v, *f.child, path);
        if (f.kind == Kind::object_array)
            for (std::size_t i = 0; i < v.size(); ++i) object(v[i], *f.child, fmt::format("{}[{}]", path, i));
    }

    void object(const json& o, const Schema& s, const std::string& path) const {
        if (o.contains("name") && !o["name"].is_string())
            fail(path + ".name", fmt::format("expected a string, got {}", json_excerpt(o["name"])));
        if (o.contains("extensions")) {
            const json& ext = o["extensions"];
            if (!ext.is_object()) fail(path + ".extensions", "expected an object");
            for (auto it = ext.begin(); it != ext.end(); ++it)
                if (!it->is_object())
                    fail(fmt::format("{}.extensions.{}", path, it.key()),
                         fmt::format("expected an object, got {}", json_excerpt(*it)));
        }
        for (const Field& f : s.fields) {
            std::string p = path.empty() ? f.name : path + "." + f.name;
            auto it = o.find(f.name);
            if (it == o.end()) {
                if (f.required) fail(p, "missing required property");
                continue;
            }
            value(*it, f, p);
        }
    }
};

// Required extensions whose absence changes geometry: refusing is the only honest answer.
bool harmless_extension(const std::string& name) {
    return name == "KHR_lights_punctual" || name.rfind("KHR_materials_", 0) == 0 ||
           name.rfind("KHR_texture_", 0) == 0 || name == "EXT_texture_webp";
}

}  // namespace

void check_gltf_schema(const json& doc, const std::string& label) {
    Checker c{label};
    if (!doc.is_object()) c.fail("(top level)", "expected a JSON object");
    c.object(doc, kRoot, "");
    if (doc.contains("extensionsRequired"))
        for (const auto& e : doc["extensionsRequired"])
            if (!harmless_extension(e.get<std::string>()))
                c.fail("extensionsRequired",
                       fmt::format("requires \"{}\", which penumbra does not support", e.get<std::string>()));
}

}  // namespace penumbra
