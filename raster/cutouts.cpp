#include "raster/cutouts.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <limits>

#include "common/errors.h"
#include "raster/technique_family.h"
#include "shaders/penumbra_shared.h"

namespace penumbra::raster {

namespace {

// A texture's level 0 and its mip levels after it, each a 2x2 box average of the one before
// (half its size, rounded down, at least 1: what glGenerateMipmap and engines' loaders make),
// down to 1x1.
void append_mip_chain(const AlphaTexture& t, std::vector<std::uint16_t>& out) {
    std::vector<std::uint16_t> level = t.alpha;
    int w = t.width, h = t.height;
    while (true) {
        out.insert(out.end(), level.begin(), level.end());
        if (w == 1 && h == 1) return;
        const int nw = std::max(w / 2, 1), nh = std::max(h / 2, 1);
        std::vector<std::uint16_t> next(static_cast<std::size_t>(nw) * static_cast<std::size_t>(nh));
        for (int y = 0; y < nh; ++y)
            for (int x = 0; x < nw; ++x) {
                std::uint32_t sum = 0;
                for (int dy = 0; dy < 2; ++dy)
                    for (int dx = 0; dx < 2; ++dx)
                        sum +=
                            level[static_cast<std::size_t>(std::min(2 * y + dy, h - 1)) * static_cast<std::size_t>(w) +
                                  static_cast<std::size_t>(std::min(2 * x + dx, w - 1))];
                next[static_cast<std::size_t>(y) * static_cast<std::size_t>(nw) + static_cast<std::size_t>(x)] =
                    static_cast<std::uint16_t>((sum + 2) / 4);
            }
        level = std::move(next);
        w = nw;
        h = nh;
    }
}

// The minFilter's mip mode and texel filter (glTF's codes: 9728 NEAREST, 9729 LINEAR, 9984 ...
// 9987 the MIPMAP ones); absent, LINEAR_MIPMAP_LINEAR, three.js's and most loaders' default.
std::uint32_t mip_flags(int min_filter) {
    switch (min_filter) {
        case 9728: return gpu::kCutoutMinNearest;
        case 9729: return 0u;
        case 9984: return (1u << gpu::kCutoutMipShift) | gpu::kCutoutMinNearest;
        case 9985: return 1u << gpu::kCutoutMipShift;
        case 9986: return (2u << gpu::kCutoutMipShift) | gpu::kCutoutMinNearest;
        default: return 2u << gpu::kCutoutMipShift;
    }
}

constexpr std::array<BindingDecl, 5> kCutoutBindings = {
    {{gpu::kBindingCutoutUv, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
     {gpu::kBindingCutoutAlpha, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
     {gpu::kBindingCutoutOfTriangle, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
     {gpu::kBindingCutoutMaterials, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
     {gpu::kBindingCutoutTexels, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER}}};
static_assert(sizeof(gpu::CutoutMaterialGpu) == 48);
static_assert(kNoCutout == gpu::kNoPrim);
}  // namespace

std::span<const BindingDecl> cutout_bindings() {
    return kCutoutBindings;
}

void upload_cutouts(SceneOnGpu& s) {
    const Scene& scene = s.scenario.scene;
    s.has_cutouts = scene.has_cutouts();
    s.has_masks = scene.has_masks();
    // Nothing of them depends on the eye: a camera moved (RasterSession::set_camera) keeps them,
    // and the set whose layout the families' pipelines were made with.
    if (!s.has_cutouts || s.cutout_set) return;
    const VulkanContext& ctx = s.ctx;
    std::vector<float> uv(2 * scene.texcoords.size());
    for (std::size_t i = 0; i < scene.texcoords.size(); ++i) {
        uv[2 * i] = scene.texcoords[i].x;
        uv[2 * i + 1] = scene.texcoords[i].y;
    }
    std::vector<gpu::CutoutMaterialGpu> materials;
    std::vector<std::uint32_t> first_texel;  // per texture: its level 0, its mip levels after it
    std::vector<std::uint16_t> texels;
    for (const AlphaTexture& t : scene.alpha_textures) {
        first_texel.push_back(static_cast<std::uint32_t>(texels.size()));
        append_mip_chain(t, texels);
    }
    if (texels.size() > std::numeric_limits<std::uint32_t>::max())
        throw InputError(
            fmt::format("{}: the cut-outs' images and their mip levels pass 2^32 texels", s.scenario.label));
    std::vector<std::uint32_t> packed((texels.size() + 1) / 2 + 1, 0u);
    for (std::size_t at = 0; at < texels.size(); ++at) packed[at >> 1] |= std::uint32_t(texels[at]) << ((at & 1) * 16);
    for (const CutoutMaterial& m : scene.cutout_materials) {
        const glm::dmat3& x = m.uv_transform;  // column-major: x[column][row]
        gpu::CutoutMaterialGpu g;
        g.row0 = glm::vec4(x[0][0], x[1][0], x[2][0], m.cutoff);
        g.row1 = glm::vec4(x[0][1], x[1][1], x[2][1], m.factor_alpha);
        std::uint32_t flags = (m.nearest ? gpu::kCutoutNearest : 0u) |
                              (m.mode == AlphaMode::blend ? gpu::kCutoutBlend : 0u) | mip_flags(m.min_filter) |
                              (static_cast<std::uint32_t>(m.wrap_s) << gpu::kCutoutWrapSShift) |
                              (static_cast<std::uint32_t>(m.wrap_t) << gpu::kCutoutWrapTShift);
        g.texture = glm::uvec4(0u, 1u, 1u, flags);
        if (m.texture >= 0) {
            const AlphaTexture& t = scene.alpha_textures[static_cast<std::size_t>(m.texture)];
            g.texture = glm::uvec4(first_texel[static_cast<std::size_t>(m.texture)], t.width, t.height,
                                   flags | gpu::kCutoutHasTexture);
        }
        materials.push_back(g);
    }
    constexpr VkBufferUsageFlags kStorage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
    s.cutout_uv = upload(ctx, uv.data(), uv.size() * sizeof(float), kStorage);
    s.cutout_alpha = upload(ctx, scene.vertex_alpha.data(), scene.vertex_alpha.size() * sizeof(float), kStorage);
    s.cutout_of_triangle =
        upload(ctx, scene.triangle_cutout.data(), scene.triangle_cutout.size() * sizeof(std::uint32_t), kStorage);
    s.cutout_materials = upload(ctx, materials.data(), materials.size() * sizeof(gpu::CutoutMaterialGpu), kStorage);
    s.cutout_texels = upload(ctx, packed.data(), packed.size() * sizeof(std::uint32_t), kStorage);
    s.cutout_set = std::make_unique<DescriptorSets>(ctx, kCutoutBindings,
                                                    VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT);
    s.cutout_set->reserve(1);
    std::vector<DescriptorResource> resources;
    append_cutout_resources(s, resources);
    s.cutout_set->write(0, resources);
}

void append_cutout_resources(const SceneOnGpu& s, std::vector<DescriptorResource>& resources) {
    for (const GpuBuffer* b :
         {&s.cutout_uv, &s.cutout_alpha, &s.cutout_of_triangle, &s.cutout_materials, &s.cutout_texels}) {
        DescriptorResource r;
        r.buffer = {b->buffer.get(), 0, VK_WHOLE_SIZE};
        resources.push_back(r);
    }
}

std::vector<std::uint32_t> alpha_spec(const Technique& t) {
    const float cutoff = t.blend == Blend::cutout ? static_cast<float>(t.blend_cutoff) : -1.0f;
    std::uint32_t bits = 0;
    std::memcpy(&bits, &cutoff, sizeof bits);
    return {bits, t.alpha_mipmaps ? 1u : 0u};
}

void check_alpha_rules(const SceneOnGpu& s, const Technique& t, const std::string& family) {
    if (s.has_masks) refuse_cutouts(s, family);
    if (s.has_cutouts && t.blend != Blend::opaque)
        throw InputError(fmt::format("{}: technique.blend \"{}\": {} draws blended materials opaque only",
                                     s.scenario.label, to_string(t.blend, t.blend_cutoff), family));
}

void refuse_cutouts(const SceneOnGpu& s, const std::string& what) {
    const Scene& scene = s.scenario.scene;
    std::string material = "a material";
    for (const CutoutMaterial& m : scene.cutout_materials)
        if (m.mode == AlphaMode::mask) {
            material = m.label;
            break;
        }
    throw InputError(fmt::format(
        "{}: {} cannot draw cut-outs ({} is alphaMode MASK, and {} more); see docs/raster.md, "
        "\"Cut-outs\"",
        s.scenario.label, what, material, scene.cutout_materials.empty() ? 0 : scene.cutout_materials.size() - 1));
}

}  // namespace penumbra::raster
