#version 460
#extension GL_GOOGLE_include_directive : require
// The depth_map family's lookup (raster/depth_map.cpp): the core's compare filters on one map per
// light, or a point light's cube.
#include "lookup_core.glsl"
#include "depth_map_layers.glsl"

float family_visibility(uvec2 pix, uint layer, vec3 m, vec2 dz, float z_receiver) {
    return depth_filter_visibility(pix, layer, m, dz, z_receiver);
}

#include "lookup_main.glsl"
