#version 460
// Shadow pass with caster offsets (caster.geom): the camera-relative position goes on to the
// geometry shader, which moves it and projects it.
layout(location = 0) in vec3 position;
void main() { gl_Position = vec4(position, 1.0); }
