"""Real assets against the input limits: what each one declares, what the budget charges
for it, what loading and rendering it really took, and how far it stays from every limit
(docs/stability.md, "Limits").

    .venv/bin/python scripts/real_assets.py FOLDER [--png OUT_FOLDER]

Every ``.gltf`` and ``.glb`` under FOLDER (the Khronos glTF sample models, say) is rendered
in a child process of its own, at 320 x 180 with the default limits, the asset's folder
allowed. A line per asset: its triangles, drawn parts, nodes and textures (largest side),
the decoded-input budget's estimated peak (app/untrusted/budget.py), to hold against the
limit, the GPU
total (app/render/limits.py), the peak resident set the child reached, the seconds, and
the outcome (``ok`` or the one-line refusal). Nothing is downloaded: point it at a copy.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

_CHILD = r"""
import json, sys, time
from pathlib import Path

def rss(name):
    for line in open("/proc/self/status"):
        if line.startswith(name):
            return int(line.split()[1]) << 10

asset, png = Path(sys.argv[1]), sys.argv[2]
from app.errors import InputError
from app.gl.context import create_context
from app.render.limits import gpu_bytes
from app.render.renderer import Renderer
from app.scene.loader import parse_scene
from app.scene.gltf_document import open_gltf
from app.untrusted.budget import Budget
from app.untrusted.policy import InputPolicy
import app.scene.geometry as geometry

policy = InputPolicy.from_options([asset.parent])
doc = open_gltf(asset, policy)
info = {"nodes": len(doc.nodes or []), "images": len(doc.images or [])}
budgets = []
original = geometry.build_parts

def build_parts(loaded, budget=None):
    budget = budget or Budget(loaded.policy.limits)
    budgets.append(budget)
    return original(loaded, budget)

geometry.build_parts = build_parts
import app.frame
app.frame.build_parts = build_parts
data = {
    "camera": {"position": [0.0, 0.0, 3.0], "target": [0.0, 0.0, 0.0]},
    "lights": [{"type": "directional", "direction": [-0.3, -1.0, -0.5]}],
    "objects": [{"shape": "mesh", "file": str(asset)}],
}
start = time.perf_counter()
try:
    loaded = parse_scene(data, Path.cwd() / "real-asset.toml", policy)
    gl = create_context("egl")
    r = Renderer(gl, loaded, (320, 180))
    r.render()
    if png:
        from app.output import write_png
        write_png(Path(png), r.read_ldr())
    b = budgets[-1]
    info.update(outcome="ok", spent=b.peak, parts=b.parts, triangles=b.triangles,
                gpu=sum(gpu_bytes(r.frame.parts)))
    side = max((max(t.pixels.shape[:2]) for p in r.frame.parts for layer in p.layers
                for t in layer.maps.values()), default=0)
    info["texture_side"] = side
    r.release()
    gl.release()
except InputError as exc:
    info.update(outcome=str(exc).split(": ", 1)[-1])
info.update(seconds=time.perf_counter() - start, peak=rss("VmHWM"))
print(json.dumps(info))
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path)
    parser.add_argument("--png", type=Path, help="also write each render here")
    args = parser.parse_args()
    assets = sorted(p for p in args.folder.rglob("*") if p.suffix.lower() in (".gltf", ".glb"))
    if args.png:
        args.png.mkdir(parents=True, exist_ok=True)
    print("| asset | triangles | parts | nodes | images (largest side) | budget used "
          "| GPU | peak RSS | s | outcome |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|---|")
    for asset in assets:
        name = str(asset.relative_to(args.folder))
        png = str(args.png / (name.replace("/", "_") + ".png")) if args.png else ""
        run = subprocess.run(
            [sys.executable, "-c", _CHILD, str(asset), png],
            cwd=REPO, capture_output=True, text=True, timeout=600,
        )  # fmt: skip
        if run.returncode != 0 or not run.stdout.strip():
            print(f"| {name} | | | | | | | | | child failed: {run.stderr.strip()[-120:]} |")
            continue
        i = json.loads(run.stdout.strip().splitlines()[-1])
        mib = 1 << 20
        print(
            f"| {name} | {i.get('triangles', '')} | {i.get('parts', '')} | {i['nodes']} "
            f"| {i['images']} ({i.get('texture_side', '')}) | {i.get('spent', 0) // mib} MiB "
            f"| {i.get('gpu', 0) // mib} MiB | {i['peak'] // mib} MiB | {i['seconds']:.1f} "
            f"| {i['outcome'][:80]} |"
        )


if __name__ == "__main__":
    main()
