#version 460
#extension GL_GOOGLE_include_directive : require
// SDSM's reduction (Lauritzen, Salvi and Lefohn, "Sample Distribution Shadow Maps", I3D 2011):
// the least and greatest view depth of the samples the camera sees, for the cascades' splits.
// The camera pass stores the triangle per pixel rather than a depth; each pixel's depth is that
// of the surface point the lookups rebuild (the pixel-centre ray against the triangle's plane),
// so the reduced range holds exactly the depths the lookups select cascades by. Depths are
// reduced as order-preserving uints: a workgroup in shared memory, then one atomic each.
#include "penumbra_shared.h"

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = kBindingGBufferPrim, r32ui) uniform readonly uimage2D gbuffer_prim;
layout(std430, binding = kBindingPositions) readonly buffer Positions { float positions[]; };
layout(std430, binding = kBindingIndices) readonly buffer Indices { uint indices[]; };
layout(std430, binding = kBindingSdsmRange) buffer Range { uint depth_min, depth_max; };
layout(push_constant) uniform Push { SdsmParams p; };

shared uint group_min, group_max;

vec3 vertex(uint i) { return vec3(positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]); }
#include "surface_seen.glsl"

// Float bits in an order uints keep: negatives flipped, positives above them.
uint ordered(float f) {
    uint u = floatBitsToUint(f);
    return (u & 0x80000000u) != 0u ? ~u : u | 0x80000000u;
}

void main() {
    if (gl_LocalInvocationIndex == 0u) {
        group_min = 0xFFFFFFFFu;
        group_max = 0u;
    }
    barrier();
    uvec2 pix = gl_GlobalInvocationID.xy;
    uint W = uint(p.image.x), H = uint(p.image.y);
    uint id = pix.x < W && pix.y < H ? imageLoad(gbuffer_prim, ivec2(pix)).r : kNoPrim;
    if (id != kNoPrim) {
        vec3 P = surface_seen(pix, id).point;  // as the lookups rebuild it
        uint d = ordered(dot(P, p.cam_forward.xyz));
        atomicMin(group_min, d);
        atomicMax(group_max, d);
    }
    barrier();
    if (gl_LocalInvocationIndex == 0u && group_min <= group_max) {
        atomicMin(depth_min, group_min);
        atomicMax(depth_max, group_max);
    }
}
