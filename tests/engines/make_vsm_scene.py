#!/usr/bin/env python3
"""Writes OUT_DIR/scene.glb and OUT_DIR/scenario.json: light bleeding's scene for vsm_test.sh.

The geometry of tests/validate/verdict_test.cpp's plate_under_roof (issue #35) at a larger scale:
a crate under a sun at 45 degrees, and a roof high above whose edge line, in the light's view,
runs across the crate's top. On the ground in the crate's shadow, along the roof's edge line, a
blurred variance map mixes roof and crate depths and Chebyshev's bound lets light through onto
ground that the crate shadows on both sides of that line (the line is no true boundary there).
The roof is 12 m up and the crate 2 m, so that the bound (up to about 0.5 here) survives three.js's
fixed light-bleed remap linstep(0.3, 0.95); in the C++ scene (the plate halfway up) it is 0.11 and
the remap would remove it. The camera looks from below the crate's top, where the roof's edge
casts a true boundary on the same light rays (only seen boundaries count, docs/metrics.md).
Standard library only; deterministic.
"""
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent.parent / "scripts"))
from make_default_scene import box, write_glb  # noqa: E402


def quad(x0, x1, y, z0, z1):
    """A horizontal rectangle at height y, facing +Y (counter-clockwise seen from above)."""
    return [(x0, y, z0), (x0, y, z1), (x1, y, z1), (x1, y, z0)], [0, 1, 2, 0, 2, 3]


def main():
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    materials = [{"name": "single_sided"}, {"name": "double_sided", "doubleSided": True}]
    meshes = [quad(-16, 10, 0, -6, 6) + (0,),     # the ground
              box(2, 2, 4) + (0,),                 # the crate: x -1..1, y 0..2, z -2..2
              quad(-16, -10, 12, -6, 6) + (1,)]    # the roof: its edge's ray crosses the crate top at x = 0
    nodes = [{"name": "ground", "mesh": 0}, {"name": "crate", "mesh": 1}, {"name": "roof", "mesh": 2}]
    write_glb(out / "scene.glb", meshes, nodes, materials)
    scenario = {
        "scene": "scene.glb",
        "image": {"width": 320, "height": 240},
        "camera": {"type": "perspective", "eye": [5.5, 1.9, 2.0], "target": [2.2, 0.0, 0.0], "up": [0, 1, 0],
                   "yfov_deg": 40, "znear": 0.1, "zfar": 100},
        "lights": [{"type": "directional", "direction": [1, -1, 0], "name": "sun"}],
    }
    (out / "scenario.json").write_text(json.dumps(scenario, indent=2) + "\n")


if __name__ == "__main__":
    main()
