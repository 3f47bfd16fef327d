#version 460
// Camera pass: the same projection as the oracle's primary rays (docs/design.md, "Conventions").
layout(location = 0) in vec3 position;
layout(push_constant) uniform Push { mat4 view_proj; } push;
void main() { gl_Position = push.view_proj * vec4(position, 1.0); }
