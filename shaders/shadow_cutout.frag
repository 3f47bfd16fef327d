#version 460
#extension GL_GOOGLE_include_directive : require
// Shadow pass of a scene with cut-outs: shadow.frag's triangle id where the surface is opaque,
// nothing where a cut-out's coverage is below its cutoff (the alpha test engines draw).
#include "penumbra_shared.h"
#include "cutout.glsl"
layout(location = 0) flat in uint first_prim;
layout(location = 1) in vec2 uv;
layout(location = 2) in float vertex_alpha;
layout(location = 0) out uint stored_prim;
void main() {
    const uint prim = first_prim + uint(gl_PrimitiveID);
    if (!cutout_opaque(prim, uv, vertex_alpha, dFdx(uv), dFdy(uv))) discard;
    stored_prim = prim;
}
