#!/usr/bin/env python3
"""Writes data/default/scene.glb: a small scene that shows what penumbra is for.

  - a ground plane of two large triangles (a receiver whose float error is not small)
  - a box and a sphere resting on it (contact shadows)
  - a 2 cm pole and a zero-thickness double-sided sign (thin occluders)
  - a panel tilted so the directional light grazes it at ~86 degrees from its normal
  - a floating slab over the box (overlapping occluders)
Standard library only, deterministic output.
"""
import json
import math
import struct
import sys
from pathlib import Path


def box(sx, sy, sz):
    """Axis-aligned box, min corner at (-sx/2, 0, -sz/2): it rests on y = 0. CCW outward faces."""
    x0, x1, z0, z1 = -sx / 2, sx / 2, -sz / 2, sz / 2
    p = [(x0, 0, z0), (x1, 0, z0), (x1, sy, z0), (x0, sy, z0),
         (x0, 0, z1), (x1, 0, z1), (x1, sy, z1), (x0, sy, z1)]
    quads = [(4, 5, 6, 7), (1, 0, 3, 2), (0, 4, 7, 3), (5, 1, 2, 6), (3, 7, 6, 2), (0, 1, 5, 4)]
    idx = []
    for a, b, c, d in quads:
        idx += [a, b, c, a, c, d]
    return p, idx


def uv_sphere(r, seg=32, rings=16):
    """Sphere of radius r whose lowest point touches y = 0."""
    p = []
    for i in range(rings + 1):
        th = math.pi * i / rings
        for j in range(seg + 1):
            ph = 2 * math.pi * j / seg
            p.append((r * math.sin(th) * math.cos(ph), r + r * math.cos(th), r * math.sin(th) * math.sin(ph)))
    idx = []
    for i in range(rings):
        for j in range(seg):
            a, b = i * (seg + 1) + j, (i + 1) * (seg + 1) + j
            if i != 0:
                idx += [a, a + 1, b]
            if i != rings - 1:
                idx += [a + 1, b + 1, b]
    return p, idx


def quad(w, h):
    """A w x h rectangle in the XY plane, facing +Z, bottom edge on y = 0."""
    return [(-w / 2, 0, 0), (w / 2, 0, 0), (w / 2, h, 0), (-w / 2, h, 0)], [0, 1, 2, 0, 2, 3]


def write_glb(path, meshes, nodes, materials):
    blob = bytearray()
    views, accessors, gl_meshes = [], [], []
    for positions, indices, material in meshes:
        pos = b"".join(struct.pack("<3f", *v) for v in positions)
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(pos), "target": 34962})
        blob += pos
        lo = [min(v[k] for v in positions) for k in range(3)]
        hi = [max(v[k] for v in positions) for k in range(3)]
        accessors.append({"bufferView": len(views) - 1, "componentType": 5126, "count": len(positions),
                          "type": "VEC3", "min": lo, "max": hi})
        ind = struct.pack(f"<{len(indices)}I", *indices)
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(ind), "target": 34963})
        blob += ind
        accessors.append({"bufferView": len(views) - 1, "componentType": 5125, "count": len(indices),
                          "type": "SCALAR"})
        gl_meshes.append({"primitives": [{"attributes": {"POSITION": len(accessors) - 2},
                                          "indices": len(accessors) - 1, "material": material}]})
    doc = {"asset": {"version": "2.0", "generator": "penumbra make_default_scene.py"},
           "scene": 0, "scenes": [{"nodes": list(range(len(nodes)))}], "nodes": nodes,
           "meshes": gl_meshes, "materials": materials, "accessors": accessors, "bufferViews": views,
           "buffers": [{"byteLength": len(blob)}]}
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    blob += b"\0" * (-len(blob) % 4)
    out = struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(js) + 8 + len(blob))
    out += struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(blob), 0x004E4942) + blob
    Path(path).write_bytes(out)


def main():
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parent.parent / "data/default/scene.glb"
    ground = ([(-8, 0, -8), (-8, 0, 8), (8, 0, 8), (8, 0, -8)], [0, 1, 2, 0, 2, 3])
    materials = [{"name": "single_sided"}, {"name": "double_sided", "doubleSided": True}]
    meshes = [ground + (0,), box(1, 1, 1) + (0,), uv_sphere(0.6) + (0,), box(0.02, 2.5, 0.02) + (0,),
              quad(1.2, 0.6) + (1,), box(3, 0.05, 1.2) + (0,), box(2.0, 0.2, 1.0) + (0,)]
    nodes = [
        {"name": "ground", "mesh": 0},
        {"name": "box", "mesh": 1, "translation": [-2.0, 0, 0.5]},
        {"name": "sphere", "mesh": 2, "translation": [1.5, 0, 1.0]},
        {"name": "pole", "mesh": 3, "translation": [0.2, 0, -1.5]},
        {"name": "sign", "mesh": 4, "translation": [0.2, 1.6, -1.5]},
        # Tilted about X so the light (travelling -Y, +Z-ish) grazes its top face.
        {"name": "grazing_panel", "mesh": 5, "translation": [3.5, 0.4, -2.0],
         "rotation": [math.sin(math.radians(-27.5)), 0, 0, math.cos(math.radians(-27.5))]},
        {"name": "floating_slab", "mesh": 6, "translation": [-2.3, 2.2, 0.2]},
    ]
    write_glb(out, meshes, nodes, materials)
    print(f"wrote {out} ({out.stat().st_size} bytes)")


if __name__ == "__main__":
    main()
