#version 460
#extension GL_GOOGLE_include_directive : require
// Depth-only shadow pass (no triangle ids) of a scene with cut-outs: the alpha test alone.
#include "penumbra_shared.h"
#include "cutout.glsl"
layout(location = 0) flat in uint first_prim;
layout(location = 1) in vec2 uv;
layout(location = 2) in float vertex_alpha;
void main() {
    if (!cutout_opaque(first_prim + uint(gl_PrimitiveID), uv, vertex_alpha, dFdx(uv), dFdy(uv))) discard;
}
