// The lookup pass's main(), included last by each family's lookup (after lookup_core.glsl and
// the family's hooks).
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
    SurfaceSeen seen = surface_seen(pix, id);
    vec3 P = seen.point, n = seen.normal;
    g_pix = pix;
    g_plane_point = seen.plane_point;
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
    if (beyond_layers(Pb, layer, footprint)) {  // no layer holds it: lit, as engines leave it
        o.flags |= kFlagOutsideMap | (layer << kFlagLayerShift);
        o.V = 1.0;
        o.footprint_m = footprint;
        o.stored_depth = 1.0 / 0.0;
        store(out_index, o);
        return;
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
        o.V = blend_layers(pix, layer, Pb, n, h, family_visibility(pix, layer, m, dz, z_receiver));
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
    o.V = blend_layers(pix, layer, Pb, n, h, family_visibility(pix, layer, m, dz, z_receiver));
    o.footprint_m = blended_footprint(Pb, layer, footprint);
    store(out_index, o);
}
