#!/usr/bin/env python3
"""Writes a foliage-like scene of cut-outs (alphaMode MASK), the content real shadows come from:

  - a ground of two triangles and a tree trunk (opaque, single-sided)
  - a crown of 40 double-sided leaf cards at scattered heights and orientations, some facing the
    sun, some edge-on, crossing each other; each card's leaf texture (64x64 RGBA PNG in the .glb's
    BIN chunk) holds a few elliptical leaves, LINEAR-filtered, cutoff 0.5
  - a chain-link fence 6 m x 2 m: one quad whose 16x16 diamond texture repeats 24 x 8 times through
    KHR_texture_transform (NEAREST, REPEAT), its wire 2 texels of 16 wide, cutoff 0.35
  - a grille: a double-sided sheet facing the sun whose COLOR_0 alpha fades the holes in and out

usage: make_foliage_scene.py OUT_DIR   (writes OUT_DIR/foliage.glb and OUT_DIR/scenario.json)
Standard library only, deterministic output.
"""
import json
import math
import random
import struct
import sys
import zlib
from pathlib import Path


def png_rgba(width, height, alpha):
    """8-bit RGBA PNG (ISO/IEC 15948): green, with alpha(x, y) in [0, 255]."""
    raw = bytearray()
    for y in range(height):
        raw.append(0)
        for x in range(width):
            raw += bytes((60, 140, 50, alpha(x, y)))

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(bytes(raw), 9)) + chunk(b"IEND", b""))


def leaf_alpha(x, y, n=64):
    """Four elliptical leaves on a card, smooth edges (a LINEAR-filtered cut-out's ramp)."""
    u, v = (x + 0.5) / n, (y + 0.5) / n
    best = -1.0
    for cx, cy, rx, ry, a in ((0.3, 0.3, 0.22, 0.12, 0.6), (0.7, 0.35, 0.2, 0.1, -0.5),
                              (0.35, 0.72, 0.18, 0.1, -0.9), (0.72, 0.74, 0.22, 0.11, 0.8)):
        du, dv = u - cx, v - cy
        s, c = math.sin(a), math.cos(a)
        p, q = (c * du + s * dv) / rx, (-s * du + c * dv) / ry
        best = max(best, 1.0 - (p * p + q * q))
    return max(0, min(255, int(round(128 + 600 * best))))


def chain_link_alpha(x, y, n=16):
    """A diamond mesh: opaque within a texel of either diagonal of the 16x16 tile."""
    d1, d2 = (x - y) % n, (x + y) % n
    return 255 if min(d1, n - d1) <= 1 or min(d2, n - d2) <= 1 else 0


def grille_alpha(x, y, n=32):
    """Square holes of 8 texels on a 16-texel pitch."""
    return 0 if (x % 16) >= 4 and (x % 16) < 12 and (y % 16) >= 4 and (y % 16) < 12 else 255


class Glb:
    def __init__(self):
        self.blob = bytearray()
        self.views, self.accessors, self.meshes, self.images = [], [], [], []

    def view(self, data, target=None):
        self.blob += b"\0" * (-len(self.blob) % 4)
        v = {"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data)}
        if target:
            v["target"] = target
        self.views.append(v)
        self.blob += data
        return len(self.views) - 1

    def accessor(self, fmt, values, kind, ncomp, minmax=False):
        data = b"".join(struct.pack("<" + fmt * ncomp, *(v if ncomp > 1 else (v,))) for v in values)
        a = {"bufferView": self.view(data, 34963 if kind == "SCALAR" else 34962),
             "componentType": 5125 if fmt == "I" else 5126, "count": len(values), "type": kind}
        if minmax:
            a["min"] = [min(v[k] for v in values) for k in range(ncomp)]
            a["max"] = [max(v[k] for v in values) for k in range(ncomp)]
        self.accessors.append(a)
        return len(self.accessors) - 1

    def mesh(self, positions, indices, material, uv=None, colour=None):
        attributes = {"POSITION": self.accessor("f", positions, "VEC3", 3, True)}
        if uv:
            attributes["TEXCOORD_0"] = self.accessor("f", uv, "VEC2", 2)
        if colour:
            attributes["COLOR_0"] = self.accessor("f", colour, "VEC4", 4)
        prim = {"attributes": attributes, "indices": self.accessor("I", indices, "SCALAR", 1), "material": material}
        self.meshes.append({"primitives": [prim]})
        return len(self.meshes) - 1

    def image(self, png, name):
        self.images.append({"name": name, "bufferView": self.view(png), "mimeType": "image/png"})
        return len(self.images) - 1

    def write(self, path, doc):
        doc.update({"meshes": self.meshes, "accessors": self.accessors, "bufferViews": self.views,
                    "images": self.images, "buffers": [{"byteLength": len(self.blob)}]})
        js = json.dumps(doc, separators=(",", ":")).encode()
        js += b" " * (-len(js) % 4)
        self.blob += b"\0" * (-len(self.blob) % 4)
        out = struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(js) + 8 + len(self.blob))
        out += struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(self.blob), 0x004E4942)
        Path(path).write_bytes(out + bytes(self.blob))


def card(w, h):
    """A w x h card in its XY plane, centred, facing +Z, uv (0, 0) at the top left."""
    p = [(-w / 2, -h / 2, 0), (w / 2, -h / 2, 0), (w / 2, h / 2, 0), (-w / 2, h / 2, 0)]
    return p, [0, 1, 2, 0, 2, 3], [(0, 1), (1, 1), (1, 0), (0, 0)]


def box(sx, sy, sz):
    x0, x1, z0, z1 = -sx / 2, sx / 2, -sz / 2, sz / 2
    p = [(x0, 0, z0), (x1, 0, z0), (x1, sy, z0), (x0, sy, z0), (x0, 0, z1), (x1, 0, z1), (x1, sy, z1), (x0, sy, z1)]
    idx = []
    for a, b, c, d in [(4, 5, 6, 7), (1, 0, 3, 2), (0, 4, 7, 3), (5, 1, 2, 6), (3, 7, 6, 2), (0, 1, 5, 4)]:
        idx += [a, b, c, a, c, d]
    return p, idx


def quaternion(axis, angle):
    n = math.sqrt(sum(a * a for a in axis))
    s = math.sin(angle / 2) / n
    return [axis[0] * s, axis[1] * s, axis[2] * s, math.cos(angle / 2)]


def main():
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    g = Glb()
    leaf = g.image(png_rgba(64, 64, leaf_alpha), "leaf")
    link = g.image(png_rgba(16, 16, chain_link_alpha), "chain_link")
    grille = g.image(png_rgba(32, 32, grille_alpha), "grille")
    materials = [
        {"name": "ground"},
        {"name": "bark"},
        {"name": "leaves", "alphaMode": "MASK", "doubleSided": True,
         "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}},
        {"name": "chain_link", "alphaMode": "MASK", "alphaCutoff": 0.35, "doubleSided": True,
         "pbrMetallicRoughness": {"baseColorTexture": {
             "index": 1, "extensions": {"KHR_texture_transform": {"scale": [24, 8]}}}}},
        {"name": "grille", "alphaMode": "MASK", "doubleSided": True,
         "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 0.9], "baseColorTexture": {"index": 2}}},
    ]
    textures = [{"source": leaf, "sampler": 0}, {"source": link, "sampler": 1}, {"source": grille, "sampler": 1}]
    samplers = [{"magFilter": 9729, "wrapS": 33071, "wrapT": 33071}, {"magFilter": 9728, "wrapS": 10497, "wrapT": 10497}]

    nodes = []
    ground = g.mesh([(-10, 0, -10), (-10, 0, 10), (10, 0, 10), (10, 0, -10)], [0, 1, 2, 0, 2, 3], 0)
    nodes.append({"name": "ground", "mesh": ground})
    trunk = g.mesh(*box(0.25, 2.2, 0.25), 1)
    nodes.append({"name": "trunk", "mesh": trunk, "translation": [-1.5, 0, 0]})
    p, i, uv = card(0.9, 0.9)
    leaf_card = g.mesh(p, i, 2, uv)
    rng = random.Random(7)
    for k in range(40):
        centre = [-1.5 + rng.uniform(-1.1, 1.1), rng.uniform(1.8, 3.2), rng.uniform(-1.1, 1.1)]
        axis = [rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)]
        nodes.append({"name": f"leaf_card_{k}", "mesh": leaf_card, "translation": centre,
                      "rotation": quaternion(axis, rng.uniform(0, math.pi))})
    p, i, uv = card(6, 2)
    fence = g.mesh(p, i, 3, uv)
    nodes.append({"name": "chain_link_fence", "mesh": fence, "translation": [2.0, 1.0, -1.5],
                  "rotation": quaternion([0, 1, 0], -0.4)})
    p, i, uv = card(2, 2)
    fade = [(1, 1, 1, 1.0), (1, 1, 1, 0.3), (1, 1, 1, 1.0), (1, 1, 1, 0.3)]
    sheet = g.mesh(p, i, 4, [(u * 4, v * 4) for u, v in uv], fade)
    nodes.append({"name": "grille", "mesh": sheet, "translation": [2.2, 1.6, 2.0],
                  "rotation": quaternion([1, 0, 0], -math.pi / 2 + 0.25)})

    doc = {"asset": {"version": "2.0", "generator": "penumbra make_foliage_scene.py"},
           "extensionsUsed": ["KHR_texture_transform"],
           "scene": 0, "scenes": [{"nodes": list(range(len(nodes)))}], "nodes": nodes,
           "materials": materials, "textures": textures, "samplers": samplers}
    g.write(out / "foliage.glb", doc)
    scenario = {
        "scene": "foliage.glb",
        "image": {"width": 640, "height": 360},
        "camera": {"type": "perspective", "eye": [5.5, 4.0, 7.5], "target": [0.0, 1.2, 0.0], "up": [0, 1, 0],
                   "yfov_deg": 50, "znear": 0.1, "zfar": 60},
        "lights": [{"type": "directional", "direction": [0.3, -0.8, -0.5], "name": "sun"},
                   {"type": "spot", "position": [4.0, 6.0, 4.0], "direction": [-0.55, -0.75, -0.4],
                    "outer_cone_deg": 35}],
        "technique": {"preset": "d3d12-textbook"},
    }
    (out / "scenario.json").write_text(json.dumps(scenario, indent=1) + "\n")
    print(f"wrote {out / 'foliage.glb'} and {out / 'scenario.json'}")


if __name__ == "__main__":
    main()
