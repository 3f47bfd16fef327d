#version 460
#extension GL_GOOGLE_include_directive : require
// The moment families' passes (docs/raster.md, "Filterable shadow maps"), one dispatch per map
// layer: the moments pass turns each depth texel into the family's moments, and the two blur
// passes filter them with a separable Gaussian of radius kRadius texels (sigma = radius / 2),
// as an engine does before its lookup samples them bilinearly. The target's format is the
// family's (R32F, RG32F, RGBA32F, or RGBA16 UNORM for msm's 16-bit storage), so the store
// itself rounds what 16 bits cannot hold.
#include "penumbra_shared.h"
#include "filterable.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

// Ids must match kSpecMoment* in penumbra_shared.h.
layout(constant_id = 0) const uint kMomentKind = 0;  // kMoment*
layout(constant_id = 1) const uint kPass = 0;
layout(constant_id = 2) const uint kRadius = 0;

layout(binding = kBindingMomentSource) uniform sampler2DArray source;
layout(binding = kBindingMomentTarget) writeonly uniform image2DArray target;
layout(push_constant) uniform Push { MomentPassParams q; };

// Moment shadow maps' optimised 16-bit quantisation (Peters & Klein 2015, section 4.3): the
// four moments mapped affinely onto [0, 1]^4 (raster/filterable.cpp has the same matrix;
// raster/filterable_lookup.comp maps them back).
vec4 msm_optimise(vec4 b) {
    const mat4 a = mat4(-2.07224649, 13.7948857237, 0.105877704, 9.7924062118,  // column 1
                        32.23703778, -59.4683975703, -1.9077466311, -33.7652110555,
                        -68.571074599, 82.0359750338, 9.3496555107, 47.9456096605,
                        39.3703274134, -35.364903257, -6.6543490743, -23.9728048165);
    return a * b + vec4(0.035955884801, 0.0, 0.0, 0.0);
}

// The family's moments of depth d.
vec4 warp(float d) {
    if (kMomentKind == kMomentVsm) return vec4(d, d * d, 0.0, 0.0);
    if (kMomentKind == kMomentMsm) {
        vec4 b = vec4(d, d * d, d * d * d, d * d * d * d);
        return q.warp.z > 0.5 ? clamp(msm_optimise(b), 0.0, 1.0) : b;
    }
    if (kMomentKind == kMomentEsm) return vec4(exp(q.warp.x * d), 0.0, 0.0, 0.0);
    float w = 2.0 * d - 1.0;  // EVSM warps depth remapped to [-1, 1]
    float pos = exp(q.warp.x * w), neg = -exp(-q.warp.y * w);
    return vec4(pos, pos * pos, neg, neg * neg);
}

float gauss(int k) {
    float sigma = 0.5 * float(kRadius);
    return exp(-0.5 * float(k * k) / (sigma * sigma));
}

void main() {
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    int res = int(q.layer.y), layer = int(q.layer.x);
    if (t.x >= res || t.y >= res) return;
    vec4 value;
    if (kPass == kMomentPassWarp) {
        float stored = texelFetch(source, ivec3(t, layer), 0).r;
        value = warp(q.layer.z != 0u ? 1.0 - stored : stored);  // reversed Z: the moments of forward depth
    } else {
        // The map's edge texels repeat beyond it, as the lookup's clamp-to-edge sampler reads them.
        // Not a ?: on vectors: glslang folds that with the specialisation constant's default.
        ivec2 step = ivec2(0, 1);
        if (kPass == kMomentPassBlurX) step = ivec2(1, 0);
        int r = int(kRadius);
        vec4 sum = vec4(0.0);
        float norm = 0.0;
        for (int k = -r; k <= r; ++k) {
            float g = gauss(k);
            ivec2 s = clamp(t + k * step, ivec2(0), ivec2(res - 1));
            sum += g * texelFetch(source, ivec3(s, layer), 0);
            norm += g;
        }
        value = sum / norm;
    }
    imageStore(target, ivec3(t, layer), value);
}
