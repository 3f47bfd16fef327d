#version 460
#extension GL_GOOGLE_include_directive : require
// Lookup pass, one dispatch per light: rebuild the surface point the oracle uses (the pixel
// centre's ray against the triangle the camera pass saw), apply the technique's receiver
// biases, and filter the shadow map. Every compare is done here on texelFetch'd depths, so a
// verdict is reproducible bit for bit; the linear comparison sampler is used only for
// "hw2x2" on devices that support it.
#include "penumbra_shared.h"

layout(local_size_x = 8, local_size_y = 8) in;

// Ids must match kSpec* in penumbra_shared.h (GLSL wants literals here).
layout(constant_id = 0) const uint kLightKind = 0;
layout(constant_id = 1) const uint kFilterType = 0;
layout(constant_id = 2) const uint kPcfSize = 3;
layout(constant_id = 3) const uint kPoissonTapCount = 16;
layout(constant_id = 4) const uint kBilinearTaps = 0;
layout(constant_id = 5) const uint kReceiverPlane = 0;
layout(constant_id = 6) const uint kHardwareCompare = 0;
layout(constant_id = 7) const uint kMode = 0;

layout(binding = kBindingGBufferPrim, r32ui) uniform readonly uimage2D gbuffer_prim;
layout(std430, binding = kBindingPositions) readonly buffer Positions { float positions[]; };
layout(std430, binding = kBindingIndices) readonly buffer Indices { uint indices[]; };
layout(binding = kBindingShadowDepth) uniform sampler2DArray shadow_depth;
layout(binding = kBindingShadowPrim) uniform usampler2DArray shadow_prim;
layout(binding = kBindingShadowCompare) uniform sampler2DArrayShadow shadow_compare;
layout(std140, binding = kBindingLookupParams) uniform Params { LookupParams p; };
layout(std430, binding = kBindingLookupOut) writeonly buffer Out { LookupTexel texels[]; };
layout(std430, binding = kBindingFaceMask) buffer FaceMask { uint face_mask; };
layout(std430, binding = kBindingVisibilityOut) writeonly buffer VisibilityOut { float visibility[]; };
layout(binding = kBindingMoments) uniform sampler2DArray moment_map;

// The verdict of pixel `i`: with every lookup behind it, or V alone.
void store(uint i, LookupTexel o) {
    if (kMode == kModeLookup) texels[i] = o;
    if (kMode == kModeVisibility) visibility[i] = o.V;
}

vec3 vertex(uint i) { return vec3(positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]); }

// Suns: light from one direction, in one map or in cascades.
const bool kDirectional = kLightKind == kLightDirectional || kLightKind == kLightCascade;

// Cascade i's slice of view depth ends at cascade_far(i) metres; its texel is cascade_texel(i).
float cascade_far(uint i) { return p.cascade_far[i >> 2][i & 3u]; }
float cascade_texel(uint i) { return p.cascade_texel[i >> 2][i & 3u]; }
uint cascade_count() { return uint(p.cascade.x); }
// The world and hardware constant biases of a layer (cascades.texel_scaled_bias scales them).
float world_bias(uint layer) {
    if (kLightKind != kLightCascade) return p.bias.x;
    uint i = min(layer, cascade_count() - 1u);
    return p.bias.x * p.cascade_world_scale[i >> 2][i & 3u];
}
float constant_bias(uint layer) {
    if (kLightKind != kLightCascade) return p.bias.w;
    uint i = min(layer, cascade_count() - 1u);
    return p.bias.w * p.cascade_constant_scale[i >> 2][i & 3u];
}
// reversed_z: the map and every depth a layer's view_proj gives are 1 - z; compares flip.
bool reversed_z() { return p.caster2.z > 0.5; }
// A map depth in the forward convention (what LookupTexel reports and the metrics read).
float forward_depth(float d) { return reversed_z() ? 1.0 - d : d; }
// 1 = lit: the reference at or in front of the stored depth (LESS_OR_EQUAL; GREATER_OR_EQUAL reversed).
bool lit_against(float ref, float stored) { return reversed_z() ? ref >= stored : ref <= stored; }

// How a normal offset scales with the angle to the light (kNormalFactor*): Godot and Unity URP
// take 1 - N.L, Filament and Babylon sin(theta).
float normal_factor(uint kind, float ndotl) {
    if (kind == kNormalFactorOneMinusNdotL) return 1.0 - max(ndotl, 0.0);
    if (kind == kNormalFactorSin) return sqrt(max(1.0 - ndotl * ndotl, 0.0));
    return 1.0;
}

// View depth of a camera-relative point (the eye is the origin for both projections).
float camera_depth(vec3 P) { return dot(P, p.cam_forward.xyz); }

// Cascades: the first whose slice holds the point's view depth (cascade_count() beyond the last).
// Cube faces in the order +X, -X, +Y, -Y, +Z, -Z; each is an exact 90-degree frustum.
uint select_layer(vec3 P) {
    if (kLightKind == kLightCascade) {
        float d = camera_depth(P);
        uint count = cascade_count();
        for (uint i = 0u; i < count; ++i)
            if (d <= cascade_far(i)) return i;
        return count;
    }
    if (kLightKind != kLightPoint) return 0u;
    vec3 d = P - p.light_pos.xyz;
    vec3 a = abs(d);
    if (a.x >= a.y && a.x >= a.z) return d.x > 0.0 ? 0u : 1u;
    if (a.y >= a.z) return d.y > 0.0 ? 2u : 3u;
    return d.z > 0.0 ? 4u : 5u;
}

// Shadow-map texel size at P in `layer`, metres: the cascade's own for cascades.
float layer_footprint(vec3 P, uint layer) {
    if (kLightKind == kLightDirectional) return p.footprint.x;
    if (kLightKind == kLightCascade) return cascade_texel(min(layer, cascade_count() - 1u));
    return p.footprint.y * dot(P - p.light_pos.xyz, p.light_axis[layer].xyz);
}

// Continuous texel coordinates (texel i spans [i, i+1)) and depth in the layer.
vec3 to_map(vec3 X, uint layer) {
    vec4 c = p.view_proj[layer] * vec4(X, 1.0);
    vec3 n = c.xyz / c.w;
    return vec3((n.xy * 0.5 + 0.5) * p.map.x, n.z);
}

float depth_units_ref(float z) {
    // UNORM formats clamp the reference to [0, 1] before the compare (Vulkan spec, 16.3.4).
    return p.bias2.z > 0.0 ? clamp(z, 0.0, 1.0) : z;
}

// One point compare at texel t; 1 = lit (reference <= stored, LESS_OR_EQUAL).
float tap_point(ivec2 t, uint layer, float ref) {
    int res = int(p.map.x);
    if (kLightKind == kLightPoint) {
        t = clamp(t, ivec2(0), ivec2(res - 1));  // a cube face clamps to its edge
    } else if (any(lessThan(t, ivec2(0))) || any(greaterThanEqual(t, ivec2(res)))) {
        return 1.0;  // outside the map: the border is lit
    }
    float stored = texelFetch(shadow_depth, ivec3(t, int(layer)), 0).r;
    return lit_against(depth_units_ref(ref), stored) ? 1.0 : 0.0;
}

// Reference depth at texel t: the receiver plane extrapolated to the texel centre when
// receiver-plane bias is on, else the receiver's own depth.
float ref_at(ivec2 t, vec3 m, vec2 dz) {
    if (kReceiverPlane == 0u) return m.z;
    return m.z + dot(dz, vec2(t) + 0.5 - m.xy);
}

float tap_at(vec2 uv, uint layer, vec3 m, vec2 dz) {
    ivec2 t = ivec2(floor(uv));
    return tap_point(t, layer, ref_at(t, m, dz));
}

// Bilinearly weighted 2x2 compare around uv, as a linear comparison sampler does.
float tap_bilinear(vec2 uv, uint layer, vec3 m, vec2 dz) {
    vec2 st = uv - 0.5;
    vec2 base = floor(st);
    // The linear comparison sampler where its four texels lie in the map. Across a 2D map's edge
    // the shader's own weights run instead: they read every texel outside as lit, while a border
    // texel compares as depth 1.0 and shadows a float reference beyond the map's far plane.
    bool in_map = all(greaterThanEqual(base, vec2(0.0))) && all(lessThan(base + 1.0, vec2(p.map.x)));
    if (kHardwareCompare != 0u && (in_map || kLightKind == kLightPoint)) {
        float ref = m.z + (kReceiverPlane != 0u ? dot(dz, uv - m.xy) : 0.0);
        return textureGrad(shadow_compare, vec4(uv * p.map.y, float(layer), depth_units_ref(ref)), vec2(0.0),
                           vec2(0.0));
    }
    vec2 f = st - base;
    ivec2 t = ivec2(base);
    float s00 = tap_point(t, layer, ref_at(t, m, dz));
    float s10 = tap_point(t + ivec2(1, 0), layer, ref_at(t + ivec2(1, 0), m, dz));
    float s01 = tap_point(t + ivec2(0, 1), layer, ref_at(t + ivec2(0, 1), m, dz));
    float s11 = tap_point(t + ivec2(1, 1), layer, ref_at(t + ivec2(1, 1), m, dz));
    return mix(mix(s00, s10, f.x), mix(s01, s11, f.x), f.y);
}

float grid_tap(vec2 uv, uint layer, vec3 m, vec2 dz) {
    return kBilinearTaps != 0u ? tap_bilinear(uv, layer, m, dz) : tap_at(uv, layer, m, dz);
}

// Per-pixel rotation of the Poisson disk from an integer hash: deterministic, no texture.
float pixel_angle(uvec2 pix) {
    uint h = pix.x * 0x8da6b343u ^ pix.y * 0xd8163841u;
    h ^= h >> 16;
    h *= 0x7feb352du;
    h ^= h >> 15;
    return float(h & 0xFFFFu) * (6.28318530718 / 65536.0);
}

// Interleaved gradient noise (Jimenez, "Next Generation Post Processing in Call of Duty: Advanced
// Warfare", SIGGRAPH 2014) at the pixel centre, as three.js evaluates it at gl_FragCoord.xy.
float interleaved_gradient_noise(uvec2 pix) {
    vec2 c = vec2(pix) + 0.5;
    return fract(52.9829189 * fract(dot(c, vec2(0.06711056, 0.00583715))));
}

// Tap k of n on a Vogel disk (golden-angle spiral, unit radius) turned by phi: three.js r18x's
// vogelDiskSample (shadowmap_pars_fragment.glsl.js).
vec2 vogel_tap(uint k, uint n, float phi) {
    float r = sqrt((float(k) + 0.5) / float(n));
    float theta = float(k) * 2.399963229728653 + phi;
    return vec2(cos(theta), sin(theta)) * r;
}

vec2 poisson_tap(uint k) {
    vec4 pair = p.poisson[k >> 1];
    return (k & 1u) == 0u ? pair.xy : pair.zw;
}

// Metres along a perspective layer's axis from a stored depth (perspective_matrix's inverse).
float view_depth(float d) {
    float n = p.pcss.y, f = p.pcss.z;
    return n * f / (f - d * (f - n));
}

// Metres along the light per depth unit of an orthographic layer: its depth is affine in
// position, and row 2 of view_proj is the gradient, which points along the light.
float ortho_metres_per_depth(uint layer) {
    mat4 vp = p.view_proj[layer];
    return 1.0 / length(vec3(vp[0][2], vp[1][2], vp[2][2]));
}

// Metres of light depth a layer's [0, 1] depth covers (far - near): its own for each cascade.
float depth_range_m(uint layer) {
    if (kDirectional) return ortho_metres_per_depth(min(layer, max(uint(p.map.w), 1u) - 1u));
    return p.pcss.z - p.pcss.y;
}

// Percentage-closer soft shadows (Fernando 2005; reference 001): the average depth of the
// blockers inside the light's footprint seen from the receiver sets the penumbra width, and a
// Poisson PCF of that width filters. Radii are texels of the layer; a texel subtends
// p.footprint.y per metre of depth.
// A sun (orthographic layers, p.pcss.x = tan(alpha), alpha its angular radius): a blocker d
// metres above the receiver shadows it from up to d tan(alpha) away, so the search reaches
// (receiver - near) tan(alpha) and the filter radius is (receiver - blocker) tan(alpha), half
// the penumbra w = (d_receiver - d_blocker) 2 tan(alpha) (docs/raster.md, "A sun with a size").
float pcss_visibility(uvec2 pix, uint layer, vec3 m, vec2 dz, float z_receiver) {
    float a = pixel_angle(pix);
    mat2 rot = mat2(cos(a), sin(a), -sin(a), cos(a));
    float light_r = p.pcss.x, near = p.pcss.y, max_r = p.pcss.w;
    float per_texel = p.footprint.y;
    int res = int(p.map.x);
    // A sun's texels of radius per depth unit between blocker and receiver.
    float sun_texels = kDirectional ? ortho_metres_per_depth(layer) * light_r / layer_footprint(vec3(0.0), layer) : 0.0;
    // 1. blockers: the light seen from the receiver, projected onto the near plane.
    float search = kDirectional ? clamp(forward_depth(m.z) * sun_texels, 1.0, max_r)
                                : clamp(light_r * (z_receiver - near) / (z_receiver * near * per_texel), 1.0, max_r);
    float blocker_sum = 0.0;
    uint blockers = 0u;
    for (uint k = 0u; k < kPoissonTapCount; ++k) {
        ivec2 t = clamp(ivec2(floor(m.xy + rot * poisson_tap(k) * search)), ivec2(0), ivec2(res - 1));
        float stored = texelFetch(shadow_depth, ivec3(t, int(layer)), 0).r;
        if (!lit_against(depth_units_ref(ref_at(t, m, dz)), stored)) {
            stored = forward_depth(stored);
            blocker_sum += kDirectional ? stored : view_depth(stored);
            ++blockers;
        }
    }
    if (blockers == 0u) return 1.0;
    float z_blocker = blocker_sum / float(blockers);
    // 2. the penumbra: the light seen from the receiver, at the blockers' depth.
    float radius = kDirectional
                       ? clamp((forward_depth(m.z) - z_blocker) * sun_texels, 1.0, max_r)
                       : clamp(light_r * (z_receiver - z_blocker) / (z_receiver * z_blocker * per_texel), 1.0, max_r);
    // 3. PCF over it.
    float sum = 0.0;
    for (uint k = 0u; k < kPoissonTapCount; ++k) sum += grid_tap(m.xy + rot * poisson_tap(k) * radius, layer, m, dz);
    return sum / float(kPoissonTapCount);
}

// Moment families (raster/filterable.h). Their moments pass and blur passes
// (shaders/moments.comp) filled kBindingMoments; the lookup samples it as an engine does:
// bilinearly, or trilinearly between its mip levels when it has them.
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

// The pixel and the receiver's plane main() found, for the mip level: compute shaders have no
// derivatives, so the lookup traces the neighbouring pixels' rays itself.
uvec2 g_pix;
vec3 g_plane_point, g_plane_normal;

// The camera ray through image point `pixel` (pixels, y down) against the receiver's plane.
vec3 on_receiver_plane(vec2 pixel) {
    vec2 ndc = vec2(pixel.x * 2.0 * p.image.z - 1.0, 1.0 - pixel.y * 2.0 * p.image.w);
    vec3 lateral = ndc.x * p.cam_right.w * p.cam_right.xyz + ndc.y * p.cam_up.w * p.cam_up.xyz;
    bool perspective = p.cam_forward.w > 0.5;
    vec3 ray_o = perspective ? vec3(0.0) : lateral;
    vec3 ray_d = perspective ? p.cam_forward.xyz + lateral : p.cam_forward.xyz;
    float denom = dot(ray_d, g_plane_normal);
    return abs(denom) > 1e-30 ? ray_o + ray_d * (dot(g_plane_point - ray_o, g_plane_normal) / denom) : g_plane_point;
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
    if (kFilterType == kFilterVsm) return reduce_bleeding(chebyshev(mo.xy, t, p.moments.x));
    if (kFilterType == kFilterMsm) {
        if (p.moment_map.y > 0.5) mo = msm_unoptimise(mo);
        return msm_visibility(mo, t);
    }
    if (kFilterType == kFilterEsm) {
        // exp(c d) filtered times exp(-c t), in logs: exp(-c t) alone underflows float.
        return clamp(exp(log(max(mo.x, 1e-38)) - p.moments.z * t), 0.0, 1.0);
    }
    // EVSM: the variance floor scaled by each warp's slope at t (TheRealMJP/Shadows).
    float w = 2.0 * t - 1.0;
    float pos = exp(p.moments.z * w), neg = -exp(-p.moments.w * w);
    float pos_floor = p.moments.x * (2.0 * p.moments.z * pos) * (2.0 * p.moments.z * pos);
    float v = chebyshev(mo.xy, pos, pos_floor);
    if (kFilterType == kFilterEvsm4) {
        float neg_floor = p.moments.x * (2.0 * p.moments.w * neg) * (2.0 * p.moments.w * neg);
        v = min(v, chebyshev(mo.zw, neg, neg_floor));
    }
    return reduce_bleeding(v);
}

float filter_visibility(uvec2 pix, uint layer, vec3 m, vec2 dz, float z_receiver) {
    if (kFilterType >= kFilterVsm && kFilterType <= kFilterMsm) return moment_visibility(m, layer);
    if (kFilterType == kFilterPcss) return pcss_visibility(pix, layer, m, dz, z_receiver);
    if (kFilterType == kFilterHw2x2) return tap_bilinear(m.xy, layer, m, dz);
    if (kFilterType == kFilterPcf) {
        float sum = 0.0;
        float half_span = 0.5 * float(kPcfSize - 1u);
        for (uint j = 0u; j < kPcfSize; ++j)
            for (uint i = 0u; i < kPcfSize; ++i)
                sum += grid_tap(m.xy + vec2(float(i) - half_span, float(j) - half_span), layer, m, dz);
        return sum / float(kPcfSize * kPcfSize);
    }
    if (kFilterType == kFilterPoisson) {
        float a = pixel_angle(pix);
        mat2 rot = mat2(cos(a), sin(a), -sin(a), cos(a));
        float sum = 0.0;
        for (uint k = 0u; k < kPoissonTapCount; ++k) sum += grid_tap(m.xy + rot * poisson_tap(k) * p.map.z, layer, m, dz);
        return sum / float(kPoissonTapCount);
    }
    if (kFilterType == kFilterVogel) {
        float phi = interleaved_gradient_noise(pix) * 6.28318530718;
        float sum = 0.0;
        for (uint k = 0u; k < kPoissonTapCount; ++k)
            sum += grid_tap(m.xy + vogel_tap(k, kPoissonTapCount, phi) * p.map.z, layer, m, dz);
        return sum / float(kPoissonTapCount);
    }
    return tap_at(m.xy, layer, m, dz);
}

// Depth gradient of the receiver plane in texel units of `layer`, from two tangent steps of h
// metres: the receiver-plane bias needs it, and so do the diagnostics.
vec2 plane_gradient(vec3 Pb, vec3 n, float h, uint layer, vec3 m) {
    if (kReceiverPlane == 0u && kMode != kModeLookup) return vec2(0.0);
    vec3 t1 = normalize(abs(n.x) > 0.9 ? cross(n, vec3(0.0, 1.0, 0.0)) : cross(n, vec3(1.0, 0.0, 0.0)));
    vec3 t2 = cross(n, t1);
    vec3 m1 = to_map(Pb + t1 * h, layer), m2 = to_map(Pb + t2 * h, layer);
    mat2 J = mat2(m1.xy - m.xy, m2.xy - m.xy);
    float det = determinant(J);
    return abs(det) > 1e-20 ? vec2(m1.z - m.z, m2.z - m.z) * inverse(J) : vec2(0.0);
}

// Weight of the next cascade at Pb: 0 outside the blend band, rising linearly to 1 at the end of
// `layer`'s slice over its last `overlap` fraction (bevy, Unity). 0 without overlap.
float cascade_blend(vec3 Pb, uint layer) {
    if (kLightKind != kLightCascade || p.cascade.y <= 0.0 || layer + 1u >= cascade_count()) return 0.0;
    float end = cascade_far(layer), start = (1.0 - p.cascade.y) * end;
    return clamp((camera_depth(Pb) - start) / max(end - start, 1e-30), 0.0, 1.0);
}

// V of `layer` mixed with the next cascade's across the blend band.
float blend_cascades(uvec2 pix, uint layer, vec3 Pb, vec3 n, float h, float v) {
    float w = cascade_blend(Pb, layer);
    if (w <= 0.0) return v;
    uint next = layer + 1u;
    vec3 m = to_map(Pb, next);
    vec2 dz = plane_gradient(Pb, n, h, next, m);
    m.z -= reversed_z() ? -p.bias.z : p.bias.z;
    return mix(v, filter_visibility(pix, next, m, dz, 0.0), w);
}

void main() {
    uvec2 pix = gl_GlobalInvocationID.xy;
    uint W = uint(p.image.x), H = uint(p.image.y);
    if (pix.x >= W || pix.y >= H) return;
    uint out_index = pix.y * W + pix.x;

    LookupTexel o;
    o.V = 0.0;
    o.ref_depth = 0.0;
    o.stored_depth = 0.0;
    o.footprint_m = 0.0;
    o.texel_slope = 0.0;
    o.bias_m = 0.0;
    o.depth_to_m = 0.0;
    o.stored_prim = kNoPrim;
    o.flags = 0u;

    uint id = imageLoad(gbuffer_prim, ivec2(pix)).r;
    if (id == kNoPrim) {
        store(out_index, o);
        return;
    }
    o.flags = kFlagSurface;

    // The surface point the oracle uses: the pixel-centre ray against the triangle's plane.
    vec3 v0 = vertex(indices[3 * id]), v1 = vertex(indices[3 * id + 1]), v2 = vertex(indices[3 * id + 2]);
    vec3 n = normalize(cross(v1 - v0, v2 - v0));
    vec2 ndc = vec2((float(pix.x) + 0.5) * 2.0 * p.image.z - 1.0, 1.0 - (float(pix.y) + 0.5) * 2.0 * p.image.w);
    vec3 lateral = ndc.x * p.cam_right.w * p.cam_right.xyz + ndc.y * p.cam_up.w * p.cam_up.xyz;
    bool perspective = p.cam_forward.w > 0.5;
    vec3 ray_o = perspective ? vec3(0.0) : lateral;
    vec3 ray_d = perspective ? p.cam_forward.xyz + lateral : p.cam_forward.xyz;
    float denom = dot(ray_d, n);
    vec3 P = abs(denom) > 1e-30 ? ray_o + ray_d * (dot(v0 - ray_o, n) / denom) : (v0 + v1 + v2) / 3.0;
    if (denom > 0.0) n = -n;  // the side the camera sees
    g_pix = pix;
    g_plane_point = v0;
    g_plane_normal = n;

    vec3 to_light = kDirectional ? -p.light_dir.xyz : normalize(p.light_pos.xyz - P);
    if (dot(n, to_light) <= 0.0) {
        o.flags |= kFlagBackFacing;
        store(out_index, o);
        return;
    }
    if (kLightKind == kLightSpot && dot(-to_light, p.light_dir.xyz) < p.light_dir.w) {
        o.flags |= kFlagOutsideCone;
        store(out_index, o);
        return;
    }

    // Shadow-map texel size at the receiver, before any offset.
    uint layer = select_layer(P);
    float footprint = layer_footprint(P, layer);
    // Receiver biases: towards the light by metres (and by a fraction of the layer's depth
    // range), along the normal by texel footprints and metres, scaled by the normal factor and
    // without its component along L when normal_perpendicular is on (Godot).
    float world = world_bias(layer) + (p.bias3.w != 0.0 ? p.bias3.w * depth_range_m(layer) : 0.0);
    float normal_m = (p.bias.y * footprint + p.bias3.x) * normal_factor(uint(p.bias3.y), dot(n, to_light));
    vec3 normal_dir = p.bias3.z > 0.5 ? n - to_light * dot(n, to_light) : n;
    vec3 Pb = P + to_light * world + normal_dir * normal_m;
    layer = select_layer(Pb);
    if (kMode == kModeFaceMask) {
        atomicOr(face_mask, 1u << layer);
        return;
    }
    if (kLightKind == kLightCascade) {
        // The cascade actually used sets the footprint the metrics judge aliasing by.
        footprint = layer_footprint(Pb, layer);
        if (layer >= cascade_count()) {  // beyond max_distance: no cascade, lit as engines leave it
            o.flags |= kFlagOutsideMap | (layer << kFlagLayerShift);
            o.V = 1.0;
            o.footprint_m = footprint;
            o.stored_depth = 1.0 / 0.0;
            store(out_index, o);
            return;
        }
    }

    o.flags |= layer << kFlagLayerShift;
    vec3 m = to_map(Pb, layer);
    float h = max(footprint, 1e-30);
    // Depth gradient of the receiver plane in texel units, from two tangent steps of one
    // footprint: the receiver-plane bias needs it, and so do the diagnostics.
    vec2 dz = plane_gradient(Pb, n, h, layer, m);
    m.z -= reversed_z() ? -p.bias.z : p.bias.z;  // shader-side constant bias, depth units
    float z_receiver = kDirectional ? 0.0 : dot(Pb - p.light_pos.xyz, p.light_axis[layer].xyz);
    if (kMode == kModeVisibility) {
        o.V = blend_cascades(pix, layer, Pb, n, h, filter_visibility(pix, layer, m, dz, z_receiver));
        store(out_index, o);
        return;
    }

    // Everything expressed as metres along the light ray, for the peter-panning rule.
    float z_toward = to_map(Pb + to_light * h, layer).z - (reversed_z() ? -p.bias.z : p.bias.z);
    float metres_per_depth = abs(m.z - z_toward) > 0.0 ? h / abs(m.z - z_toward) : 0.0;
    float max_slope = max(abs(dz.x), abs(dz.y));
    float r = p.bias2.z > 0.0 ? p.bias2.z : exp2(float(int(floor(log2(max(m.z, 1e-30)))) - 23));
    float hw = constant_bias(layer) * r + p.bias2.x * max_slope;
    if (p.bias2.y > 0.0) hw = min(hw, p.bias2.y);
    if (p.bias2.y < 0.0) hw = max(hw, p.bias2.y);
    // The caster offsets move the stored surface away from the light by the metres a receiver
    // offset would move the receiver towards it (the caster's normal factor taken at this
    // surface, which is its own caster where acne forms).
    float caster_normal = (p.caster.z + p.caster.w * footprint) * normal_factor(uint(p.caster2.x), dot(n, to_light));
    float caster_m = p.caster.x + p.caster.y * footprint + caster_normal + p.caster2.y * metres_per_depth;
    o.bias_m = world + (p.bias3.z > 0.5 ? normal_m * length(normal_dir) : normal_m) + (hw + p.bias.z) * metres_per_depth + caster_m;

    ivec2 centre = ivec2(floor(m.xy));
    int res = int(p.map.x);
    bool inside = all(greaterThanEqual(centre, ivec2(0))) && all(lessThan(centre, ivec2(res)));
    o.footprint_m = footprint;
    o.depth_to_m = metres_per_depth;
    o.texel_slope = 0.5 * (abs(dz.x) + abs(dz.y));
    o.ref_depth = forward_depth(ref_at(centre, m, dz));
    if (inside || kLightKind == kLightPoint) {
        ivec3 c = ivec3(clamp(centre, ivec2(0), ivec2(res - 1)), int(layer));
        o.stored_depth = forward_depth(texelFetch(shadow_depth, c, 0).r);
        o.stored_prim = texelFetch(shadow_prim, c, 0).r;
    } else {
        o.stored_depth = 1.0 / 0.0;
        o.flags |= kFlagOutsideMap;
    }
    o.V = blend_cascades(pix, layer, Pb, n, h, filter_visibility(pix, layer, m, dz, z_receiver));
    // Across a blend band both cascades decide: the coarser texel bounds the aliasing band.
    if (kLightKind == kLightCascade && cascade_blend(Pb, layer) > 0.0)
        o.footprint_m = max(footprint, cascade_texel(layer + 1u));
    store(out_index, o);
}
