"""Time the 1-light frame of this working tree against another commit's: the
fixed-cost target ("at least 2x faster than the commit before the change").

    .venv/bin/python scripts/frame_against.py REV [--blocks 10] [--frames 6]

The frame is what a pipeline pays for one image: ``render()`` then ``read_ldr()`` (the
8-bit image in numpy), waited for with glFinish. Two scenes at 1280x720, built by this
tree's bench: the culling scene with one light whose range reaches every pixel of its
cone (``many_lights_scene`` and ``calibrate_range``, as the bench's ``frame`` row), and
the 35 spheres of the pyrender comparison (``sphere_grid_scene``); each tree at its own
default light culling (the key is removed). Each tree renders in a child process of its
own, both alive together; the parent asks them in turn for blocks of frames, alternating
which goes first, so that a slow minute of the machine falls on both. Reported: each tree's
median frame, and the median over blocks of (this tree / REV) of the blocks' medians.
The children's display images must be equal (SHA-256), or the script exits 1: the
target allows no image change.

The other commit is checked out into a temporary git worktree (scripts/same_pixels.py
``checkout``). Only ``create_context``, ``parse_scene``, ``Renderer(gl, loaded, size)``,
``render`` and ``read_ldr`` are used from it.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from same_pixels import REPO, checkout  # scripts/ is the script's own folder on sys.path

SIZE = (1280, 720)

# A child: renders the scene in argv[1] (JSON) on demand; stdin lines are frame counts.
_CHILD = r"""
import hashlib, json, sys, time
from pathlib import Path
import app
from app.gl.context import create_context
from app.render.renderer import Renderer
from app.scene.loader import parse_scene

data = json.loads(Path(sys.argv[1]).read_text())
gl = create_context("egl")
r = Renderer(gl, parse_scene(data, Path(sys.argv[1]).with_suffix(".toml")), (1280, 720))

def frame():
    r.render()
    image = r.read_ldr()
    gl.ctx.finish()
    return image

for _ in range(3):
    image = frame()
digest = hashlib.sha256(image.tobytes()).hexdigest()
print(json.dumps({"package": app.__file__, "ldr": digest}), flush=True)
for line in sys.stdin:
    times = []
    for _ in range(int(line)):
        start = time.perf_counter()
        frame()
        times.append(1e3 * (time.perf_counter() - start))
    print(json.dumps(times), flush=True)
"""


def scenes(folder: Path) -> dict[str, Path]:
    """The two scenes as JSON files in ``folder``, built with this tree's bench."""
    sys.path.insert(0, str(REPO))
    from app.bench.scenes import calibrate_range, many_lights_scene
    from app.bench.spheres import sphere_grid_scene
    from app.gl.context import create_context

    gl = create_context("egl")
    try:
        reach = calibrate_range(gl, 1, 16.0)
    finally:
        gl.release()
    out = {}
    for name, data in (
        ("culling scene", many_lights_scene(1, reach, SIZE)),
        ("35 spheres", sphere_grid_scene(1, SIZE)),
    ):
        data["render"].pop("light_culling", None)  # each tree's own default
        path = folder / f"{name.replace(' ', '_')}.json"
        path.write_text(json.dumps(data))
        out[name] = path
    return out


def compare(trees: dict[str, Path], scene: Path, blocks: int, frames: int) -> dict:
    """Each tree's frame times and the per-block ratios of the last tree to the first."""
    children = {
        label: subprocess.Popen(
            [sys.executable, "-c", _CHILD, str(scene)],
            cwd=tree,
            env={**os.environ, "PYTHONPATH": str(tree)},
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        for label, tree in trees.items()
    }
    try:
        ready = {}
        for label, child in children.items():
            line = child.stdout.readline()
            if not line:
                raise SystemExit(f"frame_against: the {label} tree failed on {scene.name}")
            ready[label] = json.loads(line)
            if not Path(ready[label]["package"]).resolve().is_relative_to(trees[label].resolve()):
                raise SystemExit(f"frame_against: {label} imported {ready[label]['package']}")
        times = {label: [] for label in children}
        ratios = []
        labels = list(children)
        for block in range(blocks):
            medians = {}
            for label in labels if block % 2 == 0 else labels[::-1]:
                children[label].stdin.write(f"{frames}\n")
                children[label].stdin.flush()
                block_times = json.loads(children[label].stdout.readline())
                times[label] += block_times
                medians[label] = statistics.median(block_times)
            ratios.append(medians[labels[1]] / medians[labels[0]])
    finally:
        for child in children.values():
            child.stdin.close()
            child.wait()
    same = len({answer["ldr"] for answer in ready.values()}) == 1
    return {"times": times, "ratios": ratios, "same": same}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("rev", help="the commit to time against")
    parser.add_argument("--blocks", type=int, default=10)
    parser.add_argument("--frames", type=int, default=6, help="frames per block")
    args = parser.parse_args(argv)
    status = 0
    with checkout(args.rev) as other, tempfile.TemporaryDirectory(prefix="frames-") as tmp:
        for name, scene in scenes(Path(tmp)).items():
            result = compare({args.rev: other, "this tree": REPO}, scene, args.blocks,
                             args.frames)  # fmt: skip
            ratios = result["ratios"]
            for label, times in result["times"].items():
                print(f"{name}: {label} {statistics.median(times):.1f} ms per frame "
                      f"({min(times):.1f}-{max(times):.1f}, {len(times)} frames)")  # fmt: skip
            print(f"{name}: this tree / {args.rev} = {statistics.median(ratios):.3f} "
                  f"({min(ratios):.3f}-{max(ratios):.3f} over {len(ratios)} blocks); "
                  f"images {'equal' if result['same'] else 'DIFFERENT'}")  # fmt: skip
            if not result["same"]:
                status = 1
    return status


if __name__ == "__main__":
    raise SystemExit(main())
