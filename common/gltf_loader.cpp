#include "common/gltf_loader.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat4x4.hpp>
#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string_view>

#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#define TINYGLTF_NO_INCLUDE_JSON
#include <tiny_gltf.h>

#include "common/camera.h"
#include "common/errors.h"
#include "common/gltf_schema.h"
#include "common/json_reader.h"
#include "common/memory_estimate.h"

namespace penumbra {
namespace fs = std::filesystem;

namespace {

constexpr std::uint64_t kMaxFileBytes = 8ull << 30;  // 8 GiB: anything bigger is refused

struct Context {
    std::string label;  // file name used in messages
    fs::path dir;       // canonical folder of the scene file
    bool allow_external = false;
};

[[noreturn]] void fail(const Context& ctx, const std::string& element, const std::string& what) {
    throw InputError(fmt::format("{}: {}: {}", ctx.label, element, what));
}

// ---- the file's bytes -----------------------------------------------------------------------

// The scene file's bytes, as read_regular_file reads them (the same checks and messages), but
// without zero-filling the buffer first and in 8 MiB pieces side by side: a 453 MB .glb took
// 0.3 s to read on one thread, most of it the kernel faulting in and copying pages.
struct FileBytes {
    std::unique_ptr<char[]> data;
    std::size_t size = 0;
    std::string_view view() const { return {data.get(), size}; }
};

FileBytes read_scene_file(const fs::path& file, std::uint64_t max_bytes) {
    const RegularFile f(file, max_bytes);
    const int fd = f.fd();
    FileBytes out;
    const std::size_t size = f.size();
    out.data = std::make_unique_for_overwrite<char[]>(std::max<std::size_t>(size, 1));
    constexpr std::size_t kPiece = std::size_t(8) << 20;
    const std::size_t pieces = (size + kPiece - 1) / kPiece;
    // Each piece: the bytes read (short where the file ended sooner: it shrank while read), or
    // the errno of a failed read.
    std::vector<std::size_t> got(pieces, 0);
    std::vector<int> error(pieces, 0);
    tbb::parallel_for(std::size_t(0), pieces, [&](std::size_t k) {
        const std::size_t begin = k * kPiece, length = std::min(kPiece, size - begin);
        while (got[k] < length) {
            const ssize_t n =
                ::pread(fd, out.data.get() + begin + got[k], length - got[k], static_cast<off_t>(begin + got[k]));
            if (n < 0 && errno == EINTR) continue;
            if (n < 0) error[k] = errno;
            if (n <= 0) break;
            got[k] += static_cast<std::size_t>(n);
        }
    });
    // What a serial read would have: the pieces up to the first short one.
    for (std::size_t k = 0; k < pieces; ++k) {
        if (error[k] != 0) throw InputError(fmt::format("{}: cannot read: {}", file.string(), std::strerror(error[k])));
        out.size += got[k];
        if (got[k] < std::min(kPiece, size - k * kPiece)) break;
    }
    return out;
}

// The first i in [0, n) for which failing(i) holds, or n: searched in parallel, the same answer
// as a serial loop's (the loader's messages name the first bad element).
template <typename Failing>
std::size_t first_failing(std::size_t n, Failing failing) {
    return tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, n, std::size_t(1) << 14), n,
        [&](const tbb::blocked_range<std::size_t>& r, std::size_t first) {
            for (std::size_t i = r.begin(); i != r.end() && i < first; ++i)
                if (failing(i)) return i;
            return first;
        },
        [](std::size_t a, std::size_t b) { return std::min(a, b); });
}

// ---- URI policy -----------------------------------------------------------------------------

std::string percent_decode(const std::string& s, bool& bad) {
    std::string out;
    for (std::size_t i = 0; i < s.size(); ++i) {
        if (s[i] == '%') {
            if (i + 2 >= s.size() || !std::isxdigit(static_cast<unsigned char>(s[i + 1])) ||
                !std::isxdigit(static_cast<unsigned char>(s[i + 2]))) {
                bad = true;
                return out;
            }
            out.push_back(static_cast<char>(std::stoi(s.substr(i + 1, 2), nullptr, 16)));
            i += 2;
        } else {
            out.push_back(s[i]);
        }
    }
    return out;
}

bool inside(const fs::path& dir, const fs::path& candidate) {
    std::error_code ec;
    fs::path c = fs::weakly_canonical(candidate, ec);
    if (ec) return false;
    auto rel = c.lexically_relative(dir);
    return !rel.empty() && *rel.begin() != ".." && !rel.is_absolute();
}

// Refuses, before anything is read, URIs that would leave the scene's folder: absolute paths,
// schemes other than data:, ".." escapes and their percent-encoded forms.
void check_uri(const Context& ctx, const std::string& element, const std::string& uri) {
    if (uri.rfind("data:", 0) == 0) return;
    if (ctx.allow_external) return;
    bool bad = false;
    std::string decoded = percent_decode(uri, bad);
    if (bad) fail(ctx, element, fmt::format("malformed percent-encoding in uri \"{}\"", uri));
    if (decoded.find('\0') != std::string::npos) fail(ctx, element, "uri contains a NUL character");
    if (decoded.find("://") != std::string::npos)
        fail(ctx, element,
             fmt::format("uri \"{}\" names a scheme; only relative paths and data: "
                         "URIs are allowed (use --allow-external-paths to lift this)",
                         uri));
    bool absolute =
        !decoded.empty() && (decoded[0] == '/' || decoded[0] == '\\' || (decoded.size() > 1 && decoded[1] == ':'));
    if (absolute)
        fail(ctx, element,
             fmt::format("uri \"{}\" is an absolute path; external files must lie in "
                         "the scene's folder (use --allow-external-paths to lift this)",
                         uri));
    if (!inside(ctx.dir, ctx.dir / decoded))
        fail(ctx, element,
             fmt::format("uri \"{}\" resolves outside the scene's folder (use "
                         "--allow-external-paths to lift this)",
                         uri));
}

// What the raw JSON says that tinygltf's model forgets.
struct RawFacts {
    std::vector<bool> perspective_zfar_given;  // per camera: tinygltf turns an absent zfar into 0
    // Per image: whether a MASK material's baseColorTexture shows it (its bytes are kept).
    std::vector<bool> cutout_images;
    // A .glb whose buffers lie in its BIN chunk, rewritten so that tinygltf does not copy that
    // chunk into each such buffer (lean_bin_buffers below); empty where it is not.
    std::string lean_glb;
    // Per buffer: its byteLength where it is the BIN chunk's first bytes and read in place from
    // the file's bytes (at bin_offset), or -1 where tinygltf's buffer holds the data.
    std::vector<std::int64_t> in_place_length;
    std::size_t bin_offset = 0;
};

// tinygltf copies the BIN chunk into every buffer without a uri (memcpy into a zero-filled
// vector: 0.25 s for a 453 MB .glb). Where every such buffer is well formed (a byteLength
// integer within the chunk, which tinygltf checks too) and the chunk is (by tinygltf's own
// checks), the JSON handed to tinygltf says 4 bytes instead, over a 4-byte BIN chunk, and the
// loader reads those buffers from the file's bytes. The JSON is the same document re-written
// (nlohmann on both sides: the same values, keys and duplicates), so tinygltf parses the same
// model but for those byteLengths. Anything else falls back to the file as it is, for tinygltf
// to load or refuse as before.
void lean_bin_buffers(std::string_view bytes, const nlohmann::json& j, RawFacts& facts) {
    std::uint32_t header[5] = {};  // magic, version, length, chunk 0 length, chunk 0 type (checked)
    std::memcpy(header, bytes.data(), sizeof header);
    const std::uint64_t length = header[2], json_end = 20ull + header[3];
    if (length > bytes.size() || json_end % 4 != 0 || json_end + 12 > length) return;
    std::uint32_t bin_head[2];  // length, type
    std::memcpy(bin_head, bytes.data() + json_end, sizeof bin_head);
    if (bin_head[0] < 4 || bin_head[0] % 4 != 0 || bin_head[0] + json_end > length || bin_head[1] != 0x004E4942u)
        return;
    auto buffers = j.find("buffers");
    if (buffers == j.end() || !buffers->is_array()) return;
    // tinygltf hands an image in a bufferView its bytes as &buffer.data[byteOffset]: past the
    // end of a 4-byte buffer. Such files (textured models) keep the copy.
    if (auto images = j.find("images"); images != j.end() && images->is_array())
        for (const nlohmann::json& image : *images)
            if (image.is_object() && image.contains("bufferView")) return;
    nlohmann::json lean = j;
    std::vector<std::int64_t> in_place(buffers->size(), -1);
    bool any = false;
    for (std::size_t i = 0; i < buffers->size(); ++i) {
        const nlohmann::json& b = (*buffers)[i];
        if (!b.is_object()) return;
        if (auto uri = b.find("uri"); uri != b.end()) {
            if (!uri->is_string() || uri->get_ref<const std::string&>().empty()) return;
            continue;
        }
        auto len = b.find("byteLength");
        if (len == b.end() || !len->is_number_unsigned()) return;
        const std::uint64_t n = len->get<std::uint64_t>();
        if (n > bin_head[0]) return;
        if (n <= 4) continue;
        in_place[i] = static_cast<std::int64_t>(n);
        lean["buffers"][i]["byteLength"] = 4;
        any = true;
    }
    if (!any) return;
    std::string text;
    try {
        text = lean.dump();
    } catch (const nlohmann::json::exception&) {
        return;
    }
    text.resize((text.size() + 3) / 4 * 4, ' ');
    const auto json_len = static_cast<std::uint32_t>(text.size());
    const std::uint32_t head[5] = {0x46546C67u, 2u, 20 + json_len + 12, json_len, 0x4E4F534Au};
    const std::uint32_t lean_bin[2] = {4, 0x004E4942u};
    std::string glb(reinterpret_cast<const char*>(head), sizeof head);
    glb += text;
    glb.append(reinterpret_cast<const char*>(lean_bin), sizeof lean_bin);
    glb.append(bytes.data() + json_end + 8, 4);
    facts.lean_glb = std::move(glb);
    facts.in_place_length = std::move(in_place);
    facts.bin_offset = static_cast<std::size_t>(json_end + 8);
}

// glTF 1.0 files fail the 2.0 schema with baffling messages ("scene: expected a non-negative
// integer, got "defaultScene""): name the version instead.
void check_version(const Context& ctx, const nlohmann::json& j) {
    auto asset = j.find("asset");
    if (asset != j.end() && asset->is_object()) {
        auto version = asset->find("version");
        if (version != asset->end() && version->is_string()) {
            const std::string& v = version->get_ref<const std::string&>();
            if (v.rfind("2.", 0) != 0)
                fail(ctx, "asset.version",
                     fmt::format("glTF {} is not supported (penumbra reads glTF 2.0)", json_excerpt(*version, 20)));
        }
        return;
    }
    auto scene = j.find("scene");
    auto meshes = j.find("meshes");
    if ((scene != j.end() && scene->is_string()) || (meshes != j.end() && meshes->is_object()))
        fail(ctx, "asset", "missing, and the file looks like glTF 1.0 (objects keyed by name), which is not supported");
}

// Per image, whether a MASK or BLEND material's baseColorTexture shows it: only those are
// decoded (a technique's `blend: cutout(T)` tests a blended material's alpha). The schema has checked the types.
std::vector<bool> cutout_images(const nlohmann::json& j) {
    const auto images = j.find("images"), textures = j.find("textures"), materials = j.find("materials");
    if (images == j.end() || textures == j.end() || materials == j.end()) return {};
    std::vector<bool> wanted(images->size(), false);
    for (const nlohmann::json& m : *materials) {
        const std::string mode = m.value("alphaMode", std::string("OPAQUE"));
        if (mode != "MASK" && mode != "BLEND") continue;
        const auto pbr = m.find("pbrMetallicRoughness");
        if (pbr == m.end() || !pbr->contains("baseColorTexture")) continue;
        const std::size_t t = (*pbr)["baseColorTexture"]["index"].get<std::size_t>();
        if (t >= textures->size() || !(*textures)[t].contains("source")) continue;
        const std::size_t source = (*textures)[t]["source"].get<std::size_t>();
        if (source < wanted.size()) wanted[source] = true;
    }
    return wanted;
}

// Reads the JSON part of a .gltf or .glb and vets it (nesting, NUL bytes, version, types,
// URIs) before tinygltf sees it: tinygltf trusts its input and recurses without a limit.
RawFacts prevalidate(const Context& ctx, std::string_view bytes, bool binary) {
    std::string_view json_text;
    if (binary) {
        std::uint32_t header[5] = {};  // magic, version, length, chunk 0 length, chunk 0 type
        std::memcpy(header, bytes.data(), std::min(bytes.size(), sizeof header));
        if (bytes.size() >= 8 && header[1] != 2)
            fail(ctx, "GLB header", fmt::format("version {} is not supported (penumbra reads glTF 2.0)", header[1]));
        if (bytes.size() < 20 || header[4] != 0x4E4F534Au || std::uint64_t(header[3]) + 20 > bytes.size())
            fail(ctx, "GLB header", "truncated, or the first chunk is not a JSON chunk inside the file");
        json_text = bytes.substr(20, header[3]);
        // The JSON chunk is padded to 4 bytes (with spaces, though some exporters use NULs).
        while (!json_text.empty() && json_text.back() == '\0') json_text.remove_suffix(1);
    } else {
        json_text = bytes;
    }
    if (auto nul = json_text.find('\0'); nul != std::string::npos)
        fail(ctx, "JSON", fmt::format("a NUL byte at byte {} of the JSON text", nul + 1));
    check_json_nesting(json_text, ctx.label);
    RawFacts facts;
    nlohmann::json j = nlohmann::json::parse(json_text, nullptr, /*allow_exceptions=*/false);
    if (j.is_discarded() || !j.is_object()) return facts;  // tinygltf reports syntax errors
    check_version(ctx, j);
    check_gltf_schema(j, ctx.label);
    // Buffers are all read; images only where a cut-out shows them (read_cutouts checks those
    // then): a texture outside the folder that penumbra never reads refuses nothing.
    if (auto it = j.find("buffers"); it != j.end() && it->is_array())
        for (std::size_t i = 0; i < it->size(); ++i) {
            const auto& e = (*it)[i];
            if (e.is_object() && e.contains("uri") && e["uri"].is_string())
                check_uri(ctx, fmt::format("buffers[{}].uri", i), e["uri"].get<std::string>());
        }
    if (auto cams = j.find("cameras"); cams != j.end())  // an array of objects: the schema checked it
        for (const auto& c : *cams) {
            auto persp = c.find("perspective");
            facts.perspective_zfar_given.push_back(persp != c.end() && persp->contains("zfar"));
        }
    facts.cutout_images = cutout_images(j);
    if (binary) lean_bin_buffers(bytes, j, facts);
    return facts;
}

// tinygltf file-system callbacks that enforce the same policy on every file it opens.
bool fs_exists(const std::string& path, void* user) {
    auto* ctx = static_cast<Context*>(user);
    if (!ctx->allow_external && !inside(ctx->dir, path)) return false;
    std::error_code ec;
    return fs::is_regular_file(path, ec);
}
std::string fs_expand(const std::string& path, void*) {
    return path;
}
bool fs_read(std::vector<unsigned char>* out, std::string* err, const std::string& path, void* user) {
    auto* ctx = static_cast<Context*>(user);
    if (!ctx->allow_external && !inside(ctx->dir, path)) {
        *err += fmt::format("refusing to read \"{}\": outside the scene's folder\n", path);
        return false;
    }
    try {
        const std::string bytes = read_regular_file(path, kMaxFileBytes);
        out->assign(bytes.begin(), bytes.end());
    } catch (const InputError& e) {
        *err += std::string(e.what()) + "\n";
        return false;
    }
    return true;
}
bool fs_write(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
    *err += "penumbra never writes glTF files\n";
    return false;
}
// The bytes of the data-URI images that cut-outs show, as tinygltf decoded them from base64.
// Images in a bufferView are read from the loader's own checked buffers instead: tinygltf
// hands their bytes without checking the view against its buffer.
struct ImageCapture {
    const std::vector<bool>* wanted = nullptr;
    std::map<int, std::vector<unsigned char>> data_uri_bytes;
};
bool capture_image(tinygltf::Image* image, const int index, std::string*, std::string*, int, int,
                   const unsigned char* bytes, int size, void* user) {
    auto* capture = static_cast<ImageCapture*>(user);
    if (image->bufferView < 0 && index >= 0 && static_cast<std::size_t>(index) < capture->wanted->size() &&
        (*capture->wanted)[static_cast<std::size_t>(index)] && size > 0)
        capture->data_uri_bytes[index].assign(bytes, bytes + size);
    return true;  // nothing else is decoded: images carry no geometry
}

// ---- accessors ------------------------------------------------------------------------------

// A buffer's bytes: tinygltf's copy, or the file's own bytes (lean_bin_buffers).
struct BufferBytes {
    const unsigned char* data = nullptr;
    std::size_t size = 0;
};

struct AccessorView {
    const unsigned char* data = nullptr;
    std::size_t count = 0;
    std::size_t stride = 0;
    int component_type = 0;
};

// Validates an accessor against its buffer view and buffer, overflow-safely.
AccessorView checked_accessor(const Context& ctx, const tinygltf::Model& m, const std::vector<BufferBytes>& buffers,
                              int index, const std::string& user, int want_type,
                              std::initializer_list<int> want_components) {
    std::string element = fmt::format("accessors[{}]", index);
    if (index < 0 || index >= static_cast<int>(m.accessors.size()))
        fail(ctx, user, fmt::format("accessor index {} out of range ({} accessors)", index, m.accessors.size()));
    const tinygltf::Accessor& a = m.accessors[index];
    if (a.sparse.isSparse) fail(ctx, element, "sparse accessors are not supported");
    if (a.type != want_type)
        fail(ctx, element,
             fmt::format("type {} where {} expects {}", a.type, user,
                         want_type == TINYGLTF_TYPE_VEC2   ? "VEC2"
                         : want_type == TINYGLTF_TYPE_VEC3 ? "VEC3"
                         : want_type == TINYGLTF_TYPE_VEC4 ? "VEC4"
                                                           : "SCALAR"));
    bool ok_component = false;
    for (int c : want_components) ok_component |= (a.componentType == c);
    if (!ok_component) fail(ctx, element, fmt::format("componentType {} is not allowed for {}", a.componentType, user));
    if (a.count == 0) return {};
    if (a.bufferView < 0 || a.bufferView >= static_cast<int>(m.bufferViews.size()))
        fail(ctx, element,
             fmt::format("bufferView {} out of range ({} bufferViews)", a.bufferView, m.bufferViews.size()));
    const tinygltf::BufferView& bv = m.bufferViews[a.bufferView];
    if (bv.buffer < 0 || bv.buffer >= static_cast<int>(m.buffers.size()))
        fail(ctx, fmt::format("bufferViews[{}]", a.bufferView), fmt::format("buffer {} out of range", bv.buffer));
    const BufferBytes& buf = buffers[static_cast<std::size_t>(bv.buffer)];
    std::uint64_t view_end = 0;
    if (__builtin_add_overflow(std::uint64_t(bv.byteOffset), std::uint64_t(bv.byteLength), &view_end) ||
        view_end > buf.size)
        fail(ctx, fmt::format("bufferViews[{}]", a.bufferView),
             fmt::format("byteOffset + byteLength exceeds buffer {} ({} + {} > {} bytes)", bv.buffer, bv.byteOffset,
                         bv.byteLength, buf.size));
    int comp_size = tinygltf::GetComponentSizeInBytes(static_cast<std::uint32_t>(a.componentType));
    int ncomp = tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(a.type));
    std::size_t elem = static_cast<std::size_t>(comp_size * ncomp);
    std::size_t stride = bv.byteStride ? bv.byteStride : elem;
    if (stride < elem)
        fail(ctx, fmt::format("bufferViews[{}]", a.bufferView),
             fmt::format("byteStride {} is smaller than an element of accessor {} ({} bytes)", stride, index, elem));
    // Bytes the accessor spans: byteOffset + (count - 1) * stride + element size, overflow-checked.
    std::uint64_t need = 0;
    bool overflow = __builtin_mul_overflow(std::uint64_t(a.count - 1), std::uint64_t(stride), &need) ||
                    __builtin_add_overflow(need, std::uint64_t(a.byteOffset) + elem, &need);
    if (overflow || need > bv.byteLength)
        fail(ctx, element,
             fmt::format("byteOffset + count*stride exceeds bufferView {} ({} > {} bytes)", a.bufferView,
                         overflow ? std::string("2^64") : std::to_string(need), bv.byteLength));
    AccessorView v;
    v.data = buf.data + bv.byteOffset + a.byteOffset;
    v.count = a.count;
    v.stride = stride;
    v.component_type = a.componentType;
    return v;
}

// Element i of a float VEC3 accessor (checked_accessor made sure it lies inside its buffer).
glm::dvec3 position_at(const AccessorView& v, std::size_t i) {
    float f[3];
    std::memcpy(f, v.data + i * v.stride, sizeof f);
    return {f[0], f[1], f[2]};
}

// Element i of an unsigned byte, short or int index accessor.
std::uint32_t index_at(const AccessorView& v, std::size_t i) {
    const unsigned char* p = v.data + i * v.stride;
    if (v.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) return *p;
    if (v.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) {
        std::uint16_t s;
        std::memcpy(&s, p, 2);
        return s;
    }
    std::uint32_t idx;
    std::memcpy(&idx, p, 4);
    return idx;
}

// The POSITION accessor of a primitive, every element checked finite. Read where it lies in
// the buffer: the flattening transforms it straight into the scene's arrays.
AccessorView checked_positions(const Context& ctx, const tinygltf::Model& m, const std::vector<BufferBytes>& buffers,
                               int index, const std::string& user) {
    AccessorView v =
        checked_accessor(ctx, m, buffers, index, user, TINYGLTF_TYPE_VEC3, {TINYGLTF_COMPONENT_TYPE_FLOAT});
    const auto not_finite = [&](std::size_t i) {
        const glm::dvec3 q = position_at(v, i);
        return !(std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z));
    };
    if (const std::size_t i = first_failing(v.count, not_finite); i < v.count) {
        const glm::dvec3 q = position_at(v, i);
        for (int c = 0; c < 3; ++c)
            if (!std::isfinite(q[c]))
                fail(ctx, fmt::format("accessors[{}]", index),
                     fmt::format("element {} of {} is not finite ({})", i, user, static_cast<float>(q[c])));
    }
    return v;
}

// An index accessor, every element checked against the vertex count.
AccessorView checked_indices(const Context& ctx, const tinygltf::Model& m, const std::vector<BufferBytes>& buffers,
                             int index, const std::string& user, std::size_t vertex_count) {
    AccessorView v = checked_accessor(ctx, m, buffers, index, user, TINYGLTF_TYPE_SCALAR,
                                      {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                                       TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT});
    if (const std::size_t i = first_failing(v.count, [&](std::size_t k) { return index_at(v, k) >= vertex_count; });
        i < v.count) {
        const std::uint32_t idx = index_at(v, i);
        fail(ctx, user,
             fmt::format("index {} (element {} of accessors[{}]) is out of range: "
                         "POSITION has {} vertices",
                         idx, i, index, vertex_count));
    }
    return v;
}

// ---- transforms -----------------------------------------------------------------------------

glm::dmat4 local_transform(const Context& ctx, const tinygltf::Node& n, int index) {
    std::string element = fmt::format("nodes[{}]", index);
    auto check = [&](const std::vector<double>& v, std::size_t size, const char* name) {
        if (!v.empty() && v.size() != size)
            fail(ctx, element, fmt::format("{} must have {} numbers, has {}", name, size, v.size()));
        for (double d : v)
            if (!std::isfinite(d)) fail(ctx, element, fmt::format("{} is not finite", name));
    };
    check(n.matrix, 16, "matrix");
    check(n.translation, 3, "translation");
    check(n.rotation, 4, "rotation");
    check(n.scale, 3, "scale");
    if (!n.matrix.empty()) return glm::make_mat4(n.matrix.data());  // column-major, as glTF
    glm::dmat4 t(1.0), r(1.0), s(1.0);
    if (!n.translation.empty()) t[3] = glm::dvec4(n.translation[0], n.translation[1], n.translation[2], 1.0);
    if (!n.rotation.empty()) {
        glm::dquat q(n.rotation[3], n.rotation[0], n.rotation[1], n.rotation[2]);
        double len = glm::length(q);
        if (!(len > 1e-6)) fail(ctx, element, "rotation is a zero quaternion");
        r = glm::mat4_cast(q / len);
    }
    if (!n.scale.empty()) {
        s[0][0] = n.scale[0];
        s[1][1] = n.scale[1];
        s[2][2] = n.scale[2];
    }
    return t * r * s;
}

int node_light(const Context& ctx, const tinygltf::Node& n, int index, std::size_t light_count) {
    auto it = n.extensions.find("KHR_lights_punctual");
    if (it == n.extensions.end()) return -1;
    const tinygltf::Value& ext = it->second;
    if (!ext.IsObject() || !ext.Has("light") || !ext.Get("light").IsInt())
        fail(ctx, fmt::format("nodes[{}].extensions.KHR_lights_punctual", index), "expected {\"light\": integer}");
    int l = ext.Get("light").GetNumberAsInt();
    if (l < 0 || static_cast<std::size_t>(l) >= light_count)
        fail(ctx, fmt::format("nodes[{}].extensions.KHR_lights_punctual.light", index),
             fmt::format("light {} out of range ({} lights)", l, light_count));
    return l;
}

// ---- cut-outs (alphaMode MASK) -----------------------------------------------------------------

constexpr std::size_t kMaxCutoutImages = 4096;
constexpr std::uint64_t kMaxCutoutPixels = std::uint64_t(256) << 20;  // all images: 512 MiB of 16-bit alpha

std::string named(const std::string& element, const std::string& name) {
    return name.empty() ? element
                        : fmt::format("{} \"{}\"", element, escape_non_utf8(name.substr(0, kMaxNodeLabelBytes)));
}

// Component c of element i of a float or normalised unsigned byte/short accessor (glTF 2.0
// section 3.11: TEXCOORD_n and COLOR_n), as a number in [0, 1] for the normalised ones.
double unorm_at(const AccessorView& v, std::size_t i, int c) {
    const unsigned char* p = v.data + i * v.stride;
    switch (v.component_type) {
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return p[c] / 255.0;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
            std::uint16_t u;
            std::memcpy(&u, p + 2 * c, 2);
            return u / 65535.0;
        }
        default: {
            float f;
            std::memcpy(&f, p + 4 * c, 4);
            return f;
        }
    }
}

TextureWrap wrap_of(const Context& ctx, const std::string& element, int mode) {
    switch (mode) {
        case TINYGLTF_TEXTURE_WRAP_REPEAT: return TextureWrap::repeat;
        case TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE: return TextureWrap::clamp_to_edge;
        case TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT: return TextureWrap::mirrored_repeat;
        default: fail(ctx, element, fmt::format("wrap mode {} is not 10497, 33071 or 33648", mode));
    }
}

// KHR_texture_transform of a textureInfo: the matrix (offset x rotation x scale, the extension's
// own GLSL) and the texCoord it overrides, if it does.
glm::dmat3 texture_transform(const Context& ctx, const std::string& element, const tinygltf::ExtensionMap& extensions,
                             int& tex_coord) {
    const auto it = extensions.find("KHR_texture_transform");
    if (it == extensions.end()) return glm::dmat3(1.0);
    const tinygltf::Value& t = it->second;
    const std::string where = element + ".extensions.KHR_texture_transform";
    if (!t.IsObject()) fail(ctx, where, "expected an object");
    auto numbers = [&](const char* key, std::size_t n, std::vector<double> fallback) {
        if (!t.Has(key)) return fallback;
        const tinygltf::Value& v = t.Get(key);
        std::vector<double> out;
        if (n == 1 && v.IsNumber()) out.push_back(v.GetNumberAsDouble());
        if (n > 1 && v.IsArray() && v.ArrayLen() == n)
            for (std::size_t k = 0; k < n; ++k)
                if (v.Get(static_cast<int>(k)).IsNumber())
                    out.push_back(v.Get(static_cast<int>(k)).GetNumberAsDouble());
        if (out.size() != n || !std::all_of(out.begin(), out.end(), [](double d) { return std::isfinite(d); }))
            fail(ctx, where, fmt::format("{} must be {} finite number{}", key, n, n > 1 ? "s" : ""));
        return out;
    };
    const std::vector<double> offset = numbers("offset", 2, {0, 0}), scale = numbers("scale", 2, {1, 1});
    const double rotation = numbers("rotation", 1, {0})[0];
    if (t.Has("texCoord")) {
        const tinygltf::Value& c = t.Get("texCoord");
        if (!c.IsInt() || c.GetNumberAsInt() < 0) fail(ctx, where, "texCoord must be a non-negative integer");
        tex_coord = c.GetNumberAsInt();
    }
    const glm::dmat3 translation(1, 0, 0, 0, 1, 0, offset[0], offset[1], 1);
    const glm::dmat3 rotate(std::cos(rotation), std::sin(rotation), 0, -std::sin(rotation), std::cos(rotation), 0, 0, 0,
                            1);
    const glm::dmat3 scaling(scale[0], 0, 0, 0, scale[1], 0, 0, 0, 1);
    return translation * rotate * scaling;
}

// The cut-out (MASK) and blended (BLEND) materials of a model, their images decoded: per glTF
// material its index into scene.cutout_materials (kNoCutout where it is OPAQUE), and per entry
// the TEXCOORD set its texture reads.
struct Cutouts {
    std::vector<std::uint32_t> of_material;
    std::vector<int> tex_coord;
    bool any() const { return !tex_coord.empty(); }
};

Cutouts read_cutouts(const Context& ctx, const tinygltf::Model& m, const std::vector<BufferBytes>& buffers,
                     const ImageCapture& capture, Scene& scene) {
    Cutouts out;
    out.of_material.assign(m.materials.size(), kNoCutout);
    std::map<int, int> texture_of_image;  // image index -> scene.alpha_textures index
    std::uint64_t pixels = 0;
    auto decode = [&](int index) {
        if (auto it = texture_of_image.find(index); it != texture_of_image.end()) return it->second;
        const tinygltf::Image& image = m.images[static_cast<std::size_t>(index)];
        const std::string element = named(fmt::format("images[{}]", index), image.name);
        if (scene.alpha_textures.size() >= kMaxCutoutImages)
            fail(ctx, element, fmt::format("more than {} images are shown by cut-outs", kMaxCutoutImages));
        EncodedImage e;
        e.label = fmt::format("{}: {}", ctx.label, element);
        e.mime_type = image.mimeType;
        if (image.bufferView >= 0) {
            if (static_cast<std::size_t>(image.bufferView) >= m.bufferViews.size())
                fail(ctx, element, fmt::format("bufferView {} out of range", image.bufferView));
            const tinygltf::BufferView& bv = m.bufferViews[static_cast<std::size_t>(image.bufferView)];
            if (bv.buffer < 0 || static_cast<std::size_t>(bv.buffer) >= buffers.size())
                fail(ctx, fmt::format("bufferViews[{}]", image.bufferView), "buffer out of range");
            const BufferBytes& b = buffers[static_cast<std::size_t>(bv.buffer)];
            std::uint64_t end = 0;
            if (__builtin_add_overflow(std::uint64_t(bv.byteOffset), std::uint64_t(bv.byteLength), &end) ||
                end > b.size)
                fail(ctx, fmt::format("bufferViews[{}]", image.bufferView),
                     fmt::format("the image's bytes end past buffer {} ({} bytes)", bv.buffer, b.size));
            e.bytes = {b.data + bv.byteOffset, bv.byteLength};
        } else if (image.uri.empty()) {
            const auto it = capture.data_uri_bytes.find(index);
            if (it == capture.data_uri_bytes.end()) fail(ctx, element, "its data URI holds no bytes");
            e.bytes = it->second;
        } else {
            // The buffers' URI policy (check_uri), for the images penumbra reads.
            check_uri(ctx, element + ".uri", image.uri);
            bool bad = false;
            const std::string decoded = percent_decode(image.uri, bad);
            if (bad) fail(ctx, element, fmt::format("malformed percent-encoding in uri \"{}\"", image.uri));
            if (decoded.find('\0') != std::string::npos) fail(ctx, element, "uri contains a NUL character");
            e.file = ctx.dir / decoded;
        }
        AlphaTexture t = alpha_image_decoder()(e);
        pixels += static_cast<std::uint64_t>(t.width) * static_cast<std::uint64_t>(t.height);
        if (pixels > kMaxCutoutPixels)
            fail(ctx, element,
                 fmt::format("the cut-outs' images pass {} Mpixels together (this one is {}x{})",
                             kMaxCutoutPixels >> 20, t.width, t.height));
        t.label = e.label;
        scene.alpha_textures.push_back(std::move(t));
        const int k = static_cast<int>(scene.alpha_textures.size()) - 1;
        texture_of_image[index] = k;
        return k;
    };
    for (std::size_t i = 0; i < m.materials.size(); ++i) {
        const tinygltf::Material& mat = m.materials[i];
        if (mat.alphaMode != "MASK" && mat.alphaMode != "BLEND") continue;
        const std::string element = fmt::format("materials[{}]", i);
        CutoutMaterial c;
        c.mode = mat.alphaMode == "MASK" ? AlphaMode::mask : AlphaMode::blend;
        c.label = fmt::format("{}: {}", ctx.label, named(element, mat.name));
        c.cutoff = mat.alphaCutoff;
        if (!std::isfinite(c.cutoff)) fail(ctx, element, "alphaCutoff is not finite");
        const std::vector<double>& factor = mat.pbrMetallicRoughness.baseColorFactor;
        if (factor.size() != 4 || !std::isfinite(factor[3]))
            fail(ctx, element + ".pbrMetallicRoughness", "baseColorFactor must be 4 finite numbers");
        c.factor_alpha = factor[3];
        const tinygltf::TextureInfo& info = mat.pbrMetallicRoughness.baseColorTexture;
        int tex_coord = info.texCoord;
        if (info.index >= 0) {
            const std::string where = element + ".pbrMetallicRoughness.baseColorTexture";
            if (static_cast<std::size_t>(info.index) >= m.textures.size())
                fail(ctx, where, fmt::format("texture {} out of range ({} textures)", info.index, m.textures.size()));
            c.uv_transform = texture_transform(ctx, where, info.extensions, tex_coord);
            const tinygltf::Texture& tex = m.textures[static_cast<std::size_t>(info.index)];
            if (tex.source < 0) {
                scene.warnings.push_back(
                    fmt::format("{}: textures[{}] has no source penumbra reads; the cut-out {} uses its factor alone",
                                ctx.label, info.index, c.label));
            } else {
                if (static_cast<std::size_t>(tex.source) >= m.images.size())
                    fail(ctx, fmt::format("textures[{}]", info.index),
                         fmt::format("source {} out of range", tex.source));
                c.texture = decode(tex.source);
            }
            if (tex.sampler >= 0) {
                if (static_cast<std::size_t>(tex.sampler) >= m.samplers.size())
                    fail(ctx, fmt::format("textures[{}]", info.index),
                         fmt::format("sampler {} out of range", tex.sampler));
                const tinygltf::Sampler& smp = m.samplers[static_cast<std::size_t>(tex.sampler)];
                const std::string sampler = fmt::format("samplers[{}]", tex.sampler);
                c.wrap_s = wrap_of(ctx, sampler + ".wrapS", smp.wrapS);
                c.wrap_t = wrap_of(ctx, sampler + ".wrapT", smp.wrapT);
                c.nearest = smp.magFilter == TINYGLTF_TEXTURE_FILTER_NEAREST;
                c.min_filter = smp.minFilter;
            }
        }
        out.of_material[i] = static_cast<std::uint32_t>(scene.cutout_materials.size());
        out.tex_coord.push_back(tex_coord);
        scene.cutout_materials.push_back(std::move(c));
    }
    return out;
}

// ---- flattening -----------------------------------------------------------------------------

struct Flattener {
    const Context& ctx;
    const tinygltf::Model& m;
    const RawFacts& facts;
    const std::vector<BufferBytes>& buffers;
    std::uint64_t max_memory_bytes;
    Scene& scene;
    const Cutouts& cutouts;
    std::size_t degenerate = 0, skipped_points_lines = 0;

    // A primitive's texture coordinates and COLOR_0 alpha, where the model has cut-outs; its
    // triangles' cut-out index (kNoCutout where its material is not MASK).
    void add_cutout_attributes(const tinygltf::Primitive& p, const std::string& element, std::size_t base,
                               std::size_t vertex_count, std::size_t first_triangle, std::uint32_t cutout) {
        scene.triangle_cutout.resize(scene.triangles.size(), kNoCutout);
        std::fill(scene.triangle_cutout.begin() + static_cast<std::ptrdiff_t>(first_triangle),
                  scene.triangle_cutout.end(), cutout);
        scene.texcoords.resize(base + vertex_count, glm::vec2(0.0f));
        scene.vertex_alpha.resize(base + vertex_count, 1.0f);
        if (cutout == kNoCutout) return;
        auto attribute = [&](const std::string& name, int type, std::initializer_list<int> components,
                             std::size_t& count) -> std::optional<AccessorView> {
            const auto it = p.attributes.find(name);
            if (it == p.attributes.end()) return std::nullopt;
            const AccessorView v =
                checked_accessor(ctx, m, buffers, it->second, element + ".attributes." + name, type, components);
            if (v.count < vertex_count)
                fail(ctx, element + ".attributes." + name,
                     fmt::format("{} elements where POSITION has {}", v.count, vertex_count));
            count = v.count;
            return v;
        };
        std::size_t count = 0;
        const std::string set = fmt::format("TEXCOORD_{}", cutouts.tex_coord[cutout]);
        if (scene.cutout_materials[cutout].texture >= 0) {
            if (const auto uv = attribute(set, TINYGLTF_TYPE_VEC2,
                                          {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                                           TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT},
                                          count)) {
                for (std::size_t i = 0; i < vertex_count; ++i) {
                    const glm::vec2 t(static_cast<float>(unorm_at(*uv, i, 0)), static_cast<float>(unorm_at(*uv, i, 1)));
                    if (!std::isfinite(t.x) || !std::isfinite(t.y))
                        fail(ctx, element + ".attributes." + set, fmt::format("element {} is not finite", i));
                    scene.texcoords[base + i] = t;
                }
            } else {
                scene.warnings.push_back(
                    fmt::format("{}: {}: the cut-out {} reads {}, which it lacks: uv (0, 0) is used", ctx.label,
                                element, scene.cutout_materials[cutout].label, set));
            }
        }
        const auto it = p.attributes.find("COLOR_0");
        if (it != p.attributes.end() && it->second >= 0 && static_cast<std::size_t>(it->second) < m.accessors.size() &&
            m.accessors[static_cast<std::size_t>(it->second)].type == TINYGLTF_TYPE_VEC4)
            if (const auto colour = attribute("COLOR_0", TINYGLTF_TYPE_VEC4,
                                              {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                                               TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT},
                                              count))
                for (std::size_t i = 0; i < vertex_count; ++i) {
                    const double a = unorm_at(*colour, i, 3);
                    if (!std::isfinite(a))
                        fail(ctx, element + ".attributes.COLOR_0", fmt::format("element {} is not finite", i));
                    scene.vertex_alpha[base + i] = static_cast<float>(a);
                }
    }

    void add_primitive(int node_index, int mesh_index, int prim_index, const glm::dmat4& world) {
        const tinygltf::Primitive& p = m.meshes[mesh_index].primitives[prim_index];
        std::string element = fmt::format("meshes[{}].primitives[{}]", mesh_index, prim_index);
        int mode = p.mode < 0 ? TINYGLTF_MODE_TRIANGLES : p.mode;
        if (mode == TINYGLTF_MODE_POINTS || mode == TINYGLTF_MODE_LINE || mode == TINYGLTF_MODE_LINE_LOOP ||
            mode == 3 /* LINE_STRIP */) {
            ++skipped_points_lines;
            return;
        }
        if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
            mode != TINYGLTF_MODE_TRIANGLE_FAN)
            fail(ctx, element, fmt::format("mode {} is not a glTF primitive mode", p.mode));
        auto pos = p.attributes.find("POSITION");
        if (pos == p.attributes.end()) fail(ctx, element, "no POSITION attribute");
        bool double_sided = false;
        std::uint32_t cutout = kNoCutout;
        if (p.material >= 0) {
            if (p.material >= static_cast<int>(m.materials.size()))
                fail(ctx, element,
                     fmt::format("material {} out of range ({} materials)", p.material, m.materials.size()));
            double_sided = m.materials[p.material].doubleSided;
            cutout = cutouts.any() ? cutouts.of_material[static_cast<std::size_t>(p.material)] : kNoCutout;
        }
        // One pass from the buffer into the scene's arrays: no per-primitive copies of the
        // positions, indices or triangles (on a 2.36M-triangle mesh those were 84 MB of
        // zero-filled temporaries).
        const AccessorView positions =
            checked_positions(ctx, m, buffers, pos->second, element + ".attributes.POSITION");
        const bool indexed = p.indices >= 0;
        const AccessorView indices =
            indexed ? checked_indices(ctx, m, buffers, p.indices, element + ".indices", positions.count)
                    : AccessorView{};
        const std::size_t index_count = indexed ? indices.count : positions.count;
        auto vertex = [&](std::size_t k) { return indexed ? index_at(indices, k) : static_cast<std::uint32_t>(k); };
        // A mirroring transform flips the winding (glTF: the determinant defines front faces).
        bool mirror = glm::determinant(glm::dmat3(world)) < 0;
        std::uint32_t base = static_cast<std::uint32_t>(scene.positions.size());
        if (scene.positions.size() + positions.count > std::numeric_limits<std::uint32_t>::max())
            fail(ctx, element, "scene has more than 2^32 vertices");
        // Triangles of each topology, per glTF 2.0 section 3.7.2.1.
        std::size_t triangle_count = 0;
        if (mode == TINYGLTF_MODE_TRIANGLES) {
            triangle_count = index_count / 3;
            if (index_count % 3)
                scene.warnings.push_back(fmt::format("{}: {} trailing indices ignored", element, index_count % 3));
        } else if (index_count >= 3) {
            triangle_count = index_count - 2;
        }
        auto triangle = [&](std::size_t t) -> glm::u32vec3 {
            if (mode == TINYGLTF_MODE_TRIANGLES) return {vertex(3 * t), vertex(3 * t + 1), vertex(3 * t + 2)};
            if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) return {vertex(t), vertex(t + 1 + t % 2), vertex(t + 2 - t % 2)};
            return {vertex(t + 1), vertex(t + 2), vertex(0)};  // fan
        };
        // Vertices and triangles in parallel, in blocks of a fixed size, so that the scene is
        // the same whatever the thread count: the kept triangles of each block are counted
        // first, then written at their block's offset. No reserve here: check_size reserved the
        // whole scene from upper bounds of these counts.
        scene.positions.resize(base + positions.count);
        glm::dvec3* const world_positions = scene.positions.data() + base;
        const auto transformed = [&](std::size_t i) {
            return glm::dvec3(world * glm::dvec4(position_at(positions, i), 1.0));
        };
        const std::size_t far = first_failing(positions.count, [&](std::size_t i) {
            const glm::dvec3 w = transformed(i);
            world_positions[i] = w;
            return !(std::abs(w.x) <= kMaxCoordinate && std::abs(w.y) <= kMaxCoordinate &&
                     std::abs(w.z) <= kMaxCoordinate);
        });
        if (far < positions.count) {
            const glm::dvec3 w = transformed(far);
            for (int c = 0; c < 3; ++c)
                if (!(std::abs(w[c]) <= kMaxCoordinate))
                    fail(ctx, element,
                         fmt::format("vertex {} lies at {} m from the origin after node {}'s "
                                     "transform (limit {:g} m)",
                                     far, w[c], node_index, kMaxCoordinate));
        }
        const auto has_area = [&](const glm::u32vec3& t) {  // no area: can neither be seen nor occlude
            const glm::dvec3 a = world_positions[t.x], b = world_positions[t.y], c = world_positions[t.z];
            const glm::dvec3 cross = glm::cross(b - a, c - a);
            return glm::dot(cross, cross) != 0.0;
        };
        constexpr std::size_t kBlock = std::size_t(1) << 14;
        const std::size_t blocks = (triangle_count + kBlock - 1) / kBlock;
        std::vector<std::size_t> block_first(blocks + 1, 0);
        tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t k) {
            std::size_t kept = 0;
            for (std::size_t ti = k * kBlock; ti < std::min(triangle_count, (k + 1) * kBlock); ++ti)
                kept += has_area(triangle(ti));
            block_first[k + 1] = kept;
        });
        for (std::size_t k = 0; k < blocks; ++k) block_first[k + 1] += block_first[k];
        const std::size_t kept = block_first[blocks], first_triangle = scene.triangles.size();
        degenerate += triangle_count - kept;
        scene.triangles.resize(first_triangle + kept);
        scene.double_sided.resize(first_triangle + kept);
        scene.triangle_node.resize(first_triangle + kept);
        std::vector<Bounds> block_bounds(blocks);
        tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t k) {
            std::size_t out = first_triangle + block_first[k];
            Bounds& bounds = block_bounds[k];
            for (std::size_t ti = k * kBlock; ti < std::min(triangle_count, (k + 1) * kBlock); ++ti) {
                glm::u32vec3 t = triangle(ti);
                if (!has_area(t)) continue;
                for (int v = 0; v < 3; ++v) bounds.grow(world_positions[t[v]]);
                if (mirror) std::swap(t.y, t.z);
                scene.triangles[out] = t + glm::u32vec3(base);
                scene.double_sided[out] = double_sided ? 1 : 0;
                scene.triangle_node[out] = static_cast<std::uint32_t>(node_index);
                ++out;
            }
        });
        for (const Bounds& b : block_bounds)  // min and max: exact in any order
            if (!b.empty()) {
                scene.bounds.grow(b.lo);
                scene.bounds.grow(b.hi);
            }
        if (cutouts.any()) add_cutout_attributes(p, element, base, positions.count, first_triangle, cutout);
    }

    void add_camera(int node_index, int cam, const glm::dmat4& world) {
        std::string element = fmt::format("cameras[{}]", cam);
        if (cam < 0 || cam >= static_cast<int>(m.cameras.size()))
            fail(ctx, fmt::format("nodes[{}].camera", node_index), fmt::format("camera {} out of range", cam));
        if (scene.camera_placed[cam]) return;  // the first node that uses a camera places it
        const tinygltf::Camera& c = m.cameras[cam];
        Camera out;
        glm::dvec3 eye(world[3]);
        glm::dvec3 fwd(world * glm::dvec4(0, 0, -1, 0));
        glm::dvec3 up(world * glm::dvec4(0, 1, 0, 0));
        if (!look_at_basis(eye, eye + fwd, up, out))
            fail(ctx, fmt::format("nodes[{}]", node_index), "camera transform is degenerate");
        if (c.type == "perspective") {
            out.type = ProjectionType::perspective;
            out.yfov_rad = c.perspective.yfov;
            out.znear = c.perspective.znear;
            // Absent means infinite (glTF 2.0, 5.13); a given zfar is checked like any other.
            const bool given = static_cast<std::size_t>(cam) < facts.perspective_zfar_given.size() &&
                               facts.perspective_zfar_given[cam];
            out.zfar = given ? c.perspective.zfar : std::numeric_limits<double>::infinity();
        } else if (c.type == "orthographic") {
            out.type = ProjectionType::orthographic;
            out.xmag = c.orthographic.xmag;
            out.ymag = c.orthographic.ymag;
            out.znear = c.orthographic.znear;
            out.zfar = c.orthographic.zfar;
        } else {
            fail(ctx, element, fmt::format("unknown camera type \"{}\"", c.type));
        }
        scene.cameras[cam] = out;
        scene.camera_placed[cam] = true;
    }

    void add_light(int node_index, int li, const glm::dmat4& world) {
        const tinygltf::Light& l = m.lights[li];
        std::string element = fmt::format("KHR_lights_punctual.lights[{}]", li);
        Light out;
        out.origin = fmt::format("{} (placed by nodes[{}])", element, node_index);
        out.position = glm::dvec3(world[3]);
        glm::dvec3 dir(world * glm::dvec4(0, 0, -1, 0));
        double len = glm::length(dir);
        if (l.type == "directional" || l.type == "spot") {
            if (!(len > 0) || !std::isfinite(len))
                fail(ctx, fmt::format("nodes[{}]", node_index), "light transform collapses the light's direction");
            out.direction = dir / len;
        }
        if (l.type == "directional") {
            out.type = LightType::directional;
        } else if (l.type == "point") {
            out.type = LightType::point;
        } else if (l.type == "spot") {
            out.type = LightType::spot;
            out.outer_cone_rad = l.spot.outerConeAngle;
            out.inner_cone_rad = l.spot.innerConeAngle;
            if (!(out.outer_cone_rad > 0 && out.outer_cone_rad <= M_PI / 2))
                fail(ctx, element, fmt::format("spot.outerConeAngle {} outside (0, pi/2]", out.outer_cone_rad));
        } else {
            fail(ctx, element, fmt::format("unknown light type \"{}\"", l.type));
        }
        scene.lights.push_back(out);
    }

    // Counts what flattening will make before it is made: a small file can instance one mesh
    // into billions of triangles. Invalid indices are skipped here and reported by the real pass.
    template <class Item>
    void check_size(const std::vector<Item>& roots) const {
        std::uint64_t triangles = 0, vertices = 0;
        auto count_of = [&](int accessor) -> std::uint64_t {
            return accessor >= 0 && static_cast<std::size_t>(accessor) < m.accessors.size()
                       ? m.accessors[accessor].count
                       : 0;
        };
        std::vector<int> todo;
        for (const Item& r : roots) todo.push_back(r.node);
        while (!todo.empty()) {
            const tinygltf::Node& node = m.nodes[todo.back()];
            todo.pop_back();
            if (node.mesh >= 0 && static_cast<std::size_t>(node.mesh) < m.meshes.size())
                for (const tinygltf::Primitive& p : m.meshes[node.mesh].primitives) {
                    auto pos = p.attributes.find("POSITION");
                    if (pos == p.attributes.end()) continue;
                    const std::uint64_t v = count_of(pos->second), i = p.indices >= 0 ? count_of(p.indices) : v;
                    vertices += v;
                    triangles += p.mode < 0 || p.mode == TINYGLTF_MODE_TRIANGLES ? i / 3 : i;
                }
            for (int c : node.children) todo.push_back(c);  // in range: traverse() checked the forest
        }
        MemoryInputs in;
        in.triangles = triangles;
        in.vertices = vertices;
        check_memory(estimate_memory(in), max_memory_bytes, ctx.label);
        // The scene's arrays are sized once, to these counts (an upper bound of what is kept):
        // grown primitive by primitive, each doubling re-copies them and faults in fresh pages.
        scene.positions.reserve(vertices);
        scene.triangles.reserve(triangles);
        scene.double_sided.reserve(triangles);
        scene.triangle_node.reserve(triangles);
    }

    void traverse(const std::vector<int>& roots) {
        const std::size_t n = m.nodes.size();
        // glTF requires a forest: every node has at most one parent and no node is its own ancestor.
        std::vector<int> parent(n, -1);
        for (std::size_t i = 0; i < n; ++i)
            for (int c : m.nodes[i].children) {
                if (c < 0 || static_cast<std::size_t>(c) >= n)
                    fail(ctx, fmt::format("nodes[{}].children", i),
                         fmt::format("node {} out of range ({} nodes)", c, n));
                if (static_cast<std::size_t>(c) == i)
                    fail(ctx, fmt::format("nodes[{}]", i), "node hierarchy has a cycle (node is its own child)");
                if (parent[c] >= 0)
                    fail(ctx, fmt::format("nodes[{}]", c),
                         fmt::format("node has two parents (nodes {} and {}); "
                                     "glTF node hierarchies must be trees",
                                     parent[c], i));
                parent[c] = static_cast<int>(i);
            }
        for (std::size_t i = 0; i < n; ++i) {  // a cycle shows up as a walk up that never ends
            std::size_t steps = 0;
            for (int p = parent[i]; p >= 0; p = parent[p])
                if (++steps > n) fail(ctx, fmt::format("nodes[{}]", i), "node hierarchy has a cycle");
        }
        struct Item {
            int node;
            glm::dmat4 world;
        };
        std::vector<Item> stack;
        for (auto it = roots.rbegin(); it != roots.rend(); ++it) {
            if (*it < 0 || static_cast<std::size_t>(*it) >= n)
                fail(ctx, "scenes", fmt::format("root node {} out of range ({} nodes)", *it, n));
            if (parent[*it] >= 0)
                fail(ctx, fmt::format("nodes[{}]", *it), "a scene root must not be another node's child");
            stack.push_back({*it, glm::dmat4(1.0)});
        }
        check_size(stack);
        while (!stack.empty()) {  // explicit stack: deep hierarchies must not overflow ours
            Item item = stack.back();
            stack.pop_back();
            const tinygltf::Node& node = m.nodes[item.node];
            glm::dmat4 world = item.world * local_transform(ctx, node, item.node);
            if (node.mesh >= 0) {
                if (node.mesh >= static_cast<int>(m.meshes.size()))
                    fail(ctx, fmt::format("nodes[{}].mesh", item.node),
                         fmt::format("mesh {} out of range ({} meshes)", node.mesh, m.meshes.size()));
                for (std::size_t p = 0; p < m.meshes[node.mesh].primitives.size(); ++p)
                    add_primitive(item.node, node.mesh, static_cast<int>(p), world);
            }
            if (node.camera >= 0) add_camera(item.node, node.camera, world);
            int li = node_light(ctx, node, item.node, m.lights.size());
            if (li >= 0) add_light(item.node, li, world);
            for (auto it = node.children.rbegin(); it != node.children.rend(); ++it) stack.push_back({*it, world});
        }
    }
};

}  // namespace

Scene load_gltf(const fs::path& file, const GltfLoadOptions& options) {
    Context ctx;
    ctx.label = file.filename().string();
    std::error_code ec;
    if (!fs::exists(file, ec)) throw InputError(fmt::format("{}: no such file", file.string()));
    ctx.dir = fs::weakly_canonical(fs::absolute(file).parent_path());
    ctx.allow_external = options.allow_external_paths;
    const FileBytes file_bytes = read_scene_file(file, kMaxFileBytes);
    const std::string_view bytes = file_bytes.view();
    bool binary = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
    const RawFacts facts = prevalidate(ctx, bytes, binary);
    // tinygltf reads the lean copy where there is one (lean_bin_buffers).
    const std::string_view given = facts.lean_glb.empty() ? bytes : std::string_view(facts.lean_glb);

    tinygltf::TinyGLTF loader;
    tinygltf::FsCallbacks callbacks{&fs_exists, &fs_expand, &fs_read, &fs_write, &ctx};
    loader.SetFsCallbacks(callbacks);
    ImageCapture capture{&facts.cutout_images, {}};
    loader.SetImageLoader(&capture_image, &capture);
    tinygltf::Model model;
    std::string err, warn;
    std::string base_dir = ctx.dir.string();
    bool ok =
        binary ? loader.LoadBinaryFromMemory(&model, &err, &warn, reinterpret_cast<const unsigned char*>(given.data()),
                                             static_cast<unsigned int>(given.size()), base_dir)
               : loader.LoadASCIIFromString(&model, &err, &warn, bytes.data(), static_cast<unsigned int>(bytes.size()),
                                            base_dir);
    if (!ok) {
        while (!err.empty() && (err.back() == '\n' || err.back() == ' ')) err.pop_back();
        for (auto& ch : err)
            if (ch == '\n') ch = ';';
        throw InputError(
            fmt::format("{}: not a valid glTF 2.0 file: {}", ctx.label, err.empty() ? "unknown error" : err));
    }

    Scene scene;
    scene.cameras.resize(model.cameras.size());
    scene.camera_placed.assign(model.cameras.size(), false);
    // What messages call a node: its index, and its name where it has one (capped, made UTF-8).
    scene.node_labels.reserve(model.nodes.size());
    for (std::size_t i = 0; i < model.nodes.size(); ++i) {
        const std::string& name = model.nodes[i].name;
        scene.node_labels.push_back(
            name.empty() ? fmt::format("nodes[{}]", i)
                         : fmt::format("nodes[{}] \"{}\"", i, escape_non_utf8(name.substr(0, kMaxNodeLabelBytes))));
    }
    std::vector<int> roots;
    if (!model.scenes.empty()) {
        int s = model.defaultScene >= 0 ? model.defaultScene : 0;
        if (s >= static_cast<int>(model.scenes.size()))
            fail(ctx, "scene", fmt::format("default scene {} out of range ({} scenes)", s, model.scenes.size()));
        roots = model.scenes[s].nodes;
    } else {
        std::vector<bool> is_child(model.nodes.size(), false);
        for (const auto& n : model.nodes)
            for (int c : n.children)
                if (c >= 0 && static_cast<std::size_t>(c) < is_child.size()) is_child[c] = true;
        for (std::size_t i = 0; i < model.nodes.size(); ++i)
            if (!is_child[i]) roots.push_back(static_cast<int>(i));
        scene.warnings.push_back(fmt::format("{}: no scenes; using all {} root nodes", ctx.label, roots.size()));
    }
    // A root listed twice would be drawn twice, doubling its geometry: draw it once, say so.
    std::vector<int> unique_roots;
    for (int r : roots) {
        if (std::find(unique_roots.begin(), unique_roots.end(), r) == unique_roots.end()) {
            unique_roots.push_back(r);
        } else {
            scene.warnings.push_back(
                fmt::format("{}: scene lists root node {} more than once; its geometry is used once", ctx.label, r));
        }
    }
    roots = std::move(unique_roots);
    std::vector<BufferBytes> buffers(model.buffers.size());
    for (std::size_t i = 0; i < buffers.size(); ++i) {
        const bool in_place = i < facts.in_place_length.size() && facts.in_place_length[i] >= 0;
        buffers[i] = in_place ? BufferBytes{reinterpret_cast<const unsigned char*>(bytes.data()) + facts.bin_offset,
                                            static_cast<std::size_t>(facts.in_place_length[i])}
                              : BufferBytes{model.buffers[i].data.data(), model.buffers[i].data.size()};
    }
    const Cutouts cutouts = read_cutouts(ctx, model, buffers, capture, scene);
    Flattener flat{ctx, model, facts, buffers, options.max_memory_bytes, scene, cutouts};
    flat.traverse(roots);
    // A model whose cut-out materials no triangle uses costs what an opaque one does.
    if (std::none_of(scene.triangle_cutout.begin(), scene.triangle_cutout.end(),
                     [](std::uint32_t c) { return c != kNoCutout; })) {
        scene.triangle_cutout.clear();
        scene.texcoords.clear();
        scene.vertex_alpha.clear();
        scene.cutout_materials.clear();
        scene.alpha_textures.clear();
    } else {
        scene.pad_cutout_arrays();
    }
    if (flat.skipped_points_lines)
        scene.warnings.push_back(fmt::format("{}: {} point/line primitives skipped (they cast no shadows)", ctx.label,
                                             flat.skipped_points_lines));
    if (flat.degenerate)
        scene.warnings.push_back(fmt::format("{}: {} zero-area triangles dropped", ctx.label, flat.degenerate));
    return scene;
}

}  // namespace penumbra
