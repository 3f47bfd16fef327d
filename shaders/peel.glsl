// Midpoint depth's second pass (Woo 1992; peel.frag, and peel_cutout.frag defining CUTOUT): of
// the surfaces behind the first depth layer, the nearest one. Fragments at or in front of the first layer (plus `epsilon`, a few depth quanta)
// are peeled away; the others write the midpoint between the first layer and themselves, which
// grows with their depth, so the depth test (less) keeps the nearest: the map ends up holding
// (first + second) / 2, or the clear value 1 where no surface lies behind the first.
layout(set = 0, binding = 0) uniform sampler2DArray first_layer;
layout(push_constant) uniform Push {
    mat4 view_proj;
    uint layer;
    float epsilon;
} push;
layout(location = 0) flat in uint first_prim;  // shadow.vert's (cutout.vert's)
layout(location = 0) out uint second_prim;
#ifdef CUTOUT  // peel_cutout.frag: a cut-out's holes are no layer
#include "penumbra_shared.h"
#include "cutout.glsl"
layout(location = 1) in vec2 uv;
layout(location = 2) in float vertex_alpha;
#endif
void main() {
#ifdef CUTOUT
    if (!cutout_opaque(first_prim + uint(gl_PrimitiveID), uv, vertex_alpha, dFdx(uv), dFdy(uv))) discard;
#endif
    float first = texelFetch(first_layer, ivec3(ivec2(gl_FragCoord.xy), int(push.layer)), 0).r;
    if (gl_FragCoord.z <= first + push.epsilon) discard;
    gl_FragDepth = 0.5 * (first + gl_FragCoord.z);
    second_prim = first_prim + uint(gl_PrimitiveID);
}
