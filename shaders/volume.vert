#version 460
// Shadow volumes (raster/shadow_volume.cpp): the camera depth pass and the volumes share this
// shader, so that a cap drawn over the triangle it copies lands at the same depth. w = 0 is a
// point at infinity (an extruded vertex), Everitt & Kilgard 2002.
layout(location = 0) in vec4 position;  // camera-relative
layout(push_constant) uniform Push { mat4 view_proj; } push;
// Clip z and w: the depth pass clips at the near and far planes itself (volume.frag).
layout(location = 0) out vec2 clip_zw;
void main() {
    gl_Position = push.view_proj * position;
    clip_zw = gl_Position.zw;
}
