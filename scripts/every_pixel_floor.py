"""What the every-pixel FLIP against the area truth is made of, by scene and size
(docs/accuracy.md, "Every pixel: where the floor is"): rounding, the truth's own
convergence, edges against interior, and how a default, an aliased, a 4 x 4 and an 8 x 8
box-filtered frame fall as the image grows.

    python scripts/every_pixel_floor.py [--scenes NAME...] [--widths 160 320 640]

Each truth (8 x 8 rays a pixel, 32 x 32 on edges and sub-pixel highlights) is checked
against one of twice the rays per side; it is the heavy part (minutes at 640 wide on
llvmpipe's machine), so this stays out of the tests and the quick bench.
"""

from __future__ import annotations

import argparse
import sys
import time

from app.bench.raycast import FLOOR_ROWS, every_pixel_floor
from app.frame.raycast import area_reference_scene
from scripts.accuracy_doc import TARGET_FLIP, _scene, _size


def _f(x: float | None) -> str:
    return "–" if x is None else f"{x:.2e}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", nargs="+", default=["five spheres", "sec9_diffuse_retro"])
    parser.add_argument("--widths", nargs="+", type=int, default=[160, 320, 640])
    args = parser.parse_args(argv)
    from app.gl.context import create_context

    gl = create_context("egl")
    rows = [f"`{r}` 8-bit (float), edge / interior" for r in FLOOR_ROWS]
    head = "| scene | size | edge pixels | rounding alone | truth 8x8 vs 16x16 | "
    print(head + " | ".join(rows) + " |")
    print("|---" * (5 + len(rows)) + "|")
    verdicts = []
    try:
        for name in args.scenes:
            loaded = _scene(name)
            for width in args.widths:
                start = time.perf_counter()
                size = _size(loaded, width)
                truth = area_reference_scene(loaded, size, 8, 32)
                finer = area_reference_scene(loaded, size, 16, 64)
                e = every_pixel_floor(gl, loaded, size, truth, finer)
                cells = [
                    f"{_f(e[f'{r}_8bit'])} ({_f(e[f'{r}_float'])}), {_f(e[f'{r}_edge'])} / "
                    f"{_f(e[f'{r}_interior'])}"
                    for r in FLOOR_ROWS
                ]
                print(
                    f"| `{name}` | {size[0]}×{size[1]} | {100 * e['edge_share']:.1f} % |"
                    f" {_f(e['quantisation'])} | {_f(e['truth'])} | " + " | ".join(cells) + " |",
                    flush=True,
                )
                verdicts.append((name, size, e["defaults_8bit"]))
                print(f"every_pixel_floor: {name} {size} {time.perf_counter() - start:.0f} s",
                      file=sys.stderr)  # fmt: skip
    finally:
        gl.release()
    for name, size, flip in verdicts:
        ok = "PASS" if flip <= TARGET_FLIP else "FAIL"
        print(f"{ok}: `{name}` {size[0]}×{size[1]} defaults 8-bit display FLIP {flip:.2e}"
              f" (target ≤ {TARGET_FLIP:.0e})")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
