// The pixel's camera ray and the surface point the oracle judges on it (docs/oracle.md, section
// 2; raster/surface_seen.h is the CPU side): the ray through an image point against the plane of
// the triangle seen there. Every shader that rebuilds the point includes this, so the same float
// operations give the same point in each. Needs the push block `p` (cam_forward, cam_right,
// cam_up, image: LookupParams, SdsmParams) and vertex(i).

struct CameraRay {
    vec3 o, d;  // camera-relative origin; direction, its component along cam_forward 1
};

// The ray through image point `pixel` (pixels, y down; a pixel's centre is at +0.5).
CameraRay camera_ray(vec2 pixel) {
    vec2 ndc = vec2(pixel.x * 2.0 * p.image.z - 1.0, 1.0 - pixel.y * 2.0 * p.image.w);
    vec3 lateral = ndc.x * p.cam_right.w * p.cam_right.xyz + ndc.y * p.cam_up.w * p.cam_up.xyz;
    bool perspective = p.cam_forward.w > 0.5;
    CameraRay r;
    r.o = perspective ? vec3(0.0) : lateral;
    r.d = perspective ? p.cam_forward.xyz + lateral : p.cam_forward.xyz;
    return r;
}

// Where `r` meets the plane through `point` with `normal`; `parallel` for a ray in the plane.
vec3 on_plane(CameraRay r, vec3 point, vec3 normal, vec3 parallel) {
    float denom = dot(r.d, normal);
    return abs(denom) > 1e-30 ? r.o + r.d * (dot(point - r.o, normal) / denom) : parallel;
}

struct SurfaceSeen {
    vec3 point;        // the pixel centre's ray on triangle `id`'s plane (its centroid edge-on)
    vec3 normal;       // unit, of the side the camera sees
    vec3 plane_point;  // the triangle's first vertex: with `normal`, its plane
};

SurfaceSeen surface_seen(uvec2 pix, uint id) {
    vec3 v0 = vertex(indices[3 * id]), v1 = vertex(indices[3 * id + 1]), v2 = vertex(indices[3 * id + 2]);
    vec3 n = normalize(cross(v1 - v0, v2 - v0));
    CameraRay r = camera_ray(vec2(float(pix.x) + 0.5, float(pix.y) + 0.5));
    SurfaceSeen s;
    s.point = on_plane(r, v0, n, (v0 + v1 + v2) / 3.0);
    s.normal = dot(r.d, n) > 0.0 ? -n : n;
    s.plane_point = v0;
    return s;
}
