#version 460
#extension GL_GOOGLE_include_directive : require
// Camera pass: the triangle seen through each pixel centre. Single-sided triangles seen from
// behind are dropped, as the oracle drops them; all geometry still occludes light.
#include "penumbra_shared.h"
layout(std430, set = 0, binding = kBindingDoubleSided) readonly buffer DoubleSided { uint double_sided_bits[]; };
layout(location = 0) out uint seen_prim;
void main() {
    uint id = uint(gl_PrimitiveID);
    bool double_sided = ((double_sided_bits[id >> 5] >> (id & 31u)) & 1u) != 0u;
    if (!gl_FrontFacing && !double_sided) discard;
    seen_prim = id;
}
