#version 460
#extension GL_GOOGLE_include_directive : require
// Shadow volumes' camera depth pass: the depth of the surface the session's camera pass sees
// (single-sided triangles seen from behind are dropped, as camera.frag drops them).
//
// It runs with depth clamp, as the volumes do: a triangle the near plane cuts is then rasterised
// whole in both passes, so a cap over the triangle it copies gets its very depths (a rasteriser
// that clips it in one pass and not in the other gives depths a few ulps apart: lit sheets read as
// acne on an NVIDIA H200). What the camera pass clips (nearer than near, beyond far) is dropped
// here instead, from the interpolated clip z and w (Vulkan's clip volume 0 <= z <= w).
#include "penumbra_shared.h"
layout(std430, set = 0, binding = kBindingDoubleSided) readonly buffer DoubleSided { uint double_sided_bits[]; };
layout(location = 0) in vec2 clip_zw;
void main() {
    if (clip_zw.x > clip_zw.y || clip_zw.x < 0.0) discard;
    uint id = uint(gl_PrimitiveID);
    bool double_sided = ((double_sided_bits[id >> 5] >> (id & 31u)) & 1u) != 0u;
    if (!gl_FrontFacing && !double_sided) discard;
}
