#include "raster/cutouts.h"

#include <fmt/format.h>

#include <array>
#include <cstring>

#include "common/errors.h"
#include "raster/technique_family.h"
#include "shaders/penumbra_shared.h"

namespace penumbra::raster {

namespace {
constexpr std::array<BindingDecl, 5> kCutoutBindings = {{{gpu::kBindingCutoutUv, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
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
    if (!s.has_cutouts) return;
    const VulkanContext& ctx = s.ctx;
    std::vector<float> uv(2 * scene.texcoords.size());
    for (std::size_t i = 0; i < scene.texcoords.size(); ++i) {
        uv[2 * i] = scene.texcoords[i].x;
        uv[2 * i + 1] = scene.texcoords[i].y;
    }
    std::vector<gpu::CutoutMaterialGpu> materials;
    std::vector<std::uint32_t> first_texel;  // per texture
    std::size_t texels = 0;
    for (const AlphaTexture& t : scene.alpha_textures) {
        first_texel.push_back(static_cast<std::uint32_t>(texels));
        texels += t.alpha.size();
    }
    std::vector<std::uint32_t> packed((texels + 1) / 2 + 1, 0u);
    for (std::size_t k = 0, at = 0; k < scene.alpha_textures.size(); ++k)
        for (std::uint16_t a : scene.alpha_textures[k].alpha) {
            packed[at >> 1] |= std::uint32_t(a) << ((at & 1) * 16);
            ++at;
        }
    for (const CutoutMaterial& m : scene.cutout_materials) {
        const glm::dmat3& x = m.uv_transform;  // column-major: x[column][row]
        gpu::CutoutMaterialGpu g;
        g.row0 = glm::vec4(x[0][0], x[1][0], x[2][0], m.cutoff);
        g.row1 = glm::vec4(x[0][1], x[1][1], x[2][1], m.factor_alpha);
        std::uint32_t flags = (m.nearest ? gpu::kCutoutNearest : 0u) | (m.mode == AlphaMode::blend ? gpu::kCutoutBlend : 0u) |
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
    for (const GpuBuffer* b : {&s.cutout_uv, &s.cutout_alpha, &s.cutout_of_triangle, &s.cutout_materials, &s.cutout_texels}) {
        DescriptorResource r;
        r.buffer = {b->buffer.get(), 0, VK_WHOLE_SIZE};
        resources.push_back(r);
    }
}

std::vector<std::uint32_t> blend_spec(const Technique& t) {
    const float cutoff = t.blend == Blend::cutout ? static_cast<float>(t.blend_cutoff) : -1.0f;
    std::uint32_t bits = 0;
    std::memcpy(&bits, &cutoff, sizeof bits);
    return {bits};
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
    throw InputError(fmt::format("{}: {} cannot draw cut-outs ({} is alphaMode MASK, and {} more); see docs/raster.md, "
                                 "\"Cut-outs\"",
                                 s.scenario.label, what, material,
                                 scene.cutout_materials.empty() ? 0 : scene.cutout_materials.size() - 1));
}

}  // namespace penumbra::raster
