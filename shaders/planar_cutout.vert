#version 460
#extension GL_GOOGLE_include_directive : require
// Planar projection of a cut-out: the flattened triangle drawn from the camera, carrying its
// texture coordinate and COLOR_0 alpha over w (Blinn's projection is projective: a point of the
// flattened triangle at world-linear weights b' is the original's at weights b'_i / w_i,
// renormalised), and its scene triangle for the material.
#include "penumbra_shared.h"
layout(std430, set = 0, binding = kBindingPlanarAttributes) readonly buffer PlanarAttributes { vec4 planar_attributes[]; };
layout(std430, set = 0, binding = kBindingPlanarTriangles) readonly buffer PlanarTriangles { uint planar_triangles[]; };
layout(location = 0) in vec3 position;
layout(location = 0) flat out uint scene_prim;
layout(location = 1) out vec4 over_w;  // (u, v, alpha, 1) / w
layout(push_constant) uniform Push { mat4 view_proj; } push;
void main() {
    gl_Position = push.view_proj * vec4(position, 1.0);
    scene_prim = planar_triangles[gl_VertexIndex / 3];
    over_w = planar_attributes[gl_VertexIndex];
}
