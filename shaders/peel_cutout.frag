#version 460
#extension GL_GOOGLE_include_directive : require
// Midpoint depth's second pass of a scene with cut-outs: peel.glsl with the alpha test.
#define CUTOUT
#include "peel.glsl"
