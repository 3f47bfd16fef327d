#version 460
#extension GL_GOOGLE_include_directive : require
// Shadow and camera passes of a scene with cut-outs: cutout_vertex.glsl.
#include "cutout_vertex.glsl"
