// A cut-out's coverage (glTF 2.0 3.9.4) as common/alpha_coverage.cpp samples it: the texel
// grid of Vulkan's addressing (u*W - 0.5 for LINEAR, floor(u*W) for NEAREST) and its wrap modes,
// factor x texture alpha x COLOR_0 alpha against alphaCutoff. Included by the passes that draw
// a scene with cut-outs; the includer declares `set`'s layout through these bindings.
layout(std430, set = 0, binding = kBindingCutoutOfTriangle) readonly buffer CutoutOfTriangle { uint cutout_of_triangle[]; };
layout(std430, set = 0, binding = kBindingCutoutMaterials) readonly buffer CutoutMaterials { CutoutMaterialGpu cutout_materials[]; };
layout(std430, set = 0, binding = kBindingCutoutTexels) readonly buffer CutoutTexels { uint cutout_texels[]; };

// A technique's blend cutout(T) for BLEND materials; -1 (the default, the camera pass's): opaque.
layout(constant_id = 0) const float kBlendCutoff = -1.0;

int cutout_wrap(int i, int size, uint mode) {
    if (mode == 1u) return clamp(i, 0, size - 1);  // clamp_to_edge
    if (mode == 2u) {                               // mirrored_repeat
        const int period = 2 * size;
        const int t = ((i % period) + period) % period;
        return t < size ? t : period - 1 - t;
    }
    return ((i % size) + size) % size;  // repeat
}

float cutout_texel(CutoutMaterialGpu m, int i, int j) {
    const int w = int(m.texture.y), h = int(m.texture.z);
    const uint k = m.texture.x + uint(cutout_wrap(j, h, (m.texture.w >> kCutoutWrapTShift) & 3u)) * uint(w) +
                   uint(cutout_wrap(i, w, (m.texture.w >> kCutoutWrapSShift) & 3u));
    return float((cutout_texels[k >> 1] >> ((k & 1u) * 16u)) & 0xFFFFu) * (1.0 / 65535.0);
}

// Whether triangle prim's surface is opaque at texture coordinate uv with COLOR_0 alpha there.
bool cutout_opaque(uint prim, vec2 uv, float vertex_alpha) {
    const uint c = cutout_of_triangle[prim];
    if (c == kNoPrim) return true;
    const CutoutMaterialGpu m = cutout_materials[c];
    float coverage = m.row1.w * vertex_alpha;
    if ((m.texture.w & kCutoutHasTexture) != 0u) {
        const vec2 t = vec2(dot(m.row0.xyz, vec3(uv, 1.0)), dot(m.row1.xyz, vec3(uv, 1.0)));
        const vec2 x = clamp(t, vec2(-1e6), vec2(1e6)) * vec2(m.texture.yz);
        if ((m.texture.w & kCutoutNearest) != 0u) {
            const ivec2 i = ivec2(floor(x));
            coverage *= cutout_texel(m, i.x, i.y);
        } else {
            const vec2 s = x - 0.5, f = s - floor(s);
            const ivec2 i = ivec2(floor(s));
            const float top = mix(cutout_texel(m, i.x, i.y), cutout_texel(m, i.x + 1, i.y), f.x);
            const float bottom = mix(cutout_texel(m, i.x, i.y + 1), cutout_texel(m, i.x + 1, i.y + 1), f.x);
            coverage *= mix(top, bottom, f.y);
        }
    }
    return coverage >= ((m.texture.w & kCutoutBlend) != 0u ? kBlendCutoff : m.row0.w);
}
