// A cut-out's coverage (glTF 2.0 3.9.4) as common/alpha_coverage.cpp samples it: the texel
// grid of Vulkan's addressing (u*W - 0.5 for LINEAR, floor(u*W) for NEAREST) and its wrap modes,
// factor x texture alpha x COLOR_0 alpha against alphaCutoff; with kMipmaps, at the mip level a
// minified footprint selects. Included by the passes that draw
// a scene with cut-outs; the includer declares `set`'s layout through these bindings.
layout(std430, set = 0, binding = kBindingCutoutOfTriangle) readonly buffer CutoutOfTriangle { uint cutout_of_triangle[]; };
layout(std430, set = 0, binding = kBindingCutoutMaterials) readonly buffer CutoutMaterials { CutoutMaterialGpu cutout_materials[]; };
layout(std430, set = 0, binding = kBindingCutoutTexels) readonly buffer CutoutTexels { uint cutout_texels[]; };

// A technique's blend cutout(T) for BLEND materials; -1 (the default, the camera pass's): opaque.
layout(constant_id = 0) const float kBlendCutoff = -1.0;
// alpha.mipmaps: the shadow pass samples the mip level its footprint selects, as an engine's
// mipmapped alpha test does; false (the default, the camera pass's): level 0, as the truth.
layout(constant_id = 1) const bool kMipmaps = false;

int cutout_wrap(int i, int size, uint mode) {
    if (mode == 1u) return clamp(i, 0, size - 1);  // clamp_to_edge
    if (mode == 2u) {                               // mirrored_repeat
        const int period = 2 * size;
        const int t = ((i % period) + period) % period;
        return t < size ? t : period - 1 - t;
    }
    return ((i % size) + size) % size;  // repeat
}

// Texel (i, j) of the level whose first texel and size are given.
float cutout_texel(CutoutMaterialGpu m, uint first, ivec2 size, int i, int j) {
    const uint k = first + uint(cutout_wrap(j, size.y, (m.texture.w >> kCutoutWrapTShift) & 3u)) * uint(size.x) +
                   uint(cutout_wrap(i, size.x, (m.texture.w >> kCutoutWrapSShift) & 3u));
    return float((cutout_texels[k >> 1] >> ((k & 1u) * 16u)) & 0xFFFFu) * (1.0 / 65535.0);
}

// Level `level` of a texture at t (after its transform): its mip levels follow level 0 in the
// texel buffer, each half the one before (rounded down, at least 1), as raster/cutouts.cpp makes them.
float cutout_sample(CutoutMaterialGpu m, int level, vec2 t, bool nearest) {
    uint first = m.texture.x;
    ivec2 size = ivec2(m.texture.yz);
    for (int l = 0; l < level; ++l) {
        first += uint(size.x * size.y);
        size = max(size / 2, ivec2(1));
    }
    const vec2 x = clamp(t, vec2(-1e6), vec2(1e6)) * vec2(size);
    if (nearest) {
        const ivec2 i = ivec2(floor(x));
        return cutout_texel(m, first, size, i.x, i.y);
    }
    const vec2 s = x - 0.5, f = s - floor(s);
    const ivec2 i = ivec2(floor(s));
    const float top = mix(cutout_texel(m, first, size, i.x, i.y), cutout_texel(m, first, size, i.x + 1, i.y), f.x);
    const float bottom =
        mix(cutout_texel(m, first, size, i.x, i.y + 1), cutout_texel(m, first, size, i.x + 1, i.y + 1), f.x);
    return mix(top, bottom, f.y);
}

// Whether triangle prim's surface is opaque at texture coordinate uv with COLOR_0 alpha there;
// duv_dx, duv_dy: uv's derivatives across the target's pixels, for kMipmaps (Vulkan 1.3 section
// 16.5: rho the longer of the two in texels, lambda = log2(rho); NEAREST mip levels at
// floor(lambda + 0.5), LINEAR between floor(lambda) and the next).
bool cutout_opaque(uint prim, vec2 uv, float vertex_alpha, vec2 duv_dx, vec2 duv_dy) {
    const uint c = cutout_of_triangle[prim];
    if (c == kNoPrim) return true;
    const CutoutMaterialGpu m = cutout_materials[c];
    float coverage = m.row1.w * vertex_alpha;
    if ((m.texture.w & kCutoutHasTexture) != 0u) {
        const vec2 t = vec2(dot(m.row0.xyz, vec3(uv, 1.0)), dot(m.row1.xyz, vec3(uv, 1.0)));
        const uint mips = (m.texture.w >> kCutoutMipShift) & 3u;
        float lambda = 0.0;
        if (kMipmaps && mips != 0u) {
            const vec2 size = vec2(m.texture.yz);
            const vec2 dx = vec2(dot(m.row0.xy, duv_dx), dot(m.row1.xy, duv_dx)) * size;
            const vec2 dy = vec2(dot(m.row0.xy, duv_dy), dot(m.row1.xy, duv_dy)) * size;
            lambda = log2(max(max(length(dx), length(dy)), 1e-30));
        }
        if (lambda <= 0.0) {
            coverage *= cutout_sample(m, 0, t, (m.texture.w & kCutoutNearest) != 0u);
        } else {
            const bool nearest = (m.texture.w & kCutoutMinNearest) != 0u;
            const int top = int(floor(log2(float(max(m.texture.y, m.texture.z)))));
            lambda = min(lambda, float(top));
            if (mips == 1u) {
                coverage *= cutout_sample(m, int(floor(lambda + 0.5)), t, nearest);
            } else {
                const int d = int(floor(lambda));
                coverage *= mix(cutout_sample(m, d, t, nearest), cutout_sample(m, min(d + 1, top), t, nearest),
                                lambda - float(d));
            }
        }
    }
    return coverage >= ((m.texture.w & kCutoutBlend) != 0u ? kBlendCutoff : m.row0.w);
}
