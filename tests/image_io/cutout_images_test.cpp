// A MASK material's image as the loader reads it, through image_io's decoder: in a .glb's
// bufferView, in a data URI and in a file beside the scene; its sampler, texCoord set and
// KHR_texture_transform; and bad images refused naming the image, before anything is made.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <cstring>
#include <fstream>

#include "common/errors.h"
#include "common/gltf_loader.h"
#include "image_io/image_io.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

using test::GltfFixture;
using test::TempDir;

void put_u32(std::string& out, std::uint32_t v) {
    for (int s = 24; s >= 0; s -= 8) out.push_back(static_cast<char>((v >> s) & 0xFF));
}
void put_chunk(std::string& out, const char* type, const std::string& data) {
    put_u32(out, static_cast<std::uint32_t>(data.size()));
    const std::string body = std::string(type, 4) + data;
    out += body;
    put_u32(out, static_cast<std::uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(body.data()), body.size())));
}
// An 8-bit RGBA PNG (PNG spec, ISO/IEC 15948: IHDR, one IDAT of filter-0 rows, IEND) whose
// alpha is `alpha` (row-major, row 0 at the top); declared_* overrides the header's size.
std::string rgba_png(int width, int height, const std::vector<std::uint8_t>& alpha, int declared_w = 0,
                     int declared_h = 0) {
    std::string raw;
    for (int y = 0; y < height; ++y) {
        raw.push_back(0);
        for (int x = 0; x < width; ++x) raw += std::string{char(200), char(100), char(50), char(alpha[y * width + x])};
    }
    uLongf size = compressBound(raw.size());
    std::string z(size, '\0');
    compress(reinterpret_cast<Bytef*>(z.data()), &size, reinterpret_cast<const Bytef*>(raw.data()), raw.size());
    z.resize(size);
    std::string png("\x89PNG\r\n\x1a\n", 8), ihdr;
    put_u32(ihdr, static_cast<std::uint32_t>(declared_w ? declared_w : width));
    put_u32(ihdr, static_cast<std::uint32_t>(declared_h ? declared_h : height));
    ihdr += std::string{8, 6, 0, 0, 0};  // 8 bits, RGBA, deflate, no filter choice, no interlace
    put_chunk(png, "IHDR", ihdr);
    put_chunk(png, "IDAT", z);
    put_chunk(png, "IEND", "");
    return png;
}

std::string base64(const std::string& in) {
    static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    for (std::size_t i = 0; i < in.size(); i += 3) {
        const std::uint32_t n = (std::uint32_t(std::uint8_t(in[i])) << 16) |
                                (i + 1 < in.size() ? std::uint32_t(std::uint8_t(in[i + 1])) << 8 : 0) |
                                (i + 2 < in.size() ? std::uint32_t(std::uint8_t(in[i + 2])) : 0);
        out += k[(n >> 18) & 63];
        out += k[(n >> 12) & 63];
        out += i + 1 < in.size() ? k[(n >> 6) & 63] : '=';
        out += i + 2 < in.size() ? k[n & 63] : '=';
    }
    return out;
}

// The fixture's quad with TEXCOORD_0 (its x, -z) and a MASK material whose baseColorTexture
// is images[0], given by `image` (an image object without its source yet).
GltfFixture masked_quad(nlohmann::json image) {
    GltfFixture g;
    const float uv[] = {0, 0, 1, 0, 1, 1, 0, 1};
    const std::size_t at = g.bin.size();
    g.bin.resize(at + sizeof uv);
    std::memcpy(g.bin.data() + at, uv, sizeof uv);
    g.doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", at}, {"byteLength", sizeof uv}});
    g.doc["accessors"].push_back({{"bufferView", 2}, {"componentType", 5126}, {"count", 4}, {"type", "VEC2"}});
    g.doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = 2;
    g.doc["meshes"][0]["primitives"][0]["material"] = 0;
    g.doc["materials"] = {{{"name", "Leaves"},
                           {"alphaMode", "MASK"},
                           {"alphaCutoff", 0.4},
                           {"doubleSided", true},
                           {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}};
    g.doc["textures"] = {{{"source", 0}, {"sampler", 0}}};
    g.doc["samplers"] = {{{"magFilter", 9728}, {"wrapS", 33071}, {"wrapT", 33648}}};
    g.doc["images"] = {image};
    g.doc["buffers"][0]["byteLength"] = g.bin.size();
    return g;
}

const std::vector<std::uint8_t> kAlpha = {0, 255, 128, 64, 255, 0};  // 3 x 2

void expect_masked(const Scene& s) {
    ASSERT_TRUE(s.has_cutouts());
    ASSERT_EQ(s.cutout_materials.size(), 1u);
    const CutoutMaterial& m = s.cutout_materials[0];
    EXPECT_DOUBLE_EQ(m.cutoff, 0.4);
    EXPECT_TRUE(m.nearest);
    EXPECT_EQ(m.wrap_s, TextureWrap::clamp_to_edge);
    EXPECT_EQ(m.wrap_t, TextureWrap::mirrored_repeat);
    EXPECT_NE(m.label.find("materials[0] \"Leaves\""), std::string::npos) << m.label;
    ASSERT_EQ(s.alpha_textures.size(), 1u);
    const AlphaTexture& t = s.alpha_textures[0];
    ASSERT_EQ(t.width, 3);
    ASSERT_EQ(t.height, 2);
    for (std::size_t i = 0; i < kAlpha.size(); ++i) EXPECT_DOUBLE_EQ(t.at(i), kAlpha[i] / 255.0) << i;
    EXPECT_EQ(s.triangle_cutout, (std::vector<std::uint32_t>{0, 0}));
    ASSERT_EQ(s.texcoords.size(), 4u);
    EXPECT_EQ(s.texcoords[2], glm::vec2(1, 1));
    // Triangle 0's uv are (0, 0), (1, 0), (1, 1): barycentrics (b1, b2) give uv (b1 + b2, b2).
    EXPECT_TRUE(s.cutout_coverage(0, 0.5, 0.25, 1e-6).opaque);    // uv (0.75, 0.25): texel (2, 0), 128/255
    EXPECT_FALSE(s.cutout_coverage(0, 0.15, 0.75, 1e-6).opaque);  // uv (0.9, 0.75): texel (2, 1), 0
}

TEST(CutoutImages, AreReadFromABufferViewADataUriAndAFile) {
    TempDir dir;
    const std::string png = rgba_png(3, 2, kAlpha);
    {  // a .glb's bufferView
        GltfFixture g = masked_quad({{"bufferView", 3}, {"mimeType", "image/png"}});
        const std::size_t at = g.bin.size();
        g.bin.insert(g.bin.end(), png.begin(), png.end());
        g.doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", at}, {"byteLength", png.size()}});
        g.doc["buffers"] = {{{"byteLength", g.bin.size()}}};
        std::string text = g.doc.dump();
        text.resize((text.size() + 3) / 4 * 4, ' ');
        std::vector<unsigned char> bin = g.bin;
        bin.resize((bin.size() + 3) / 4 * 4, 0);
        const auto jl = static_cast<std::uint32_t>(text.size()), bl = static_cast<std::uint32_t>(bin.size());
        const std::uint32_t head[5] = {0x46546C67u, 2u, 28 + jl + bl, jl, 0x4E4F534Au}, bin_head[2] = {bl, 0x004E4942u};
        std::string bytes(reinterpret_cast<const char*>(head), sizeof head);
        bytes += text;
        bytes.append(reinterpret_cast<const char*>(bin_head), sizeof bin_head);
        bytes.append(bin.begin(), bin.end());
        test::write_text(dir / "scene.glb", bytes);
        expect_masked(load_gltf(dir / "scene.glb"));
    }
    expect_masked(load_gltf(masked_quad({{"uri", "data:image/png;base64," + base64(png)}}).write(dir, "data.gltf")));
    test::write_text(dir / "leaf.png", png);
    expect_masked(load_gltf(masked_quad({{"uri", "leaf.png"}}).write(dir, "file.gltf")));
    // An opaque material's image is never read: a missing file does not matter.
    GltfFixture opaque = masked_quad({{"uri", "missing.png"}});
    opaque.doc["materials"][0]["alphaMode"] = "OPAQUE";
    EXPECT_FALSE(load_gltf(opaque.write(dir, "opaque.gltf")).has_cutouts());
}

TEST(CutoutImages, ReadTheTextureTransformAndTheFactor) {
    TempDir dir;
    test::write_text(dir / "leaf.png", rgba_png(3, 2, kAlpha));
    GltfFixture g = masked_quad({{"uri", "leaf.png"}});
    g.doc["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = {1, 1, 1, 0.5};
    g.doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"] = {
        {"KHR_texture_transform", {{"offset", {0.25, 0}}, {"rotation", M_PI / 2}, {"scale", {2, 1}}}}};
    const Scene s = load_gltf(g.write(dir));
    const CutoutMaterial& m = s.cutout_materials.at(0);
    EXPECT_DOUBLE_EQ(m.factor_alpha, 0.5);
    const glm::dvec3 uv = m.uv_transform * glm::dvec3(0.1, 0, 1);  // scale, rotate, offset
    EXPECT_NEAR(uv.x, 0.25, 1e-12);
    EXPECT_NEAR(uv.y, 0.2, 1e-12);
}

std::string error_of(const std::filesystem::path& file) {
    try {
        load_gltf(file);
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

TEST(CutoutImages, BadImagesAreInputErrorsNamingTheImage) {
    TempDir dir;
    const std::string png = rgba_png(3, 2, kAlpha);
    test::write_text(dir / "truncated.png", png.substr(0, png.size() - 30));
    test::write_text(dir / "huge.png", rgba_png(3, 2, kAlpha, 65536, 65536));
    test::write_text(dir / "fake.jpg", "this is not a JPEG at all, nor any image");
    const std::vector<std::pair<nlohmann::json, std::string>> cases = {
        {{{"uri", "truncated.png"}}, "cannot read the pixels"},
        {{{"uri", "huge.png"}}, "65536x65536 pixels declared"},
        {{{"uri", "fake.jpg"}, {"mimeType", "image/jpeg"}}, "not an image"},
        {{{"uri", "data:image/jpeg;base64," + base64("not a jpeg either")}}, "not an image"},
        {{{"uri", "absent.png"}}, "absent.png"},
    };
    int k = 0;
    for (const auto& [image, what] : cases) {
        const std::string name = "case" + std::to_string(k++) + ".gltf";
        const std::string e = error_of(masked_quad(image).write(dir, name));
        EXPECT_NE(e.find(name + ": images[0]"), std::string::npos) << e;
        EXPECT_NE(e.find(what), std::string::npos) << e;
    }
    // Outside the scene's folder: refused, the buffers' rule; but only for an image penumbra
    // reads: an opaque material's texture outside the folder refuses nothing.
    const std::string outside = error_of(masked_quad({{"uri", "../leaf.png"}}).write(dir, "outside.gltf"));
    EXPECT_NE(outside.find("images[0].uri"), std::string::npos) << outside;
    EXPECT_NE(outside.find("outside the scene's folder"), std::string::npos) << outside;
    EXPECT_NE(error_of(masked_quad({{"uri", "/etc/leaf.png"}}).write(dir, "absolute.gltf")).find("absolute path"),
              std::string::npos);
    GltfFixture opaque = masked_quad({{"uri", "../../elsewhere/albedo.png"}});
    opaque.doc["materials"][0]["alphaMode"] = "OPAQUE";
    EXPECT_EQ(error_of(opaque.write(dir, "opaque_outside.gltf")), "");
    // The decoder is image_io's: a read of an ordinary image goes through the same module.
    test::write_text(dir / "leaf.png", png);
    EXPECT_EQ(read_image(dir / "leaf.png").width, 3);
}

}  // namespace
}  // namespace penumbra
