#version 460
// Shadow pass: camera-relative positions into one light layer's clip space.
layout(location = 0) in vec3 position;
layout(push_constant) uniform Push { mat4 view_proj; } push;
void main() { gl_Position = push.view_proj * vec4(position, 1.0); }
