// The shadow pass's caster offsets (caster.geom; caster_cutout.geom defines CUTOUT), as Unity
// URP (ApplyShadowBias) and Babylon (shadowMapVertexNormalBias, shadowMapVertexMetric) apply them while drawing the map: each
// vertex moves away from the light along L by metres and texels, and inward along the normal
// (-N) by metres and texels scaled by the normal factor; then the depth moves by caster.depth.
// The normal is the triangle's face normal: penumbra keeps no vertex normals, and a glTF mesh
// with hard edges carries the face normal at every vertex of a face anyway (docs/raster.md,
// "Bias as engines apply it").
#include "penumbra_shared.h"

layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;
layout(push_constant) uniform Push { ShadowPush s; };
layout(location = 0) flat in uint first_prim_in[];
layout(location = 0) flat out uint first_prim;
#ifdef CUTOUT  // a cut-out's texture coordinate and COLOR_0 alpha, on to shadow_cutout*.frag
layout(location = 1) in vec2 uv_in[];
layout(location = 2) in float vertex_alpha_in[];
layout(location = 1) out vec2 uv;
layout(location = 2) out float vertex_alpha;
#endif

float normal_factor(uint kind, float ndotl) {
    if (kind == kNormalFactorOneMinusNdotL) return 1.0 - max(ndotl, 0.0);
    if (kind == kNormalFactorSin) return sqrt(max(1.0 - ndotl * ndotl, 0.0));
    return 1.0;
}

void main() {
    vec3 a = gl_in[0].gl_Position.xyz, b = gl_in[1].gl_Position.xyz, c = gl_in[2].gl_Position.xyz;
    vec3 face = cross(b - a, c - a);  // counter-clockwise is the front face: the outward normal
    vec3 n = length(face) > 0.0 ? normalize(face) : vec3(0.0);
    bool positional = s.light.w > 0.5;
    for (int i = 0; i < 3; ++i) {
        vec3 P = gl_in[i].gl_Position.xyz;
        vec3 to_light = positional ? normalize(s.light.xyz - P) : -s.light.xyz;
        // The layer's texel at the vertex: fixed for an orthographic layer, growing with the
        // depth along the layer's axis for a perspective one.
        float texel = positional ? s.texel.w * dot(P - s.light.xyz, s.texel.xyz) : s.texel.w;
        float along_l = s.offsets.x + s.offsets.y * texel;
        float inward = (s.offsets.z + s.offsets.w * texel) * normal_factor(uint(s.caster.x), dot(n, to_light));
        vec3 Q = P - to_light * along_l - n * inward;
        gl_Position = s.view_proj * vec4(Q, 1.0);
        // caster.depth in depth units: clip z by depth * w (Vulkan's depth is z / w); reversed
        // Z stores 1 - z, so the same move away from the light lowers it.
        gl_Position.z += (s.caster.w > 0.5 ? -s.caster.y : s.caster.y) * gl_Position.w;
        gl_PrimitiveID = gl_PrimitiveIDIn;
        first_prim = first_prim_in[0];
#ifdef CUTOUT
        uv = uv_in[i];
        vertex_alpha = vertex_alpha_in[i];
#endif
        EmitVertex();
    }
    EndPrimitive();
}
