// The vertex stage of a scene with cut-outs (cutout.vert; caster_cutout.vert defines CASTER):
// shadow.vert's positions and first_prim, and each vertex's texture coordinate and COLOR_0 alpha (by its index: the draws are indexed into
// the scene's vertices) for the fragment's coverage (shaders/cutout.glsl).
#include "penumbra_shared.h"
layout(std430, set = 0, binding = kBindingCutoutUv) readonly buffer CutoutUv { float cutout_uv[]; };
layout(std430, set = 0, binding = kBindingCutoutAlpha) readonly buffer CutoutAlpha { float cutout_alpha[]; };
layout(location = 0) in vec3 position;
layout(location = 0) flat out uint first_prim;
layout(location = 1) out vec2 uv;
layout(location = 2) out float vertex_alpha;
#ifdef CASTER  // caster_cutout.geom projects
void main() {
    gl_Position = vec4(position, 1.0);
#else
layout(push_constant) uniform Push { mat4 view_proj; } push;
void main() {
    gl_Position = push.view_proj * vec4(position, 1.0);
#endif
    first_prim = uint(gl_InstanceIndex);
    uv = vec2(cutout_uv[2 * gl_VertexIndex], cutout_uv[2 * gl_VertexIndex + 1]);
    vertex_alpha = cutout_alpha[gl_VertexIndex];
}
