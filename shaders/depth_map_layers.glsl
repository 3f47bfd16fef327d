// The depth map's layers (raster/depth_map.cpp), the lookup hooks of lookup_core.glsl for a family
// that draws one map per light and six cube faces for a point light.

// Cube faces in the order +X, -X, +Y, -Y, +Z, -Z; each is an exact 90-degree frustum.
uint select_layer(vec3 P) {
    if (kLightKind != kLightPoint) return 0u;
    vec3 d = P - p.light_pos.xyz;
    vec3 a = abs(d);
    if (a.x >= a.y && a.x >= a.z) return d.x > 0.0 ? 0u : 1u;
    if (a.y >= a.z) return d.y > 0.0 ? 2u : 3u;
    return d.z > 0.0 ? 4u : 5u;
}

float layer_footprint(vec3 P, uint layer) {
    if (kLightKind == kLightDirectional) return p.footprint.x;
    return p.footprint.y * dot(P - p.light_pos.xyz, p.light_axis[layer].xyz);
}

float world_bias(uint layer) { return p.bias.x; }
float constant_bias(uint layer) { return p.bias.w; }
bool beyond_layers(vec3 Pb, uint layer, inout float footprint) { return false; }
float blend_layers(uvec2 pix, uint layer, vec3 Pb, vec3 n, float h, float v) { return v; }
float blended_footprint(vec3 Pb, uint layer, float footprint) { return footprint; }
