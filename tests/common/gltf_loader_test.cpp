// glTF input: topology, hierarchy and transforms are read exactly; malformed files are
// refused with the file and element named.
#include "common/gltf_loader.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cctype>
#include <cstring>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include "common/errors.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

using test::GltfFixture;
using test::TempDir;

std::string error_of(const std::filesystem::path& file, GltfLoadOptions options = {}) {
    try {
        load_gltf(file, options);
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

TEST(GltfLoader, ReadsIndexedTrianglesWithNodeTransformsInDouble) {
    TempDir dir;
    GltfFixture g;
    g.doc["nodes"][0]["translation"] = {1e7, 0.25, -3};
    g.doc["nodes"][0]["scale"] = {2, 2, 2};
    Scene s = load_gltf(g.write(dir));
    ASSERT_EQ(s.triangle_count(), 2u);
    // (1, 0, -1) * 2 + (1e7, 0.25, -3): representable exactly in double, not in float.
    const glm::dvec3& p = s.positions[s.triangles[0][2]];
    EXPECT_EQ(p, glm::dvec3(1e7 + 2, 0.25, -5));
    EXPECT_EQ(s.double_sided[0], 0);
}

TEST(GltfLoader, ComposesTheHierarchyAndFlipsWindingUnderMirrors) {
    TempDir dir;
    GltfFixture g;
    g.doc["nodes"] = {{{"children", {1}}, {"translation", {0, 10, 0}}}, {{"mesh", 0}, {"scale", {-1, 1, 1}}}};
    Scene s = load_gltf(g.write(dir));
    ASSERT_EQ(s.triangle_count(), 2u);
    for (std::size_t t = 0; t < 2; ++t) {
        glm::dvec3 a = s.positions[s.triangles[t][0]], b = s.positions[s.triangles[t][1]],
                   c = s.positions[s.triangles[t][2]];
        EXPECT_EQ(a.y, 10.0);
        // The fixture's quad faces +Y (CCW seen from above); mirrored, it must still face +Y.
        EXPECT_GT(glm::cross(b - a, c - a).y, 0.0) << "triangle " << t;
    }
}

TEST(GltfLoader, ExpandsStripsAndFansSkipsLinesAndHonoursDoubleSided) {
    TempDir dir;
    GltfFixture g;
    // Same 4 vertices as a strip (0 1 3 2 -> 2 triangles) and as a fan (0 1 2 3 -> 2 triangles).
    g.doc["meshes"][0]["primitives"] = {{{"attributes", {{"POSITION", 0}}}, {"mode", 5}, {"material", 0}},
                                        {{"attributes", {{"POSITION", 0}}}, {"mode", 6}},
                                        {{"attributes", {{"POSITION", 0}}}, {"mode", 1}}};
    g.doc["materials"] = {{{"doubleSided", true}}};
    Scene s = load_gltf(g.write(dir));
    EXPECT_EQ(s.triangle_count(), 4u);
    EXPECT_EQ(s.double_sided[0], 1);
    EXPECT_EQ(s.double_sided[2], 0);
    ASSERT_EQ(s.warnings.size(), 1u);
    EXPECT_NE(s.warnings[0].find("1 point/line primitives skipped"), std::string::npos);
    // Strip triangle p is (p, p + 1 + p%2, p + 2 - p%2) per glTF 3.7.2.1: triangle 1 is (1, 3, 2).
    EXPECT_EQ(s.triangles[1], glm::u32vec3(1, 3, 2));
    // Fan triangles are (v[i], v[i+1], v0).
    EXPECT_EQ(s.triangles[2] - glm::u32vec3(4), glm::u32vec3(1, 2, 0));
}

TEST(GltfLoader, ReadsBinaryGlb) {
    Scene s = load_gltf(std::filesystem::path(PENUMBRA_SOURCE_DIR) / "data/default/scene.glb");
    EXPECT_GT(s.triangle_count(), 1000u);
    EXPECT_LT(s.bounds.lo.y, 1e-9);
}

// A .glb of `doc` over `bin` (its BIN chunk, padded to 4 bytes).
std::filesystem::path write_glb(const TempDir& dir, nlohmann::json doc, std::vector<unsigned char> bin,
                                const std::string& name = "scene.glb") {
    std::string text = doc.dump();
    text.resize((text.size() + 3) / 4 * 4, ' ');
    bin.resize((bin.size() + 3) / 4 * 4, 0);
    const auto json_len = static_cast<std::uint32_t>(text.size()), bin_len = static_cast<std::uint32_t>(bin.size());
    const std::uint32_t head[5] = {0x46546C67u, 2u, 28 + json_len + bin_len, json_len, 0x4E4F534Au};
    const std::uint32_t bin_head[2] = {bin_len, 0x004E4942u};
    std::string bytes(reinterpret_cast<const char*>(head), sizeof head);
    bytes += text;
    bytes.append(reinterpret_cast<const char*>(bin_head), sizeof bin_head);
    bytes.append(bin.begin(), bin.end());
    test::write_text(dir / name, bytes);
    return dir / name;
}

// The .glb's buffers are read where they lie in the file (tinygltf is handed 4-byte buffers);
// every buffer without a uri is the BIN chunk's first bytes, as tinygltf reads it.
TEST(GltfLoader, ReadsAGlbsBufferInPlace) {
    TempDir dir;
    GltfFixture g;
    const Scene expected = load_gltf(g.write(dir));
    nlohmann::json doc = g.doc;
    doc["buffers"] = {{{"byteLength", 48}}, {{"byteLength", g.bin.size()}}};
    doc["bufferViews"][1]["buffer"] = 1;  // the indices through a second buffer: the same bytes
    const Scene s = load_gltf(write_glb(dir, doc, g.bin));
    EXPECT_EQ(s.positions, expected.positions);
    EXPECT_EQ(s.triangles, expected.triangles);
    // An image in a bufferView (a textured model): tinygltf indexes the buffer's bytes there,
    // so the buffers are copied as before, with the same scene.
    nlohmann::json textured = doc;
    textured["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", 40}, {"byteLength", 8}});
    textured["images"] = {{{"bufferView", 2}, {"mimeType", "image/png"}}};
    const Scene t = load_gltf(write_glb(dir, textured, g.bin, "textured.glb"));
    EXPECT_EQ(t.positions, expected.positions);
    EXPECT_EQ(t.triangles, expected.triangles);
    // A buffer longer than the chunk is still refused, by tinygltf, as before.
    doc["buffers"][1]["byteLength"] = g.bin.size() + 8;
    EXPECT_NE(error_of(write_glb(dir, doc, g.bin)).find("Invalid `byteLength'"), std::string::npos);
    // A view past the buffer's own length (not the chunk's) is refused with the buffer's length.
    doc["buffers"][1]["byteLength"] = 52;
    EXPECT_EQ(error_of(write_glb(dir, doc, g.bin)),
              "scene.glb: bufferViews[1]: byteOffset + byteLength exceeds buffer 1 (48 + 12 > 52 bytes)");
}

// The loader checks, transforms and keeps triangles in parallel (in blocks of a fixed size) and
// reads the file in pieces: the scene, and the element a refusal names, must not depend on the
// thread count. A 600 x 600 grid (720k triangles in 44 blocks, a 13 MB file in 2 pieces), every
// seventh row of vertices folded onto the one before (zero-area triangles dropped), mirrored.
TEST(GltfLoader, GivesTheSameSceneWhateverTheThreadCount) {
    constexpr std::uint32_t n = 600;
    std::vector<float> pos;
    for (std::uint32_t j = 0; j <= n; ++j)
        for (std::uint32_t i = 0; i <= n; ++i) {
            const std::uint32_t row = j % 7 == 6 ? j - 1 : j;
            pos.insert(pos.end(), {float(i), 0.001f * float(i % 13), -float(row)});
        }
    std::vector<std::uint32_t> idx;
    for (std::uint32_t j = 0; j < n; ++j)
        for (std::uint32_t i = 0; i < n; ++i) {
            const std::uint32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 2, d = a + n + 1;
            idx.insert(idx.end(), {a, b, c, a, c, d});
        }
    std::vector<unsigned char> bin(pos.size() * 4 + idx.size() * 4);
    std::memcpy(bin.data(), pos.data(), pos.size() * 4);
    std::memcpy(bin.data() + pos.size() * 4, idx.data(), idx.size() * 4);
    GltfFixture g;
    nlohmann::json doc = g.doc;
    doc["nodes"][0]["scale"] = {-1, 1, 1};
    doc["accessors"][0]["count"] = pos.size() / 3;
    doc["accessors"][0].erase("min");
    doc["accessors"][0].erase("max");
    doc["accessors"][1]["count"] = idx.size();
    doc["accessors"][1]["componentType"] = 5125;
    doc["bufferViews"] = {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", pos.size() * 4}},
                          {{"buffer", 0}, {"byteOffset", pos.size() * 4}, {"byteLength", idx.size() * 4}}};
    doc["buffers"] = {{{"byteLength", bin.size()}}};
    TempDir dir;
    const auto file = write_glb(dir, doc, bin);
    ASSERT_GT(std::filesystem::file_size(file), 8u << 20);
    // Two vertices out of range: the first is named.
    std::vector<unsigned char> far = bin;
    const float huge = 1e30f;
    for (std::size_t v : {std::size_t(300000), std::size_t(20000)}) std::memcpy(far.data() + 12 * v, &huge, 4);
    const auto far_file = write_glb(dir, doc, far, "far.glb");
    auto load_with = [&](int threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
        return std::pair{load_gltf(file), error_of(far_file)};
    };
    const auto [one, one_error] = load_with(1);
    EXPECT_EQ(one.triangle_count(), 2u * n * n - 2u * n * (n / 7));
    ASSERT_EQ(one.warnings.size(), 1u);
    EXPECT_EQ(one.warnings[0], "scene.glb: " + std::to_string(2 * n * (n / 7)) + " zero-area triangles dropped");
    EXPECT_EQ(one_error.rfind("far.glb: meshes[0].primitives[0]: vertex 20000 lies at -1", 0), 0u) << one_error;
    for (int threads : {2, 5}) {
        SCOPED_TRACE(threads);
        const auto [many, many_error] = load_with(threads);
        EXPECT_EQ(many.positions, one.positions);
        EXPECT_EQ(many.triangles, one.triangles);
        EXPECT_EQ(many.double_sided, one.double_sided);
        EXPECT_EQ(many.triangle_node, one.triangle_node);
        EXPECT_EQ(many.bounds.lo, one.bounds.lo);
        EXPECT_EQ(many.bounds.hi, one.bounds.hi);
        EXPECT_EQ(many.warnings, one.warnings);
        EXPECT_EQ(many_error, one_error);
    }
}

TEST(GltfLoader, RefusesAccessorsOutsideTheirBufferView) {
    TempDir dir;
    GltfFixture g;
    g.doc["accessors"][0]["count"] = 5;
    EXPECT_EQ(error_of(g.write(dir)),
              "scene.gltf: accessors[0]: byteOffset + count*stride exceeds bufferView 0 (60 > 48 bytes)");
}

TEST(GltfLoader, RefusesOutOfRangeIndices) {
    TempDir dir;
    GltfFixture g;
    g.bin[48] = 9;  // first index
    EXPECT_NE(error_of(g.write(dir))
                  .find("meshes[0].primitives[0].indices: index 9 (element 0 of accessors[1]) "
                        "is out of range: POSITION has 4 vertices"),
              std::string::npos);
}

TEST(GltfLoader, RefusesNonFinitePositionsAndCycles) {
    TempDir dir;
    GltfFixture g;
    float inf = std::numeric_limits<float>::infinity();
    std::memcpy(g.bin.data() + 4, &inf, 4);
    EXPECT_NE(error_of(g.write(dir))
                  .find("accessors[0]: element 0 of meshes[0].primitives[0].attributes.POSITION "
                        "is not finite"),
              std::string::npos);
    GltfFixture c;
    c.doc["nodes"] = {{{"mesh", 0}, {"children", {1}}}, {{"children", {2}}}, {{"children", {1}}}};
    EXPECT_NE(error_of(c.write(dir)).find("scene.gltf: nodes["), std::string::npos);
    GltfFixture self;
    self.doc["nodes"][0]["children"] = {0};
    EXPECT_EQ(error_of(self.write(dir)), "scene.gltf: nodes[0]: node hierarchy has a cycle (node is its own child)");
}

TEST(GltfLoader, KeepsExternalFilesInsideTheScenesFolder) {
    TempDir dir;
    std::filesystem::create_directories(dir / "sub");
    for (const char* uri : {"../scene.bin", "/etc/passwd", "%2e%2e/scene.bin", "file:///etc/passwd"}) {
        GltfFixture g;
        g.doc["buffers"][0]["uri"] = uri;
        auto file = g.write(dir, "sub/scene.gltf");
        std::string err = error_of(file);
        EXPECT_NE(err.find("scene.gltf: buffers[0].uri:"), std::string::npos) << uri << " -> " << err;
        EXPECT_NE(err.find("--allow-external-paths"), std::string::npos) << err;
    }
    GltfFixture g;
    g.doc["buffers"][0]["uri"] = "../scene.bin";
    GltfLoadOptions allow;
    allow.allow_external_paths = true;
    EXPECT_EQ(load_gltf(g.write(dir, "sub/scene.gltf"), allow).triangle_count(), 2u);
}

// The malformed files of Debian's assimp-testmodels: each must be refused cleanly, with the file,
// the glTF element and the reason named (not the file alone).
struct MalformedModel {
    const char* file;    // under /usr/share/assimp/models/glTF2
    const char* reason;  // the element and what is wrong with it
};

class MalformedAssimpModel : public ::testing::TestWithParam<MalformedModel> {};

TEST_P(MalformedAssimpModel, IsRefusedWithTheFileTheElementAndTheReasonNamed) {
    auto file = test::assimp_model(GetParam().file);
    // Not optional: scripts/install-deps.sh installs it, and a missing model must not pass.
    ASSERT_FALSE(file.empty()) << "assimp-testmodels is not installed (scripts/install-deps.sh installs it)";
    std::string err = error_of(file);
    EXPECT_NE(err.find(file.filename().string() + ": " + GetParam().reason), std::string::npos) << "message: " << err;
}

INSTANTIATE_TEST_SUITE_P(
    AssimpTestModels, MalformedAssimpModel,
    ::testing::Values(
        MalformedModel{"IndexOutOfRange/IndexOutOfRange.gltf",
                       "meshes[0].primitives[0].indices: index 255 (element 0 of accessors[0]) is out of range"},
        MalformedModel{"IndexOutOfRange/AllIndicesOutOfRange.gltf",
                       "meshes[0].primitives[0].indices: index 65535 (element 0 of accessors[0]) is out of range"},
        MalformedModel{"MissingBin/BoxTextured.gltf", "not a valid glTF 2.0 file: File not found : BoxTextured0.bin"},
        MalformedModel{"BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb",
                       "accessors[2]: element 0 of meshes[0].primitives[0].attributes.POSITION is not finite"},
        MalformedModel{"RecursiveNodes/RecursiveNodes.gltf", "nodes[0]: node hierarchy has a cycle"},
        MalformedModel{"wrongTypes/badArray.gltf", "meshes[0].primitives: expected an array of objects"},
        MalformedModel{"wrongTypes/badNumber.gltf", "materials[0].normalTexture.index: missing required property"},
        MalformedModel{"wrongTypes/badObject.gltf", "materials[0].pbrMetallicRoughness: expected an object"},
        MalformedModel{"wrongTypes/badString.gltf", "scenes[0].name: expected a string, got 42"},
        MalformedModel{
            "wrongTypes/badUint.gltf",
            "materials[0].pbrMetallicRoughness.baseColorTexture.index: expected a non-negative integer, got -1"},
        MalformedModel{
            "wrongTypes/badExtension.gltf",
            "materials[0].pbrMetallicRoughness.baseColorTexture.extensions.KHR_texture_transform: expected an "
            "object"},
        MalformedModel{"SchemaFailures/sceneWrongType.gltf", "scene: expected a non-negative integer, got \"hello\""}),
    [](const auto& p) {
        std::string name = std::filesystem::path(p.param.file).stem().string();
        for (char& c : name)
            if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
        return name;
    });

}  // namespace
}  // namespace penumbra
