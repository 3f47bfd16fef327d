#version 460
#extension GL_GOOGLE_include_directive : require
// Planar projection of a cut-out: its flattened shadow only where the original is opaque, at the
// texture's base level (a flattened triangle has no map texels to minify over).
#include "penumbra_shared.h"
#include "cutout.glsl"
layout(location = 0) flat in uint scene_prim;
layout(location = 1) in vec4 over_w;
layout(location = 0) out uint stored_prim;
void main() {
    const vec3 a = over_w.xyz / over_w.w;
    if (!cutout_opaque(scene_prim, a.xy, a.z, vec2(0.0), vec2(0.0))) discard;
    stored_prim = scene_prim;
}
