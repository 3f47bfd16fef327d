#version 460
// Shadow pass: store which triangle owns each texel, so the metrics can recognise
// self-shadowing (acne) by identity rather than by a depth tolerance. gl_PrimitiveID counts from
// the draw's first triangle (shadow.vert's first_prim).
layout(location = 0) flat in uint first_prim;
layout(location = 0) out uint stored_prim;
void main() { stored_prim = first_prim + uint(gl_PrimitiveID); }
