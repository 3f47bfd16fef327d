#version 460
#extension GL_GOOGLE_include_directive : require
// Shadow volumes' camera depth pass: the depth of the surface the session's camera pass sees
// (single-sided triangles seen from behind are dropped, as camera.frag drops them).
#include "penumbra_shared.h"
layout(std430, set = 0, binding = kBindingDoubleSided) readonly buffer DoubleSided { uint double_sided_bits[]; };
void main() {
    uint id = uint(gl_PrimitiveID);
    bool double_sided = ((double_sided_bits[id >> 5] >> (id & 31u)) & 1u) != 0u;
    if (!gl_FrontFacing && !double_sided) discard;
}
