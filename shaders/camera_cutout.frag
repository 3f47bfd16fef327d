#version 460
#extension GL_GOOGLE_include_directive : require
// Camera pass of a scene with cut-outs: camera.frag, and the camera sees through a cut-out where
// its coverage is below its cutoff, as the oracle's primary rays do.
#include "penumbra_shared.h"
#include "cutout.glsl"
layout(std430, set = 0, binding = kBindingDoubleSided) readonly buffer DoubleSided { uint double_sided_bits[]; };
layout(location = 0) flat in uint first_prim;
layout(location = 1) in vec2 uv;
layout(location = 2) in float vertex_alpha;
layout(location = 0) out uint seen_prim;
void main() {
    const uint id = first_prim + uint(gl_PrimitiveID);
    const bool double_sided = ((double_sided_bits[id >> 5] >> (id & 31u)) & 1u) != 0u;
    if (!gl_FrontFacing && !double_sided) discard;
    if (!cutout_opaque(id, uv, vertex_alpha, vec2(0.0), vec2(0.0))) discard;  // level 0, as the truth
    seen_prim = id;
}
