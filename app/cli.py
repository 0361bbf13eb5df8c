"""pbs: the physically based shading lab's command line.

Exit codes: 0 success, 2 bad input (one line naming the file and key), 1 anything else.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import NoReturn

from app.errors import EXIT_BAD_INPUT, InputError
from app.output import HDR_SUFFIXES, write_hdr, write_png


def _size(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"(\d+)[xX](\d+)", text)
    if not match or not all(1 <= int(g) <= 16384 for g in match.groups()):
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT within 1..16384, got '{text}'")
    return int(match.group(1)), int(match.group(2))


class _Parser(argparse.ArgumentParser):
    """argparse whose usage errors are one line, like every other bad input."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"pbs: error: {message} (see '{self.prog} --help')\n")


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="pbs", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    render = sub.add_parser("render", help="render a scene file headless to PNG")
    render.add_argument("scene", help="scene file (TOML); a bundled scene's name also works")
    render.add_argument("-o", "--output", required=True, help="PNG file to write")
    render.add_argument("--size", type=_size, help="WIDTHxHEIGHT (default: the scene's)")
    render.add_argument("--hdr", help="also write the linear HDR image (.exr or .npy)")
    render.add_argument(
        "--backend",
        choices=("auto", "egl", "osmesa"),
        default="auto",
        help="headless OpenGL backend (default: EGL, then OSMesa)",
    )
    render.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
    return parser


def _resolve_scene(name: str) -> Path:
    path = Path(name)
    if path.exists() or path.suffix:
        return path
    from app.resources import scenes_dir

    bundled = scenes_dir() / f"{name}.toml"
    return bundled if bundled.exists() else path


def _write(path: Path, option: str, write: Callable[[Path], None]) -> None:
    try:
        write(path)
    except OSError as exc:
        why = f"{exc.strerror}: {exc.filename}" if exc.filename else str(exc.strerror or exc)
        raise InputError(str(path), option, f"cannot write ({why})") from None


def cmd_render(args: argparse.Namespace) -> int:
    from app.gl.context import create_context
    from app.render.renderer import Renderer
    from app.scene.loader import load_scene

    start = time.perf_counter()
    out = Path(args.output)
    if out.suffix.lower() != ".png":
        raise InputError(str(out), "-o", "the output must be a .png file")
    if args.hdr and Path(args.hdr).suffix not in HDR_SUFFIXES:  # write_hdr: lower case only
        raise InputError(args.hdr, "--hdr", "the HDR output must end in .exr or .npy")
    loaded = load_scene(_resolve_scene(args.scene))
    gl = create_context(args.backend)
    renderer = Renderer(gl, loaded, args.size)
    renderer.render()
    ldr = renderer.read_ldr()
    hdr = renderer.read_hdr() if args.hdr else None
    renderer.release()
    if hdr is not None:
        _write(Path(args.hdr), "--hdr", lambda p: write_hdr(p, hdr))
    _write(out, "-o", lambda p: write_png(p, ldr))
    if not args.quiet:
        w, h = renderer.size
        print(
            f"{out}: {w}x{h}, {len(loaded.scene.lights)} lights, {gl.backend} "
            f"({gl.renderer}), {time.perf_counter() - start:.2f} s"
        )
    gl.release()
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pbs`` and ``python -m app``."""
    parser = _parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse exits 2 on bad arguments, 0 on --help
        return int(exc.code or 0)
    handlers = {"render": cmd_render}
    try:
        return handlers[args.command](args)
    except InputError as exc:
        print(f"pbs: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT


if __name__ == "__main__":
    raise SystemExit(main())
