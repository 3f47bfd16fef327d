#version 460
#extension GL_GOOGLE_include_directive : require
// The moment families' lookup (raster/filterable.h; docs/raster.md, "Filterable shadow maps"): the
// depth map's layers, and instead of depth compares the filtered moments that their passes
// (raster/filterable_moments.comp) wrote to kBindingFamilyImage, sampled as an engine does:
// bilinearly, or trilinearly between its mip levels when it has them.
#include "lookup_core.glsl"
#include "depth_map_layers.glsl"
#include "filterable.glsl"

layout(binding = kBindingFamilyImage) uniform sampler2DArray moment_map;

// Specialisation constant 1 (kSpecFilter) carries the family (kMoment*) here.
const uint kMomentKind = kFilterType;

// Moment shadow maps' 16-bit moments were mapped onto [0, 1]^4 by Peters & Klein's optimised
// quantisation (section 4.3) before the store rounded them; this maps them back (the paper's
// matrix; raster/filterable.cpp has the same numbers, and the tests compare the two).
vec4 msm_unoptimise(vec4 q) {
    const mat4 inv = mat4(0.2227744146, 0.1549679261, 0.1451988946, 0.163127443,  // column 1
                          0.0771972861, 0.1394629426, 0.2120202157, 0.2591432266,
                          0.7926986636, 0.7963415838, 0.7258694464, 0.6539092497,
                          0.0319417555, -0.1722823173, -0.2758014811, -0.3376131734);
    return inv * (q - vec4(0.035955884801, 0.0, 0.0, 0.0));
}

// The mip level of the moment texture for this pixel: log2 of the longer of the pixel's two
// steps across the map, in texels (the level a fragment shader's derivatives would give). 0, the
// full-resolution map, where a pixel covers less than a texel.
float moment_lod(uint layer) {
    if (p.moment_map.x <= 1.0) return 0.0;
    vec2 c = vec2(g_pix) + 0.5;
    vec2 m = to_map(on_receiver_plane(c), layer).xy;
    vec2 dx = to_map(on_receiver_plane(c + vec2(1.0, 0.0)), layer).xy - m;
    vec2 dy = to_map(on_receiver_plane(c + vec2(0.0, 1.0)), layer).xy - m;
    float rho = max(length(dx), length(dy));
    if (isnan(rho) || isinf(rho)) return p.moment_map.x - 1.0;  // a neighbour's ray misses the plane
    return clamp(log2(max(rho, 1e-30)), 0.0, p.moment_map.x - 1.0);
}

// One-tailed Chebyshev bound on P(depth >= t) with a variance floor (Donnelly & Lauritzen 2006).
float chebyshev(vec2 m, float t, float min_variance) {
    if (t <= m.x) return 1.0;
    float variance = max(m.y - m.x * m.x, min_variance);
    float d = t - m.x;
    return variance / (variance + d * d);
}

// Moment shadow maps (Peters & Klein 2015): the sharpest lower bound on the shadow of a receiver
// at depth z given the four moments, after the moment bias p.moments.x; Hamburger over the real
// line, Hausdorff (p.moments.z = 1) over [0, 1]. The same steps as msm_visibility in
// raster/filterable.cpp, which the tests check this against.
float msm_visibility(vec4 moments, float z) {
    float alpha = p.moments.x;
    vec4 b = mix(moments, vec4(0.5), alpha);
    // LDL^T of the Hankel matrix [[1, b1, b2], [b1, b2, b3], [b2, b3, b4]], solving B c = (1, z, z^2).
    float d22 = b.y - b.x * b.x;
    float l32 = (b.z - b.x * b.y) / d22;
    float d33 = b.w - b.y * b.y - l32 * l32 * d22;
    float c2 = z - b.x;
    float c3 = (z * z - b.y - l32 * c2) / d33;
    c2 = c2 / d22 - l32 * c3;
    float c1 = 1.0 - b.x * c2 - b.y * c3;
    // The other two support points: the roots of c1 + c2 x + c3 x^2.
    float pp = c2 / c3, q = c1 / c3;
    float r = sqrt(max(0.25 * pp * pp - q, 0.0));
    float z2 = -0.5 * pp - r, z3 = -0.5 * pp + r;
    float shadow = 0.0;
    if (z > z3) {
        shadow = 1.0 - (z2 * z3 - b.x * (z2 + z3) + b.y) / ((z - z2) * (z - z3));
    } else if (z > z2) {
        shadow = (z * z3 - b.x * (z + z3) + b.y) / ((z3 - z2) * (z - z2));
    }
    if (p.moments.z > 0.5 && (z2 < 0.0 || z3 > 1.0)) {
        // Hausdorff: those points leave [0, 1]; four points, one of them at 0 or 1. Where the
        // receiver ties the free point the formula is 0/0: the three-point bound stays.
        float free = ((b.z - b.y) * z + b.z - b.w) / ((b.y - b.x) * z + b.y - b.z);
        float w = z > free ? 1.0 : 0.0;
        float four = (b.y - b.x + (b.z - b.x - (free + 1.0) * (b.y - b.x)) * (free - w - z) / (z * (z - free))) /
                         (free - w) +
                     1.0 - b.x;
        if (!isnan(four) && !isinf(four)) shadow = four;
    }
    return 1.0 - clamp(shadow, 0.0, 1.0);
}

// Light-bleed reduction: linstep(amount, 1, p).
float reduce_bleeding(float pmax) {
    return clamp((pmax - p.moments.y) / (1.0 - p.moments.y), 0.0, 1.0);
}

float moment_visibility(vec3 m, uint layer) {
    int res = int(p.map.x);
    ivec2 centre = ivec2(floor(m.xy));
    bool in_map = all(greaterThanEqual(centre, ivec2(0))) && all(lessThan(centre, ivec2(res)));
    if (!in_map && kLightKind != kLightPoint) return 1.0;  // outside a 2D map: lit, as a depth tap there
    vec4 mo = textureLod(moment_map, vec3(m.xy * p.map.y, float(layer)), moment_lod(layer));
    float t = forward_depth(depth_units_ref(m.z));
    if (kMomentKind == kMomentVsm) return reduce_bleeding(chebyshev(mo.xy, t, p.moments.x));
    if (kMomentKind == kMomentMsm) {
        if (p.moment_map.y > 0.5) mo = msm_unoptimise(mo);
        return msm_visibility(mo, t);
    }
    if (kMomentKind == kMomentEsm) {
        // exp(c d) filtered times exp(-c t), in logs: exp(-c t) alone underflows float.
        return clamp(exp(log(max(mo.x, 1e-38)) - p.moments.z * t), 0.0, 1.0);
    }
    // EVSM: the variance floor scaled by each warp's slope at t (TheRealMJP/Shadows).
    float w = 2.0 * t - 1.0;
    float pos = exp(p.moments.z * w), neg = -exp(-p.moments.w * w);
    float pos_floor = p.moments.x * (2.0 * p.moments.z * pos) * (2.0 * p.moments.z * pos);
    float v = chebyshev(mo.xy, pos, pos_floor);
    if (kMomentKind == kMomentEvsm4) {
        float neg_floor = p.moments.x * (2.0 * p.moments.w * neg) * (2.0 * p.moments.w * neg);
        v = min(v, chebyshev(mo.zw, neg, neg_floor));
    }
    return reduce_bleeding(v);
}


float family_visibility(uvec2 pix, uint layer, vec3 m, vec2 dz, float z_receiver) {
    return moment_visibility(m, layer);
}

#include "lookup_main.glsl"
