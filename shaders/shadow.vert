#version 460
// Shadow pass: camera-relative positions into one light layer's clip space. A draw of part of the
// triangles (cull material's runs) starts its instance at the run's first triangle, so that the
// fragment shaders store scene triangle ids: first_prim + gl_PrimitiveID.
layout(location = 0) in vec3 position;
layout(location = 0) flat out uint first_prim;
layout(push_constant) uniform Push { mat4 view_proj; } push;
void main() {
    gl_Position = push.view_proj * vec4(position, 1.0);
    first_prim = uint(gl_InstanceIndex);
}
