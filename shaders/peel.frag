#version 460
#extension GL_GOOGLE_include_directive : require
// Midpoint depth's second pass: peel.glsl.
#include "peel.glsl"
