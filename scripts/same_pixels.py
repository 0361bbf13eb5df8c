"""Show that a change moved no pixel: every bundled scene's linear HDR output, bit for bit,
in this working tree and at another commit.

    .venv/bin/python scripts/same_pixels.py [REV]        (REV defaults to HEAD)

A refactor that claims "no change in any rendered pixel" runs this against the commit it
started from. The other commit is checked out into a temporary git worktree and both trees
render in their own child processes with the same interpreter and the same GL backend;
each child prints one SHA-256 per scene of the float32 HDR image (``Renderer.read_hdr``,
before exposure and tone mapping) and of the 8-bit display image. The script exits 1 and
names the scenes whose digests differ, 0 when every one matches. A scene the other commit
cannot read (it uses a key added since) is listed as new and not compared.

Only ``app.gl.context.create_context``, ``app.scene.loader.load_scene`` and
``Renderer(gl, loaded)`` / ``render()`` / ``read_hdr()`` / ``read_ldr()`` are used, so the
comparison works across refactors that keep that much of the API.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

# Run inside a child whose sys.path starts at the tree to measure.
_CHILD = r"""
import hashlib, json, sys
from pathlib import Path
import app
from app.gl.context import create_context
from app.render.renderer import Renderer
from app.scene.loader import load_scene

gl = create_context(sys.argv[2])
out = {}
for path in sorted(Path(sys.argv[1]).glob("*.toml")):
    try:
        renderer = Renderer(gl, load_scene(path))
    except Exception as exc:  # a scene this tree cannot read (a key added since)
        out[path.stem] = {"error": f"{type(exc).__name__}: {exc}"}
        continue
    try:
        renderer.render()
        hdr = renderer.read_hdr()
        ldr = renderer.read_ldr()
    finally:
        renderer.release()
    out[path.stem] = {
        "hdr": hashlib.sha256(hdr.astype("<f4").tobytes()).hexdigest(),
        "ldr": hashlib.sha256(ldr.tobytes()).hexdigest(),
        "shape": list(hdr.shape),
    }
print(json.dumps({"package": app.__file__, "scenes": out}))
"""


@contextlib.contextmanager
def checkout(rev: str) -> Iterator[Path]:
    """``rev`` checked out into a temporary git worktree, removed afterwards (also used by
    scripts/frame_against.py)."""
    with tempfile.TemporaryDirectory(prefix="pbs-rev-") as tmp:
        tree = Path(tmp) / "tree"
        subprocess.run(
            ["git", "-C", str(REPO), "worktree", "add", "--detach", "-q", str(tree), rev],
            check=True,
        )
        try:
            yield tree
        finally:
            subprocess.run(
                ["git", "-C", str(REPO), "worktree", "remove", "--force", str(tree)],
                check=False,
            )


def digests(tree: Path, scenes: Path, backend: str) -> dict[str, dict]:
    """{scene: {"hdr": sha256, "ldr": sha256, "shape": [H, W, 3]}} rendered by ``tree``."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    result = subprocess.run(
        [sys.executable, "-c", _CHILD, str(scenes), backend],
        cwd=tree,
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    if result.returncode != 0:
        raise SystemExit(f"same_pixels: rendering in {tree} failed:\n{result.stderr}")
    answer = json.loads(result.stdout.strip().splitlines()[-1])
    if not Path(answer["package"]).resolve().is_relative_to(tree.resolve()):
        raise SystemExit(f"same_pixels: the child imported {answer['package']}, not {tree}")
    return answer["scenes"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("rev", nargs="?", default="HEAD", help="the commit to compare with")
    parser.add_argument("--backend", choices=("auto", "egl", "osmesa"), default="auto")
    args = parser.parse_args(argv)
    scenes = REPO / "scenes"  # both trees render this tree's scene files
    with checkout(args.rev) as other:
        before = digests(other, scenes, args.backend)
    after = digests(REPO, scenes, args.backend)
    differ, new = [], []
    for name in sorted(after):
        if "error" in after[name]:
            print(f"{'BROKEN':9} {name}: {after[name]['error']}")
            differ.append(name)
        elif "error" in before.get(name, {"error": ""}):
            print(f"{'new':9} {name} ({args.rev} cannot read it)")
            new.append(name)
        else:
            same = before[name] == after[name]
            print(f"{'same' if same else 'DIFFERENT':9} {name}")
            if not same:
                differ.append(name)
    compared = len(after) - len(new)
    print(
        f"{compared - len(differ)} of {compared} scenes bit-identical to {args.rev}"
        + (f"; {len(new)} new" if new else "")
    )
    return 1 if differ else 0


if __name__ == "__main__":
    raise SystemExit(main())
