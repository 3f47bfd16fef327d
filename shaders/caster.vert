#version 460
// Shadow pass with caster offsets (caster.geom): the camera-relative position goes on to the
// geometry shader, which moves it and projects it; first_prim as in shadow.vert.
layout(location = 0) in vec3 position;
layout(location = 0) flat out uint first_prim;
void main() {
    gl_Position = vec4(position, 1.0);
    first_prim = uint(gl_InstanceIndex);
}
