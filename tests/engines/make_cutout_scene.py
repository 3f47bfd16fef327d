#!/usr/bin/env python3
"""Writes OUT_DIR/scene.glb and OUT_DIR/scenario.json: cut-outs' scene for cutout_test.sh.

A ground (single-sided), a 3 m checkerboard card of 8 x 8 texels (alphaMode MASK, cutoff 0.5,
NEAREST, double-sided) tilted 20 degrees 1.4 m up, and a double-sided opaque sheet with its back to
the sun: the alpha test and the material's sides decide both engines' shadows. Standard library
only; deterministic.
"""
import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent.parent / "scripts"))
from make_foliage_scene import Glb, card, png_rgba, quaternion  # noqa: E402


def quaternion_product(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return [aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz]


def main():
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    g = Glb()
    checker = g.image(png_rgba(8, 8, lambda x, y: 255 if (x + y) % 2 == 0 else 0), "checkerboard")
    materials = [{"name": "ground"},
                 {"name": "checkerboard", "alphaMode": "MASK", "doubleSided": True,
                  "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}},
                 {"name": "sheet", "doubleSided": True}]
    ground = g.mesh([(-6, 0, -6), (-6, 0, 6), (6, 0, 6), (6, 0, -6)], [0, 1, 2, 0, 2, 3], 0)
    p, i, uv = card(3, 3)
    board = g.mesh(p, i, 1, uv)
    p, i, _ = card(1.6, 1.0)
    sheet = g.mesh(p, i, 2)
    nodes = [{"name": "ground", "mesh": ground},
             # Facing up and tilted: rotated -90 degrees about x, then 20 degrees about z.
             {"name": "checkerboard_card", "mesh": board, "translation": [-0.5, 1.4, 0.3],
              "rotation": quaternion_product(quaternion([0, 0, 1], math.radians(20)),
                                             quaternion([1, 0, 0], -math.pi / 2))},
             # Its front face down, away from the sun.
             {"name": "sheet_back_to_the_sun", "mesh": sheet, "translation": [2.4, 1.0, -1.8],
              "rotation": quaternion([1, 0, 0], math.pi / 2)}]
    doc = {"asset": {"version": "2.0", "generator": "penumbra tests/engines/make_cutout_scene.py"},
           "scene": 0, "scenes": [{"nodes": list(range(len(nodes)))}], "nodes": nodes, "materials": materials,
           "textures": [{"source": checker, "sampler": 0}],
           "samplers": [{"magFilter": 9728, "minFilter": 9728, "wrapS": 33071, "wrapT": 33071}]}
    g.write(out / "scene.glb", doc)
    scenario = {
        "scene": "scene.glb",
        "image": {"width": 320, "height": 180},
        "camera": {"type": "perspective", "eye": [4.0, 6.0, 7.0], "target": [0.3, 0.4, 0.0], "up": [0, 1, 0],
                   "yfov_deg": 45, "znear": 0.1, "zfar": 100},
        "lights": [{"type": "directional", "direction": [0.35, -0.75, -0.45], "name": "sun"}],
    }
    (out / "scenario.json").write_text(json.dumps(scenario, indent=2) + "\n")


if __name__ == "__main__":
    main()
