#version 460
#extension GL_GOOGLE_include_directive : require
// The cascaded family's lookup for suns (raster/cascades.cpp; docs/raster.md, "Cascaded shadow
// maps"): a layer per cascade of view depth, each with its own texel and, with
// cascades.texel_scaled_bias, its own world and constant bias; the next cascade blended in over
// the last `overlap` fraction of a slice. The filters are the depth map's (lookup_core.glsl).
#include "lookup_core.glsl"

// Cascade i's slice of view depth ends at cascade_far(i) metres; its texel is cascade_texel(i).
float cascade_far(uint i) { return p.cascade_far[i >> 2][i & 3u]; }
float cascade_texel(uint i) { return p.cascade_texel[i >> 2][i & 3u]; }
uint cascade_count() { return uint(p.cascade.x); }

// The first cascade whose slice holds the point's view depth (cascade_count() beyond the last).
uint select_layer(vec3 P) {
    float d = camera_depth(P);
    uint count = cascade_count();
    for (uint i = 0u; i < count; ++i)
        if (d <= cascade_far(i)) return i;
    return count;
}

float layer_footprint(vec3 P, uint layer) { return cascade_texel(min(layer, cascade_count() - 1u)); }

float world_bias(uint layer) {
    uint i = min(layer, cascade_count() - 1u);
    return p.bias.x * p.cascade_world_scale[i >> 2][i & 3u];
}
float constant_bias(uint layer) {
    uint i = min(layer, cascade_count() - 1u);
    return p.bias.w * p.cascade_constant_scale[i >> 2][i & 3u];
}

// The cascade actually used sets the footprint the metrics judge aliasing by; beyond
// max_distance there is none.
bool beyond_layers(vec3 Pb, uint layer, inout float footprint) {
    footprint = layer_footprint(Pb, layer);
    return layer >= cascade_count();
}

float family_visibility(uvec2 pix, uint layer, vec3 m, vec2 dz, float z_receiver) {
    return depth_filter_visibility(pix, layer, m, dz, z_receiver);
}

// Weight of the next cascade at Pb: 0 outside the blend band, rising linearly to 1 at the end of
// `layer`'s slice over its last `overlap` fraction (bevy, Unity). 0 without overlap.
float cascade_blend(vec3 Pb, uint layer) {
    if (p.cascade.y <= 0.0 || layer + 1u >= cascade_count()) return 0.0;
    float end = cascade_far(layer), start = (1.0 - p.cascade.y) * end;
    return clamp((camera_depth(Pb) - start) / max(end - start, 1e-30), 0.0, 1.0);
}

// V of `layer` mixed with the next cascade's across the blend band.
float blend_layers(uvec2 pix, uint layer, vec3 Pb, vec3 n, float h, float v) {
    float w = cascade_blend(Pb, layer);
    if (w <= 0.0) return v;
    uint next = layer + 1u;
    vec3 m = to_map(Pb, next);
    vec2 dz = plane_gradient(Pb, n, h, next, m);
    m.z -= reversed_z() ? -p.bias.z : p.bias.z;
    return mix(v, family_visibility(pix, next, m, dz, 0.0), w);
}

// Across a blend band both cascades decide: the coarser texel bounds the aliasing band.
float blended_footprint(vec3 Pb, uint layer, float footprint) {
    return cascade_blend(Pb, layer) > 0.0 ? max(footprint, cascade_texel(layer + 1u)) : footprint;
}

#include "lookup_main.glsl"
