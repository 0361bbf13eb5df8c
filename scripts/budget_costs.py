"""Measure what the loaders really allocate per unit of what an input declares: the
numbers behind ``COSTS`` in app/untrusted/budget.py (docs/stability.md, "Limits").

    .venv/bin/python scripts/budget_costs.py

Each measurement runs in a fresh child process: the peak resident set is reset
(``/proc/self/clear_refs``), one loader builds its output from a generated input, and the
peak's growth is divided by the units (vertices, triangles, texels, file bytes). Two sizes
are measured per kind and the difference is used, so that fixed costs (imports, caches)
cancel. Each kind is measured at its peak while being built and at what stays once it
is built (after a garbage collection and ``malloc_trim``): the two numbers of each of the
budget's ``COSTS``, which must stay above them.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

_CHILD = r"""
import io, json, sys, tempfile
from pathlib import Path
import numpy as np
from PIL import Image

kind, n = sys.argv[1], int(sys.argv[2])
folder = Path(tempfile.mkdtemp())

def peak_reset():
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")

def rss(name):
    for line in open("/proc/self/status"):
        if line.startswith(name):
            return int(line.split()[1]) << 10

from app.scene.loader import load_scene
from app.scene.geometry import build_parts
from app.textures.environment import read_hdr

scene_head = '[camera]\nposition = [0.0, 0.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\n'
if kind in ("vertex", "triangle"):
    sys.path.insert(0, str(Path.cwd()))
    from tests.gltf_builder import GltfBuilder
    import pygltflib
    side = n
    u, v = np.meshgrid(np.linspace(0, 1, side), np.linspace(0, 1, side))
    pos = np.stack([u.ravel(), v.ravel(), np.zeros(u.size)], 1).astype(np.float32)
    uv = np.stack([u.ravel(), v.ravel()], 1).astype(np.float32)
    i = np.arange(side * side).reshape(side, side)
    quads = np.stack([i[:-1, :-1], i[:-1, 1:], i[1:, 1:], i[:-1, :-1], i[1:, 1:], i[1:, :-1]], -1)
    idx = quads.reshape(-1).astype(np.uint32)
    b = GltfBuilder()
    attrs = pygltflib.Attributes(POSITION=b.accessor(pos), TEXCOORD_0=b.accessor(uv),
                                 NORMAL=b.accessor(np.tile(np.float32([0, 0, 1]), (len(pos), 1))))
    prim = pygltflib.Primitive(attributes=attrs, indices=b.accessor(idx))
    b.node(mesh=b.mesh(prim))
    b.save(folder / "m.glb")
    (folder / "s.toml").write_text(scene_head + '[[objects]]\nshape = "mesh"\nfile = "m.glb"\n')
    units = {"vertex": len(pos), "triangle": len(idx) // 3}
elif kind.endswith("texel") and kind != "environment texel":
    rgb = (np.random.default_rng(0).random((n, n, 3)) * 255).astype(np.uint8)
    Image.fromarray(rgb).save(folder / "t.png")
    key = {"colour texel": "base_color_map", "normal texel": "normal_map",
           "scalar texel": "metallic_map", "direction texel": "anisotropy_direction_map"}[kind]
    extra = "anisotropy = 0.5\n" if kind == "direction texel" else ""
    (folder / "s.toml").write_text(scene_head + f'[materials.m]\n{extra}{key} = "t.png"\n'
                                   '[[objects]]\nshape = "sphere"\nmaterial = "m"\n')
    units = {kind: n * n}
elif kind == "environment texel":
    w, h = 2 * n, n
    head = f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n".encode()
    body = np.random.default_rng(0).integers(0, 255, (h, w, 4), np.uint8)
    body[..., 3] = 128
    (folder / "e.hdr").write_bytes(head + body.tobytes())
    units = {kind: w * h}
elif kind == "mesh file byte":
    rng = np.random.default_rng(0)
    lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in rng.random((n, 3))]
    lines += [f"f {a} {b} {c}" for a, b, c in rng.integers(1, n + 1, (n, 3))]
    (folder / "m.obj").write_text("\n".join(lines) + "\n")
    (folder / "s.toml").write_text(scene_head + '[[objects]]\nshape = "mesh"\nfile = "m.obj"\n')
    units = {kind: (folder / "m.obj").stat().st_size}
peak_reset()
base = rss("VmRSS")
if kind == "environment texel":
    from app.textures.environment import environment_map
    from app.frame.lights import map_lights
    env = environment_map("image", str(folder / "e.hdr"))
else:
    from app.untrusted.budget import Budget
    from app.untrusted.policy import Limits
    limits = Limits(max_memory=1 << 50)
    kept = build_parts(load_scene(folder / "s.toml"), Budget(limits))
import ctypes, gc
gc.collect()
ctypes.CDLL("libc.so.6").malloc_trim(0)
print(json.dumps({"units": units, "peak": rss("VmHWM") - base, "kept": rss("VmRSS") - base}))
"""

SIZES = {
    "vertex": (200, 500),  # grid side: 40,000 and 250,000 vertices
    "colour texel": (512, 1536),
    "scalar texel": (512, 1536),
    "normal texel": (512, 1536),
    "direction texel": (512, 1536),
    "environment texel": (256, 1024),
    "mesh file byte": (20_000, 100_000),
}


def measure(kind: str, n: int) -> dict:
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, kind, str(n)],
        cwd=REPO, capture_output=True, text=True, check=True,
    )  # fmt: skip
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    print("| kind | units (small, large) | peak growth (small, large) | peak bytes per unit "
          "| bytes kept per unit |")  # fmt: skip
    print("|---|---|---|---|---|")
    for kind, (small, large) in SIZES.items():
        a, b = measure(kind, small), measure(kind, large)
        unit = kind if kind != "vertex" else "vertex"
        ua, ub = a["units"][unit], b["units"][unit]
        per = (b["peak"] - a["peak"]) / (ub - ua)
        kept = (b["kept"] - a["kept"]) / (ub - ua)
        print(f"| {kind} | {ua:,}, {ub:,} | {a['peak'] >> 20} MiB, {b['peak'] >> 20} MiB "
              f"| {per:.0f} | {kept:.0f} |")  # fmt: skip


if __name__ == "__main__":
    main()
