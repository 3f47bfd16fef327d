#version 460
// Shadow pass: store which triangle owns each texel, so the metrics can recognise
// self-shadowing (acne) by identity rather than by a depth tolerance.
layout(location = 0) out uint stored_prim;
void main() { stored_prim = uint(gl_PrimitiveID); }
