// A material's alpha coverage, as glTF 2.0 defines it (section 3.9.4 "Alpha Coverage"):
// coverage = baseColorFactor.a x baseColorTexture.a (x COLOR_0.a), and a MASK material is
// opaque where coverage >= alphaCutoff, transparent elsewhere. The oracle judges every hit on a
// cut-out with it; the raster's shaders sample the same texels the same way.
#pragma once

#include <cstdint>
#include <filesystem>
#include <glm/mat3x3.hpp>
#include <glm/vec2.hpp>
#include <span>
#include <string>
#include <vector>

namespace penumbra {

enum class AlphaMode : std::uint8_t { opaque, mask, blend };
// glTF samplers' wrapS / wrapT (10497, 33071, 33648), as Vulkan's address modes define them.
enum class TextureWrap : std::uint8_t { repeat, clamp_to_edge, mirrored_repeat };

// A decoded image's alpha channel (1 where the image has none), row 0 at v = 0 (glTF 2.0 3.9.2),
// in 16-bit steps: an 8-bit alpha k reads k/255 exactly (k x 257 / 65535).
struct AlphaTexture {
    int width = 0, height = 0;
    std::vector<std::uint16_t> alpha;
    std::string label;  // for messages: "images[2] \"leaf.png\""
    double at(std::size_t i) const { return alpha[i] * (1.0 / 65535.0); }
};

// An image a glTF file names, for the decoder: a file, or bytes in memory (a bufferView, a data
// URI) with the mimeType that says their format.
struct EncodedImage {
    std::string label;           // what messages call it ("scene.glb: images[2] \"leaf\"")
    std::filesystem::path file;  // set for an external image
    std::span<const unsigned char> bytes;
    std::string mime_type;  // "image/png", "image/jpeg", ...
};
// Limits of a decoded image, checked from its header before any pixel is decoded.
inline constexpr int kMaxTextureSide = 16384;
inline constexpr std::uint64_t kMaxTexturePixels = std::uint64_t(64) << 20;
// Decodes an image's alpha, or throws InputError naming it (image_io registers the decoder,
// through OpenImageIO: the one module that links it).
using AlphaImageDecoder = AlphaTexture (*)(const EncodedImage&);
void set_alpha_image_decoder(AlphaImageDecoder decoder);
// The registered decoder; throws EnvironmentError where none is (a program without image_io).
AlphaImageDecoder alpha_image_decoder();

// A material whose coverage can hide part of a triangle (alphaMode MASK), or a blended one
// (BLEND), which the truth holds opaque and a technique's `blend` rule may draw otherwise
// (docs/raster.md, "Blended materials"). Opaque materials have none: every hit on them is a hit.
struct CutoutMaterial {
    AlphaMode mode = AlphaMode::mask;  // mask or blend
    double cutoff = 0.5;               // alphaCutoff (MASK)
    double factor_alpha = 1.0;         // baseColorFactor[3]
    int texture = -1;                  // Scene::alpha_textures index; -1: the factor (and COLOR_0) alone
    TextureWrap wrap_s = TextureWrap::repeat, wrap_t = TextureWrap::repeat;
    bool nearest = false;  // magFilter NEAREST (9728); LINEAR otherwise, as engines default
    int min_filter = -1;   // the sampler's minFilter (glTF's GL code), -1 absent: for alpha.mipmaps only
    // KHR_texture_transform: uv' = uv_transform * (uv, 1) (offset x rotation x scale).
    glm::dmat3 uv_transform{1.0};
    std::string label;  // "materials[3] \"Leaves\""
};

// What a point of a cut-out is: opaque or not, and whether that answer would change within
// `reach_texels` of the sampled point (a texel boundary or the cutoff's contour crosses there).
struct CoverageAnswer {
    bool opaque = true;
    bool ambiguous = false;
};

// The texture's alpha at uv with the material's wrap and filter (Vulkan 1.3 section 16.8, texel
// coordinates u*W - 0.5 for LINEAR, floor(u*W) for NEAREST).
double sample_alpha(const AlphaTexture& texture, const CutoutMaterial& m, glm::dvec2 uv);
// Coverage at texture coordinate uv (before uv_transform), vertex_alpha being COLOR_0's alpha there.
double coverage_at(const CutoutMaterial& m, const AlphaTexture* texture, glm::dvec2 uv, double vertex_alpha);
// Opaque where coverage >= cutoff; ambiguous where the answer differs at any corner of the
// square of half-side reach_texels around uv (in the texture's texels after uv_transform).
CoverageAnswer judge_coverage(const CutoutMaterial& m, const AlphaTexture* texture, glm::dvec2 uv, double vertex_alpha,
                              double reach_texels);

}  // namespace penumbra
