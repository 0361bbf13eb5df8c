"""pbs: the physically based shading lab's command line.

Exit codes: 0 success, 2 bad input (one line naming the file and key), 1 anything else.
"""

from __future__ import annotations

import argparse
import atexit
import contextlib
import logging
import math
import os
import re
import sys
import time
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

import app.code_cache as code_table  # first: the code dataclasses and typing compile, cached
from app.common.debug_views import DEBUG_VIEWS, LIGHT_VIEWS
from app.errors import EXIT_BAD_INPUT, InputError
from app.untrusted import RefusedError, files
from app.untrusted.policy import InputPolicy

if TYPE_CHECKING:
    import numpy as np

    from app.gl.context import GLContext
    from app.render.renderer import Renderer
    from app.scene.loader import LoadedScene
    from app.scene.look import Look
    from app.textures.maps import PreparedLevels
    from app.waiting import Ahead


def _size(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"(\d+)[xX](\d+)", text)
    if not match or not all(1 <= int(g) <= 16384 for g in match.groups()):
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT within 1..16384, got '{text}'")
    return int(match.group(1)), int(match.group(2))


def _one_line(text: str) -> str:
    """``text`` with every character that is not printable written as an escape (\\n,
    \\x1e, \\u2028): an error quotes keys and values from the user's file, and a line
    break or record separator among them must not split the one-line error (found by
    tests/test_fuzz_scenes.py: an unknown key named "\\x1e")."""
    return "".join(c if c.isprintable() else ascii(c)[1:-1] for c in text)


class _Parser(argparse.ArgumentParser):
    """argparse whose usage errors are one line, like every other bad input."""

    def error(self, message: str) -> NoReturn:
        message = _one_line(message)
        self.exit(EXIT_BAD_INPUT, f"pbs: error: {message} (see '{self.prog} --help')\n")


def _memory(text: str) -> int:
    """``--max-memory``: bytes, with an optional K, M, G or T suffix (powers of 1024)."""
    match = re.fullmatch(r"(\d+(?:\.\d+)?)\s*([KMGT]?)i?B?", text.strip(), re.IGNORECASE)
    if not match:
        raise argparse.ArgumentTypeError(f"expected a size such as 8G or 512M, got '{text}'")
    scale = 1024 ** "KMGT".find(match.group(2).upper()) * 1024 if match.group(2) else 1
    value = int(float(match.group(1)) * scale)
    if not 1 << 20 <= value <= 1 << 50:
        raise argparse.ArgumentTypeError(f"expected a size within 1M..1024T, got '{text}'")
    return value


def _input_options(parser: argparse.ArgumentParser) -> None:
    """``--allow-path`` and ``--max-memory``: what the input may read and cost
    (app/untrusted/policy.py, docs/stability.md "Untrusted input")."""
    parser.add_argument(
        "--allow-path",
        action="append",
        default=[],
        metavar="DIR",
        help="a folder (besides each file's own and the bundled data) that the files an "
        "input names may be read from; repeatable",
    )
    parser.add_argument(
        "--max-memory",
        type=_memory,
        metavar="SIZE",
        help="the most memory an input's decoded meshes and textures, and its GPU "
        "resources, may take (default 4G); larger inputs exit 2",
    )


def _look_options(parser: argparse.ArgumentParser, view: str = "three-quarter") -> None:
    """How a model file (or a scene file without camera or lights) is shown
    (app/scene/model_file.py, docs/scene-format.md); ``view`` the default view."""
    from app.scene.look import VIEWS

    parser.add_argument(
        "--view",
        choices=tuple(VIEWS),
        default=view,
        help=f"a model file's view: the camera's direction (default {view})",
    )
    parser.add_argument(
        "--azimuth",
        type=_number(lambda v: -360.0 <= v <= 360.0, "degrees within -360..360"),
        metavar="DEG",
        help="a model file's camera azimuth about +Y, from +Z towards +X",
    )
    parser.add_argument(
        "--elevation",
        type=_number(lambda v: -90.0 <= v <= 90.0, "degrees within -90..90"),
        metavar="DEG",
        help="a model file's camera elevation above the horizon",
    )
    parser.add_argument(
        "--camera",
        choices=("auto", "file"),
        default="auto",
        help="a model file's camera: framed (auto, default) or the glTF file's first (file)",
    )
    parser.add_argument(
        "--animation",
        metavar="NAME|INDEX",
        help="a glTF model's animation to pose it by, by name or index (default: none, the "
        "rest pose; with --time alone, the first); docs/gltf.md",
    )
    parser.add_argument(
        "--time",
        type=_number(lambda v: -1e9 <= v <= 1e9, "seconds within -1e9..1e9"),
        metavar="SECONDS",
        help="the time of the animation shown, clamped to its range (default: its start)",
    )
    parser.add_argument(
        "--variant",
        metavar="NAME",
        help="a glTF model's KHR_materials_variants variant (default: its own materials)",
    )
    parser.add_argument(
        "--env",
        default="studio",
        metavar="studio|sky|FILE",
        help="a model file's environment: the bundled studio (default), the sky, or an "
        ".hdr/.exr image",
    )


def _look(args: argparse.Namespace) -> Look:
    """The ``Look`` of the look options, or an ``InputError`` naming the option."""
    from app.scene.look import Look

    if args.env not in ("studio", "sky") and Path(args.env).suffix.lower() not in (
        ".hdr",
        ".exr",
    ):
        raise InputError(args.env, "--env", "expected studio, sky or an .hdr/.exr file")
    if args.env not in ("studio", "sky"):
        try:
            files.check_readable(Path(args.env), 1 << 62)  # its size is checked when read
        except RefusedError as exc:
            raise InputError(args.env, "--env", str(exc).removeprefix(f"{args.env}: ")) from None
    return Look(
        args.view, args.azimuth, args.elevation, args.camera, args.env,
        args.animation, args.time, args.variant,
    )  # fmt: skip


@contextlib.contextmanager
def _silenced(logger: str, quiet: bool) -> Iterator[None]:
    """The ``logger``'s notes dropped while ``quiet`` (``-q``: nothing on success)."""
    log = logging.getLogger(logger)
    was = log.disabled
    log.disabled = was or quiet
    try:
        yield
    finally:
        log.disabled = was


def _policy(args: argparse.Namespace) -> InputPolicy:
    return InputPolicy.from_options(args.allow_path, args.max_memory)


def _gl_backend(parser: argparse.ArgumentParser, devices: bool = False) -> None:
    """The ``--backend`` and ``--device`` options of the commands that render headless
    (with ``devices``, ``pbs batch``'s ``--devices`` too, the two exclusive)."""
    parser.add_argument(
        "--backend",
        choices=("auto", "egl", "osmesa"),
        default="auto",
        help="headless OpenGL backend (default: EGL, then OSMesa)",
    )
    group = parser.add_mutually_exclusive_group() if devices else parser
    group.add_argument(
        "--device",
        type=_device_index,
        metavar="N",
        help="the EGL device to render on: its index in 'pbs devices' (default: "
        "$PBS_EGL_DEVICE, else EGL's first); OSMesa ignores it",
    )
    if devices:
        group.add_argument(
            "--devices",
            type=_device_list,
            metavar="N,M",
            help="EGL devices the workers spread over, round-robin: worker k on the "
            "(k mod count)-th listed",
        )


def _device_list(text: str) -> tuple[int, ...]:
    """``--devices``: comma-separated EGL device indexes."""
    try:
        return tuple(_device_index(part.strip()) for part in text.split(","))
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated device indexes (0,1), got '{text}'"
        ) from None


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="pbs", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    render = sub.add_parser(
        "render",
        help="render a scene file headless to PNG",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="debug views (--debug VIEW; docs/debug-views.md):\n"
        + "\n".join(f"  {name:12} {line}" for name, line in DEBUG_VIEWS.items()),
    )
    render.add_argument(
        "scene",
        help="scene file (TOML), a bundled scene's name, or a model file (.glb, .gltf, "
        ".obj, .stl, .ply) to show framed and lit by the defaults",
    )
    render.add_argument("-o", "--output", required=True, help="PNG file to write")
    render.add_argument(
        "--size",
        type=_size,
        help="WIDTHxHEIGHT (default: the scene's); the limit is the machine's: width and "
        "height times render.supersample at most the GL's largest render target "
        "(GL_MAX_TEXTURE_SIZE, 16384 under llvmpipe) and the render targets at most 4 GiB "
        "(docs/scene-format.md, 'Image size limits'); a larger size exits 2",
    )
    render.add_argument(
        "--fit",
        action="store_true",
        help="with --size of another aspect ratio than the scene's: keep the scene's whole "
        "framing (a narrower image widens the vertical field of view; a wider one shows "
        "more at the sides)",
    )
    render.add_argument("--hdr", help="also write the linear HDR image (.exr or .npy)")
    render.add_argument(
        "--background",
        choices=("opaque", "transparent"),
        help="transparent: an RGBA PNG whose alpha is the antialiased coverage (straight "
        "alpha), and an --hdr image with premultiplied RGB and A; opaque: the scene's "
        "background (default: the scene's render.background)",
    )
    _gl_backend(render)
    render.add_argument(
        "--debug",
        metavar="VIEW",
        choices=tuple(DEBUG_VIEWS),
        help="write a debug view instead of the render: one of the views listed below",
    )
    render.add_argument(
        "--debug-light",
        type=int,
        metavar="N",
        help="the light (index into the scene's lights, in the order they are summed: "
        "directional first) of the views fresnel, ndf, g2, specular, diffuse, light "
        "(default 0)",
    )
    render.add_argument(
        "--compare",
        metavar="KEY=A,B",
        help="split-screen comparison: render the scene with the key set to A on the left "
        "and to B on the right; A and B are TOML values "
        '(materials.gold.fresnel=\'"schlick","conductor"\', docs/compare.md)',
    )
    render.add_argument(
        "--compare-mode",
        choices=("split", "difference"),
        help="with --compare: the two halves with a divider line (default), or |A - B| of "
        "the linear radiance times --gain",
    )
    render.add_argument(
        "--divider",
        type=_fraction,
        help="with --compare: where the split falls, a fraction of the width (default 0.5)",
    )
    render.add_argument(
        "--gain",
        type=_gain,
        help="with --compare-mode difference: magnification of |A - B| (default 8)",
    )
    _look_options(render)
    _input_options(render)
    render.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
    _brdf_parser(sub)
    _batch_parser(sub)
    sub.add_parser(
        "devices",
        help="list the devices EGL enumerates (for --device), with the GL of each",
        description="One line per device EGL enumerates (eglQueryDevicesEXT), in the order "
        "--device and PBS_EGL_DEVICE count: its index, its kind (Mesa's software "
        "device, a DRM device file, a CUDA device) and GL_VENDOR and GL_RENDERER of an "
        "OpenGL 3.3 context made on it. Exit 1 where EGL cannot enumerate devices.",
    )
    _textures_parser(sub)
    _gallery_parser(sub)
    _walkthrough_parser(sub)
    view = sub.add_parser(
        "view",
        help="open the desktop viewer on a scene (glfw window, Dear ImGui panels)",
        description="Open a window on a scene: orbit (left-drag), pan (right- or shift-drag), "
        "zoom (wheel), click to select, F frame, R reset, Tab panels, Ctrl+S save, P "
        "screenshot (Shift+P with HDR). docs/viewer.md.",
    )
    view.add_argument("scene", nargs="?", help="scene file or bundled name (default: showcase)")
    view.add_argument("--size", type=_size, default=(960, 540), help="window WIDTHxHEIGHT")
    view.add_argument("--no-vsync", action="store_true", help="do not wait for the display")
    view.add_argument(
        "--walkthrough",
        action="store_true",
        help="open the classroom walkthrough's panel on its step (docs/walkthrough.md)",
    )
    _lang_option(view, "the walkthrough's language")
    view.add_argument(
        "--step", type=int, default=1, metavar="N", help="the walkthrough's step: RTR4 §9.N"
    )
    _look_options(view)
    _input_options(view)
    sub.add_parser(
        "bench",
        help="measure run time against error (options: pbs bench --help)",
        add_help=False,
    )
    return parser


def _number(accept: Callable[[float], bool], expected: str) -> Callable[[str], float]:
    """An argparse type: a float that ``accept`` takes (NaN never passes a comparison)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not accept(value):
            raise argparse.ArgumentTypeError(f"expected {expected}, got '{text}'")
        return value

    return parse


_fraction = _number(lambda x: 0.0 <= x <= 1.0, "a number within 0..1")
_gain = _number(lambda x: 0.0 < x <= 1e6, "a number > 0 and <= 1e6")


def _thetas(text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(part) for part in text.split(","))
    except ValueError:
        values = ()
    if not values or not all(0.0 <= t <= 90.0 for t in values):  # also rejects nan
        raise argparse.ArgumentTypeError(
            f"expected comma-separated angles in degrees within 0..90, got '{text}'"
        )
    return values


def _integer(low: int, high: int) -> Callable[[str], int]:
    """An argparse type: a whole number within low..high (digits only, no sign)."""

    def parse(text: str) -> int:
        if not re.fullmatch(r"\d+", text) or not low <= int(text) <= high:
            raise argparse.ArgumentTypeError(
                f"expected an integer within {low}..{high}, got '{text}'"
            )
        return int(text)

    return parse


_dpi = _integer(10, 1200)
_workers = _integer(1, 256)
_device_index = _integer(0, 1023)


def _brdf_parser(sub: argparse._SubParsersAction) -> None:
    """The ``brdf`` subcommand's arguments (docs/brdf-explorer.md)."""
    brdf = sub.add_parser(
        "brdf",
        help="plot BRDF lobes and directional albedo of materials to PNG",
        description="Plot the lobe in the plane of incidence and the directional albedo of "
        "each material, one column per material (docs/brdf-explorer.md).",
    )
    brdf.add_argument(
        "materials",
        nargs="+",
        metavar="MATERIAL-OR-SCENE",
        help="a preset name (gold), a scene file (all its materials, or scene.toml:NAME), "
        "or an inline TOML table ('{ ndf = \"beckmann\", roughness = 0.3 }')",
    )
    brdf.add_argument("-o", "--output", required=True, help="PNG file to write")
    brdf.add_argument(
        "--backend",
        choices=("glsl", "reference"),
        default="glsl",
        help="evaluate the renderer's GLSL (default) or its float64 twin",
    )
    brdf.add_argument(
        "--theta",
        type=_thetas,
        default=(0.0, 30.0, 60.0, 80.0),
        help="incident angles of the lobe curves, degrees (default 0,30,60,80)",
    )
    brdf.add_argument(
        "--quantity",
        choices=("fcos", "f"),
        default="fcos",
        help="lobe radius: f(l,v) cos(theta_v) (default) or f(l,v)",
    )
    brdf.add_argument("--log", action="store_true", help="log radius (4 decades) for the lobes")
    brdf.add_argument("--rgb", action="store_true", help="lobe per RGB channel, not luminance")
    brdf.add_argument("--size", type=_size, help="WIDTHxHEIGHT in pixels (default: by --dpi)")
    brdf.add_argument(
        "--dpi", type=_dpi, help="pixels per inch (default 100; a column is 4.6 x 7.4 in)"
    )
    brdf.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")


def _sections(text: str) -> set[int]:
    try:
        values = {int(part) for part in text.split(",")}
    except ValueError:
        values = set()
    if not values or not all(1 <= n <= 13 for n in values):
        raise argparse.ArgumentTypeError(
            f"expected comma-separated section numbers within 1..13, got '{text}'"
        )
    return values


def _lang_option(parser: argparse.ArgumentParser, what: str) -> None:
    """``--lang en|ko``, the walkthrough's language (Korean needs a Hangul font)."""
    parser.add_argument(
        "--lang",
        choices=("en", "ko"),
        default="en",
        help=f"{what} (default en; ko needs a font with Hangul glyphs, fonts-noto-cjk)",
    )


def _walkthrough_parser(sub: argparse._SubParsersAction) -> None:
    """The ``walkthrough`` subcommand's arguments (docs/walkthrough.md)."""
    walkthrough = sub.add_parser(
        "walkthrough",
        help="render the classroom walkthrough's steps into an offline HTML handout",
        description="Render every step of the walkthrough (labelled views, A/B comparisons "
        "with their difference, sweeps, BRDF plots) and write DIR/index.html, an offline "
        "handout that prints on A4, and DIR/walkthrough.md (docs/walkthrough.md).",
    )
    walkthrough.add_argument("--out", required=True, metavar="DIR", help="folder to write")
    _lang_option(walkthrough, "language of the text")
    walkthrough.add_argument(
        "--size",
        type=_size,
        help="WIDTHxHEIGHT of every image (default: each scene's own); the scene's whole "
        "framing is kept at any aspect ratio (as pbs render --fit)",
    )
    walkthrough.add_argument(
        "--steps", type=_sections, metavar="N,M", help="only these sections (default: all)"
    )
    walkthrough.add_argument(
        "--folder", help="the step files' folder (default: the bundled walkthrough/)"
    )
    _gl_backend(walkthrough)
    walkthrough.add_argument(
        "-q", "--quiet", action="store_true", help="no progress bar, no summary"
    )


def _batch_parser(sub: argparse._SubParsersAction) -> None:
    """The ``batch`` subcommand's arguments (docs/batch.md)."""
    batch = sub.add_parser(
        "batch",
        help="render many images from a job file: an orbit, a key sweep, a list of scenes",
        description="Render every image of a job file into DIR on warm GL contexts, with "
        "DIR/manifest.jsonl (one line per job). Exit 0: every job ok or already done; 1: "
        "some jobs failed (listed at the end; the others ran); 2: bad job file or "
        "arguments. docs/batch.md.",
    )
    batch.add_argument("jobs", help="job file (TOML, or JSON by its .json suffix)")
    batch.add_argument("-o", "--output", required=True, metavar="DIR", help="folder to write")
    batch.add_argument(
        "--workers", type=_workers, default=1, metavar="N",
        help="worker processes, each with one GL context (default 1: in this process)",
    )  # fmt: skip
    batch.add_argument(
        "--no-resume", action="store_true",
        help="render every job again (default: skip outputs that are valid PNGs already)",
    )  # fmt: skip
    dask = batch.add_mutually_exclusive_group()
    dask.add_argument(
        "--scheduler", metavar="ADDRESS",
        help="run the jobs on a Dask distributed cluster (tcp://host:8786); needs the "
        "'distributed' extra",
    )  # fmt: skip
    dask.add_argument(
        "--dask-local", type=_workers, metavar="N",
        help="run the jobs on a new local Dask cluster of N worker processes",
    )  # fmt: skip
    _gl_backend(batch, devices=True)
    _input_options(batch)
    batch.add_argument("-q", "--quiet", action="store_true", help="no progress bar, no summary")


def _textures_parser(sub: argparse._SubParsersAction) -> None:
    """The ``textures`` subcommand's arguments (docs/textures.md)."""
    textures = sub.add_parser(
        "textures",
        help="write the procedural textures (rust mask, normal map, ...) as PNG files",
        description="Generate the procedural textures of app/textures/procedural.py and write "
        "them as PNG files, or check that the files in a folder hold them (docs/textures.md).",
    )
    textures.add_argument(
        "--out", help="folder to write to or check (default: the bundled scenes/textures/)"
    )
    textures.add_argument(
        "--check",
        action="store_true",
        help="write nothing; exit 1 listing the files whose pixels differ from the generators",
    )
    textures.add_argument("-q", "--quiet", action="store_true", help="print only problems")


def _write(path: Path, option: str, write: Callable[[Path], None]) -> None:
    try:
        write(path)
    except OSError as exc:
        why = f"{exc.strerror}: {exc.filename}" if exc.filename else str(exc.strerror or exc)
        raise InputError(str(path), option, f"cannot write ({why})") from None


def _check_output(
    path: Path, option: str, inputs: set[Path] | frozenset[Path] = frozenset()
) -> None:
    """An output path that may be written: not an input of the command, not a device,
    FIFO or folder (app/untrusted/files.py ``check_output``). A missing parent folder is
    no refusal: writing makes it, like ``mkdir -p`` (app/output.py ``atomic_write``, and
    ``run_batch`` for ``pbs batch -o``; docs/scene-format.md "Errors")."""
    try:
        files.check_output(path, inputs)
    except RefusedError as exc:
        raise InputError(str(path), option, str(exc)) from None


def _debug_image(
    renderer: Renderer, view: str, light: int, out: Path, scene: Path
) -> tuple[np.ndarray, str | None]:
    """The display image of debug view ``view`` of the rendered frame, and the line the
    view reports (the nan view's counts, printed even with -q), or None."""
    from app.render.debug_views import DebugPass

    debug = DebugPass(renderer)
    try:
        debug.run(view, light)
        image = debug.read_display()
        bad = debug.bad_pixels
        if view == "tiles" and not debug.tiled:
            print(
                f"pbs: note: {scene}: no tile culling in this frame (no local lights, or "
                'render.light_culling = "none"): the tiles view is zero everywhere',
                file=sys.stderr,
            )
    finally:
        debug.release()
    if bad is None:
        return image, None
    from app.render.debug import describe

    pixels = image.shape[0] * image.shape[1]
    return image, f"{out}: NaN debug view: {describe(bad)} of {pixels} pixels"


def _size_option(exc: InputError) -> InputError:
    """A renderer's refusal of its ``size`` (app/render/limits.py) as the CLI's option."""
    return InputError(exc.file, "--size" if exc.key == "size" else exc.key, exc.message)


def _release_writes() -> None:
    """Let the prepared-texture cache write the entries it held while a still's scene was
    read (app/textures/background.py ``writes_held``): its writer then runs beside the
    renderer's set-up on the main thread, on the core the scene's decodes and levels no
    longer use."""
    from app.textures.background import release_writes

    release_writes()


def _renderer_class() -> type[Renderer]:
    """The renderer's class, its modules imported (the GL stack among them)."""
    from app.render.renderer import Renderer

    return Renderer


def _environment_twin() -> None:
    """Import the float64 twin that an environment's set-up projects its map onto SH9 with
    (app/render/ibl.py ``EnvironmentLighting``, which imports it when a frame has an
    environment), at one of the scene reader's waits rather than after the scene is read
    (docs/performance.md, "A real asset against f3d")."""
    import app.reference.ibl  # noqa: F401


def _draw_chain_ahead(args: argparse.Namespace, context: Ahead, levels: PreparedLevels) -> None:
    """Draw a map's normal/roughness chain on the render's GL context (made now where it is
    not yet) at a wait of the scene's reader, for the renderer's upload to take
    (app/render/texture_upload.py ``draw_chain_ahead``): the GL's fraction of a second of
    a cold render spent where the main thread waits for another map, not after the scene
    is read (docs/performance.md, "A real asset against f3d")."""
    from app.render.texture_upload import draw_chain_ahead
    from app.untrusted.policy import Limits

    limit = Limits().with_memory(args.max_memory).max_memory
    draw_chain_ahead(context.lend().ctx, levels, limit)


def _forget_chains_ahead(context: Ahead) -> None:
    """Forget the chains drawn ahead that the renderer did not take (a render refused after
    its scene was read): their textures go with the GL context."""
    from app.render.texture_upload import forget_chains_ahead

    try:
        gl = context.lend()
    except Exception:  # no context was made: nothing was drawn on it
        return
    forget_chains_ahead(gl.ctx)


def _start_device(args: argparse.Namespace) -> None:
    """Start the EGL device's driver on a thread of its own (app/gl/egl.py
    ``start_device``: llvmpipe's LLVM loaded without the GIL) for the context ``_context``
    makes later; nothing for ``--backend osmesa``. A model file's render starts it with
    its early decodes, a scene file's once the file is read and valid: a bad scene is
    refused without the GL stack (docs/performance.md, "Start-up")."""
    if args.backend != "osmesa":
        from app.gl.egl import start_device

        start_device(args.device)


def _context(args: argparse.Namespace) -> GLContext:
    """The headless context of ``--backend`` on ``--device`` (app/gl/context.py): an
    index EGL does not enumerate is one line naming the option (or PBS_EGL_DEVICE) and
    how many devices there are, exit 2, before anything is written."""
    from app.gl.context import create_context

    return create_context(args.backend, args.device, "--device")


def _gallery_parser(sub: argparse._SubParsersAction) -> None:
    gallery = sub.add_parser(
        "gallery",
        help="render a folder of sample models beside their reference screenshots into "
        "one contact sheet PNG",
        description="Each subfolder NAME of FOLDER is a model as the Khronos glTF sample "
        "repositories lay them out (NAME/glTF/NAME.gltf, NAME/glTF-Binary/NAME.glb or "
        "NAME/NAME.glb, its reference NAME/screenshot/screenshot.png or .jpg); a .gltf/.glb "
        "in FOLDER itself is a model too (reference NAME.png beside it). Each is rendered "
        "as 'pbs render MODEL --view front' frames it (no scene file), in the reference "
        "viewer's look (image-based light only, a fixed exposure of 0 EV, the neutral tone "
        "map), beside its reference, labelled. A bad "
        "model or reference exits 2 naming its file, and writes nothing. docs/gltf.md, "
        "'Conformance gallery'.",
    )
    gallery.add_argument("folder", help="folder of sample models")
    gallery.add_argument("-o", "--output", required=True, help="contact sheet PNG to write")
    gallery.add_argument(
        "--size",
        type=_number(lambda v: 16 <= v <= 2048 and v == int(v), "an integer within 16..2048"),
        default=256,
        metavar="PIXELS",
        help="each panel's side (default 256)",
    )
    gallery.add_argument(
        "--columns",
        type=_number(lambda v: 1 <= v <= 64 and v == int(v), "an integer within 1..64"),
        default=3,
        metavar="N",
        help="models a row (default 3)",
    )
    _gl_backend(gallery)
    _look_options(gallery, view="front")  # the view of most Khronos reference screenshots
    _input_options(gallery)
    gallery.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")


def cmd_gallery(args: argparse.Namespace) -> int:
    """Render a folder of models beside their references into one sheet (app/gallery.py);
    every model and reference is read before the sheet is written."""
    from app.gallery import find_models, render_gallery

    start = time.perf_counter()
    out = Path(args.output)
    if out.suffix.lower() != ".png":
        raise InputError(str(out), "-o", "the output must be a .png file")
    folder = Path(args.folder)
    models = find_models(folder)
    inputs = {m.model.resolve() for m in models} | {
        m.reference.resolve() for m in models if m.reference is not None
    }
    _check_output(out, "-o", inputs)
    look = _look(args)
    gl = _context(args)
    try:
        with _silenced("pbs.scene", args.quiet):
            sheet = render_gallery(
                gl, models, int(args.size), int(args.columns), look,
                allow_paths=args.allow_path, max_memory=args.max_memory,
            )  # fmt: skip
        described = gl.described
    finally:
        gl.release()
    from app.output import write_png

    _write(out, "-o", lambda p: write_png(p, sheet))
    if not args.quiet:
        h, w = sheet.shape[:2]
        with_reference = sum(m.reference is not None for m in models)
        print(
            f"{out}: {w}x{h}, {len(models)} models ({with_reference} with a reference), "
            f"{described}, {time.perf_counter() - start:.2f} s"
        )
    return 0


def _one_blas_thread() -> None:
    """Ask numpy's OpenBLAS for one thread, before numpy is imported (a value the
    environment gives wins): OpenBLAS starts a thread per core that spins after each
    product, and a render's few small products gain nothing from them while its own
    threads (the decodes, the chain) lose a core to them. ``pbs render``, ``pbs batch``
    (its worker processes inherit the environment) and ``pbs view`` (docs/performance.md)."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def cmd_render(args: argparse.Namespace) -> int:
    """Render a scene to PNG. Each layer is imported when the command reaches it: the
    scene's (pydantic, numpy) to validate it, GL and the renderer once it is valid or
    where its reader waits for a map (app/waiting.py), so a bad scene is refused without
    them (docs/performance.md, "Start-up")."""
    _one_blas_thread()
    still = not (args.fit or args.compare is not None or args.debug is not None)
    if still and args.max_memory is None:  # a glTF file's whole images decode while the
        # scene's modules are imported (app/scene/early_images.py)
        from app.scene.early_images import start_still_decodes

        start_still_decodes(args.scene)
    from app.scene.look import is_model_file

    if is_model_file(args.scene):  # a scene file's, once it is read (_read_and_render)
        _start_device(args)
    if still:  # one frame: no later load reuses a decoded image; the prepared-texture
        # cache's writes wait for the renderer's set-up (_read_and_render)
        from app.textures.background import writes_held
        from app.textures.decoded import keep_decoded_images

        keeping = keep_decoded_images(False)
        try:
            with writes_held():
                return _render(args, still)
        finally:  # a caller in this process (a test, the API) may load again
            keep_decoded_images(keeping)
    return _render(args, still)


def _render(args: argparse.Namespace, still: bool) -> int:
    """``cmd_render`` once a still's decodes are started: the scene read, checked and
    rendered, the PNG written. The renderer's import and the GL context are made ahead,
    where the scene's reader waits for its maps (app/waiting.py), else after it."""
    from app.waiting import GL_CHAIN, Ahead, AheadEach, ahead

    renderer_class = Ahead(_renderer_class)
    context = Ahead(lambda: _context(args), release=lambda gl: gl.release())
    # made at a wait only, never asked for: a scene that waits for no map imports it when
    # its environment is set up, if it has one
    environment_twin = Ahead(_environment_twin)
    # a map's chain drawn on the GL where the reader waits for another map
    chains = AheadEach(GL_CHAIN, lambda levels: _draw_chain_ahead(args, context, levels))
    with ahead(renderer_class, context, environment_twin, chains):
        try:
            return _read_and_render(args, still, renderer_class, context)
        finally:
            if context.made:
                _forget_chains_ahead(context)


def _read_and_render(
    args: argparse.Namespace, still: bool, renderer_class: Ahead, context: Ahead
) -> int:
    """``_render``'s work, with the renderer class and the GL context it takes when the
    scene is read and checked."""
    from app.scene.look import is_model_file
    from app.scene.sources import scene_from, scene_path

    start = time.perf_counter()
    out = Path(args.output)
    if out.suffix.lower() != ".png":
        raise InputError(str(out), "-o", "the output must be a .png file")
    if args.hdr:
        from app.output import HDR_SUFFIXES

        if Path(args.hdr).suffix not in HDR_SUFFIXES:  # write_hdr: lower case only
            raise InputError(args.hdr, "--hdr", "the HDR output must end in .exr or .npy")
    if args.debug_light is not None and args.debug not in LIGHT_VIEWS:
        raise InputError("--debug-light", "", f"applies only to --debug {', '.join(LIGHT_VIEWS)}")
    scene_file = scene_path(args.scene)
    outputs = [(out, "-o")] + ([(Path(args.hdr), "--hdr")] if args.hdr else [])
    if args.hdr and Path(args.hdr).resolve() == out.resolve():
        raise InputError(args.hdr, "--hdr", "is the same file as -o")
    for path, option in outputs:
        _check_output(path, option, {scene_file.resolve()})
    with files.recording() as inputs:  # every file the scene names, for the outputs' check
        with _silenced("pbs.scene", args.quiet):  # -q: no note on the defaults used
            loaded = scene_from(
                scene_file,
                allow_paths=args.allow_path,
                max_memory=args.max_memory,
                look=_look(args),
                size=args.size,
                still=still,  # one frame from the framing camera: the levels it samples
            )
        if args.fit:
            from app.frame.camera import fit_scene

            loaded = fit_scene(loaded, args.size)
        if args.background is not None:
            from app.scene.edits import edited

            loaded = edited(loaded, {"render.background": args.background}, "--background")
        if not is_model_file(scene_file):
            _start_device(args)  # the renderer's modules are imported meanwhile
        if args.compare is not None:
            return _render_comparison(args, loaded, out, start, inputs, context)
        for option, value in (
            ("--compare-mode", args.compare_mode),
            ("--divider", args.divider),
            ("--gain", args.gain),
        ):
            if value is not None:
                raise InputError(option, "", "applies only with --compare")
        make_renderer = renderer_class.get()
        gl = context.get()
        _release_writes()  # held while a still's scene was read (cmd_render)
        try:
            renderer = make_renderer(gl, loaded, args.size)
        except InputError as exc:
            gl.release()
            raise _size_option(exc) from None
    for path, option in outputs:
        _check_output(path, option, inputs)
    light = 0 if args.debug_light is None else args.debug_light
    if args.debug in LIGHT_VIEWS and not 0 <= light < len(renderer.lights):
        count = len(renderer.lights)
        renderer.release()
        raise InputError(
            str(scene_file), "--debug-light",
            f"light {light} out of range: the scene has {count} light(s)"
            + (f", 0..{count - 1}" if count else ""),
        )  # fmt: skip
    renderer.want_hdr(bool(args.hdr))  # both images from one HDR lighting pass
    renderer.render()
    ldr = renderer.read_image()  # RGBA with a transparent background
    hdr = renderer.read_hdr_image() if args.hdr else None
    report = None
    if args.debug is not None:
        ldr, report = _debug_image(renderer, args.debug, light, out, scene_file)
    renderer.release()
    from app.output import write_hdr, write_png

    if args.hdr:
        _write(Path(args.hdr), "--hdr", lambda p: write_hdr(p, hdr))
    _write(out, "-o", lambda p: write_png(p, ldr))
    if report is not None:
        print(report)  # the point of --debug nan, so -q does not silence it
    if not args.quiet:
        h, w = ldr.shape[:2]  # a debug view has the G-buffer's size (render_size)
        print(
            f"{out}: {w}x{h}, {len(renderer.lights)} lights"
            f"{' (environment included)' if loaded.scene.environment else ''}, "
            f"{gl.described}, {time.perf_counter() - start:.2f} s"
        )
    gl.release()
    return 0


def _render_comparison(
    args: argparse.Namespace,
    loaded: LoadedScene,
    out: Path,
    start: float,
    inputs: set[Path],
    context: Ahead,
) -> int:
    """``render --compare KEY=A,B``: both sides validated before any GL work, then the
    split or difference composite written as the PNG (app/render/compare.py)."""
    from app.render.compare import Comparison, divider_column, parse_compare

    for option, value in (
        ("--hdr", args.hdr),
        ("--debug", args.debug),
        ("--background", args.background),
    ):
        if value is not None:
            raise InputError(option, "", "does not combine with --compare")
    mode = args.compare_mode or "split"
    if mode == "split" and args.gain is not None:
        raise InputError("--gain", "", "applies only with --compare-mode difference")
    if mode == "difference" and args.divider is not None:
        raise InputError("--divider", "", "applies only with --compare-mode split")
    divider = 0.5 if args.divider is None else args.divider
    gain = 8.0 if args.gain is None else args.gain
    spec = parse_compare(args.compare)
    spec.scenes(loaded, args.size)  # every refusal here, before the context is taken
    gl = context.get()
    try:
        comparison = Comparison(gl, loaded, spec, args.size)
    except InputError as exc:
        raise _size_option(exc) from None
    _check_output(out, "-o", inputs)
    comparison.render()
    comparison.composite(mode, divider, gain)
    ldr = comparison.read_ldr()
    w, h = comparison.size
    comparison.release()
    from app.output import write_png

    _write(out, "-o", lambda p: write_png(p, ldr))
    if not args.quiet:
        if mode == "split":
            how = f"split at column {divider_column(divider, w)} (A left, B right)"
        else:
            how = f"difference |A - B| x {gain:g}"
        print(
            f"{out}: {w}x{h}, {spec.describe()}, {how}, "
            f"{gl.described}, {time.perf_counter() - start:.2f} s"
        )
    gl.release()
    return 0


def cmd_brdf(args: argparse.Namespace) -> int:
    """Plot materials' BRDFs (app/brdf/plot.py). Every argument is checked before any GL or
    matplotlib work, so bad input exits 2 without writing anything."""
    from app.brdf import plot

    start = time.perf_counter()
    out = Path(args.output)
    if out.suffix.lower() != ".png":
        raise InputError(str(out), "-o", "the output must be a .png file")
    materials = plot.parse_material_args(args.materials)  # all validated before any work
    try:
        columns = plot.compute_columns(materials, args.theta, args.quantity, args.backend)
    except plot.ModelUnavailableError as exc:
        print(f"pbs: error: {exc}", file=sys.stderr)
        return 1
    fig = plot.render_figure(
        columns, args.quantity, rgb=args.rgb, log=args.log, size=args.size, dpi=args.dpi,
        backend=args.backend,
    )  # fmt: skip
    _write(out, "-o", lambda p: plot.save_png(fig, p))
    if not args.quiet:
        width, height = fig.canvas.get_width_height(physical=True)
        error = max(float(c.albedo.error.max()) for c in columns)
        print(
            f"{out}: {width}x{height}, {len(columns)} material(s), {args.backend} backend, "
            f"albedo quadrature error ~{error:.0e}, {time.perf_counter() - start:.2f} s"
        )
    return 0


def cmd_batch(args: argparse.Namespace) -> int:
    """Render a job file's images (app/batch). The job file, and the scenes of an orbit or
    a sweep, are validated before any GL work; a failed job is reported, not fatal."""
    _one_blas_thread()  # here and in the worker processes, which inherit the environment
    from app.batch.jobs import plan_jobs
    from app.progress import Progress

    start = time.perf_counter()
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise InputError(str(out), "-o", "not a folder")
    plan = plan_jobs(args.jobs, out, _policy(args))
    from app.batch.run import dask_client, run_batch  # the workers and GL: a valid plan only
    from app.gl.context import device_requests

    # Every device checked here, before a worker starts or DIR is made.
    asked = args.devices if args.devices is not None else args.device
    option = "--devices" if args.devices is not None else "--device"
    devices = device_requests(asked, option, args.backend)

    client = None
    if args.scheduler is not None or args.dask_local is not None:
        option = "--scheduler" if args.scheduler is not None else "--dask-local"
        client = dask_client(args.scheduler, args.dask_local, option)
    progress = Progress(len(plan.jobs), enabled=not args.quiet)
    try:
        results = run_batch(
            plan, out, args.workers, args.backend, not args.no_resume, progress, client,
            devices=devices,
        )  # fmt: skip
    except OSError as exc:
        why = f"{exc.strerror}: {exc.filename}" if exc.filename else str(exc)
        raise InputError(str(out), "-o", f"cannot write ({why})") from None
    finally:
        if client is not None:
            client.close()  # type: ignore[attr-defined]
    failed = [r for r in results if r["status"] == "failed"]
    if not args.quiet:
        done = sum(r["status"] == "ok" for r in results)
        skipped = sum(r["status"] == "skipped" for r in results)
        print(
            f"{out}: {plan.kind}, {done} rendered, {skipped} skipped, {len(failed)} failed "
            f"of {len(results)}; {out / 'manifest.jsonl'}; {time.perf_counter() - start:.2f} s"
        )
    if failed:
        print(f"pbs: error: {len(failed)} of {len(results)} jobs failed:", file=sys.stderr)
        for r in failed:
            print(f"  {r['job']}: {_one_line(r['error'] or '')}", file=sys.stderr)
        return 1
    return 0


def cmd_devices(args: argparse.Namespace) -> int:
    """List the EGL devices (app/gl/egl.py): ctypes on libEGL alone, no moderngl."""
    from app.gl import egl

    try:
        found = egl.devices()
    except egl.EGLUnavailableError as exc:
        print(f"pbs: error: EGL cannot enumerate devices: {exc}", file=sys.stderr)
        return 1
    if not found:
        print("pbs: error: EGL enumerates no devices", file=sys.stderr)
        return 1
    for device in found:
        print(_one_line(device.line()))
    return 0


def cmd_textures(args: argparse.Namespace) -> int:
    """Write the procedural textures into ``--out``, or with ``--check`` compare the files
    there with freshly generated pixels. Every texture is generated before anything is
    written, and each file is renamed into place whole."""
    from app.resources import scenes_dir
    from app.textures.procedural import TEXTURES, difference, png_bytes, write_texture

    out = Path(args.out) if args.out else scenes_dir() / "textures"
    if out.exists() and not out.is_dir():
        raise InputError(str(out), "--out", "not a folder")
    generated = [(texture, texture.pixels()) for texture in TEXTURES]
    if args.check:
        differ = []
        for texture, pixels in generated:
            problem = difference(out / texture.name, texture, pixels)
            if problem is not None:
                differ.append(texture.name)
                print(f"{out / texture.name}: differs: {problem}")
            elif not args.quiet:
                print(f"{out / texture.name}: matches ({texture.what})")
        if differ:
            print(
                f"pbs: error: {out}: {len(differ)} of {len(generated)} textures differ from "
                f"'pbs textures': {', '.join(differ)}",
                file=sys.stderr,
            )
            return 1
        return 0
    encoded = [(texture, pixels, png_bytes(pixels, texture.mode)) for texture, pixels in generated]
    for texture, pixels, data in encoded:
        path = out / texture.name
        _write(path, "--out", lambda p, data=data: write_texture(p, data))
        if not args.quiet:
            height, width = pixels.shape[:2]
            print(f"{path}: {width}x{height} {texture.mode}, {len(data)} bytes, {texture.what}")
    return 0


def cmd_walkthrough(args: argparse.Namespace) -> int:
    """Render the walkthrough's steps and write the handout (app/walkthrough). The steps
    and the fonts are checked before any GL work."""
    from app.progress import Progress
    from app.resources import walkthrough_dir
    from app.walkthrough.build import build, count_items
    from app.walkthrough.handout import write_handout
    from app.walkthrough.labels import find_font
    from app.walkthrough.model import load_walkthrough

    start = time.perf_counter()
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InputError(str(out), "--out", "not a folder")
    steps = load_walkthrough(args.folder or walkthrough_dir(), args.steps)
    find_font(args.lang)
    gl = _context(args)
    progress = Progress(count_items(steps), enabled=not args.quiet)
    try:
        rendered = build(gl, steps, out, args.lang, args.size, progress)
    except OSError as exc:
        why = f"{exc.strerror}: {exc.filename}" if exc.filename else str(exc)
        raise InputError(str(out), "--out", f"cannot write ({why})") from None
    finally:
        gl.release()
    page, markdown = write_handout(out, rendered, args.lang)
    if not args.quiet:
        images = sum(len(r.figures) for r in rendered)
        print(
            f"{page}: {len(rendered)} step(s), {images} image(s), lang {args.lang}; "
            f"{markdown}; {time.perf_counter() - start:.2f} s"
        )
    return 0


def cmd_view(args: argparse.Namespace) -> int:
    _one_blas_thread()
    from app.scene.model_file import is_model_file, model_document
    from app.scene.sources import scene_path
    from app.viewer.window import Viewer, ViewerError

    steps = None
    if args.walkthrough:
        from app.resources import walkthrough_dir
        from app.walkthrough.model import load_walkthrough

        if args.scene:
            raise InputError("--walkthrough", "", "opens its steps' own scenes: give no scene")
        # Every step validated before the window opens: a broken one is one line, exit 2.
        steps = load_walkthrough(walkthrough_dir())
        sections = [loaded.step.section for loaded in steps]
        if args.step not in sections:
            raise InputError(
                "--step", "", f"no step {args.step} (steps: {sections[0]}..{sections[-1]})"
            )
    if args.lang == "ko":
        from app.walkthrough.labels import find_font

        find_font("ko")  # no Hangul font: one line naming the package, exit 2
    scene = scene_path(args.scene) if args.scene else None
    policy, data = _policy(args), None
    if scene is not None and is_model_file(scene):  # shown framed and lit, saved beside it
        look = _look(args)
        if look.env not in ("studio", "sky"):
            policy = InputPolicy((*policy.allowed, Path(look.env).resolve().parent), policy.limits)
        scene, data = model_document(scene, policy, look, args.size)
    try:
        viewer = Viewer(
            scene, args.size, vsync=not args.no_vsync, hangul=args.lang == "ko",
            policy=policy, data=data,
        )  # fmt: skip
    except ViewerError as exc:
        print(f"pbs: error: {exc}", file=sys.stderr)
        return 1
    try:
        if steps is not None:
            viewer.open_walkthrough(steps, args.lang, args.step)
        viewer.run()
    finally:
        viewer.close()
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pbs`` and ``python -m app``. Called without ``argv`` (the process's
    own command line), a ``pbs render`` that succeeded ends the process itself once its
    outputs are written (``_end_process``); with ``argv`` it always returns."""
    own_process = argv is None
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["bench"]:  # app.bench owns its options (also `python -m app.bench`)
        from app.bench import main as bench_main

        return bench_main(argv[1:])
    parser = _parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse exits 2 on bad arguments, 0 on --help
        return int(exc.code or 0)
    if own_process:  # the process is the command's, not a caller's
        _no_pydantic_plugins()
        if args.command == "render":
            _no_cycle_collection()
        atexit.register(code_table.TABLE.save)  # _end_process saves it, atexit or not
    handlers = {
        "render": cmd_render,
        "brdf": cmd_brdf,
        "batch": cmd_batch,
        "textures": cmd_textures,
        "gallery": cmd_gallery,
        "devices": cmd_devices,
        "walkthrough": cmd_walkthrough,
        "view": cmd_view,
    }
    try:
        with _notes_after_success():
            code = handlers[args.command](args)
    except InputError as exc:
        print(f"pbs: error: {_one_line(str(exc))}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except (MemoryError, RecursionError) as exc:  # a backstop: the budgets refuse first
        what = "ran out of memory" if isinstance(exc, MemoryError) else "nests too deeply"
        name = getattr(args, "scene", None) or getattr(args, "jobs", None) or args.command
        print(f"pbs: error: {name}: the input {what} to be read", file=sys.stderr)
        return EXIT_BAD_INPUT
    if own_process and args.command == "render" and code == 0:
        _end_process()
    return code


# pydantic's module that finds its plugins (entry points of the group "pydantic")
_PLUGIN_LOADER = "pydantic.plugin._loader"


def _no_pydantic_plugins() -> None:
    """Run the command's process without pydantic plugins, as
    ``PYDANTIC_DISABLE_PLUGINS=__all__`` does, and without looking for them: the first
    model pydantic builds imports its plugin loader, which imports ``importlib.metadata``
    (email, zipfile, socket and more) and reads every installed distribution's entry
    points, on the main thread of every command that reads a scene (its cost:
    docs/performance.md, "Start-up"). A plugin would only watch pbs validate its own
    scene models. The loader pydantic imports is then one whose ``get_plugins`` finds
    none; any other name is taken from pydantic's own module, loaded where asked for.
    Nothing where pydantic has loaded its plugins already, nor in a caller's process
    (``main(argv)``: its plugins are its own)."""
    if _PLUGIN_LOADER in sys.modules:
        return
    import types

    def get_plugins() -> tuple:
        return ()

    def from_pydantic(name: str):  # -> Any: the real module's attribute
        if name.startswith("__"):  # the import system's questions (a package's __path__)
            raise AttributeError(name)
        import importlib.machinery
        import importlib.util

        import pydantic.plugin

        spec = importlib.machinery.PathFinder.find_spec(_PLUGIN_LOADER, pydantic.plugin.__path__)
        if spec is None or spec.loader is None:
            raise AttributeError(name)
        real = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(real)
        loader.__getattr__ = real.__getattribute__  # loaded once
        return getattr(real, name)

    loader = types.ModuleType(_PLUGIN_LOADER, "pydantic's plugin loader, finding none (pbs)")
    loader.get_plugins = get_plugins  # type: ignore[attr-defined]
    loader.__getattr__ = from_pydantic  # type: ignore[attr-defined]
    sys.modules[_PLUGIN_LOADER] = loader


def _no_cycle_collection() -> None:
    """Switch Python's cyclic garbage collector off for a ``pbs render`` process: it draws
    one image and ends (``_end_process``), and what it allocates is freed by reference
    counting (arrays, images, GL objects), so the collector's passes found little to free
    and walked every object the imports made, on the main thread and holding the GIL
    (docs/performance.md, "Start-up"). Garbage in a reference cycle stays until the
    process ends: a render makes little of it (small objects, no arrays)."""
    import gc

    gc.disable()


def _end_process() -> NoReturn:
    """End the process now that its outputs are written and closed: the texture layer's
    background work joined (every prepared-texture entry on disk), the standard streams
    flushed, then the C library's ``exit``, which runs the native libraries' exit handlers
    (Mesa's among them) but not Python's teardown of every module and object (its cost
    after a textured model's PNG: docs/performance.md, "A real asset against f3d")."""
    import ctypes

    from app.textures.background import finish_background_work

    finish_background_work()
    code_table.TABLE.save()  # as atexit would: the C library's exit skips Python's handlers
    code = 0
    for stream in (sys.stdout, sys.stderr):
        if stream is None:  # closed at the start (pythonw, or `>&-`): nothing to flush
            continue
        try:
            stream.flush()
        except (OSError, ValueError):  # as Python's own exit reports a failed flush
            code = 120
    try:
        c_exit = ctypes.CDLL(None).exit
    except (OSError, AttributeError, TypeError):  # no C library to name (Windows): skip them
        os._exit(code)
    c_exit(code)
    os._exit(code)  # not reached: exit does not return


class _Held(logging.Handler):
    """Keeps the project's log records (notes such as a glTF extension approximated)."""

    def __init__(self) -> None:
        super().__init__(logging.INFO)
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


@contextlib.contextmanager
def _notes_after_success() -> Iterator[None]:
    """Hold the notes and warnings a command produces and print them, one line each,
    only when it ends without an error: a refused input prints its one error line alone."""
    logger = logging.getLogger("pbs")
    held, propagate = _Held(), logger.propagate
    logger.addHandler(held)
    logger.propagate = False
    try:
        with warnings.catch_warnings(record=True) as caught:  # the filters in force kept
            yield
    finally:
        logger.removeHandler(held)
        logger.propagate = propagate
    for record in held.records:
        print(f"pbs: note: {_one_line(record.getMessage())}", file=sys.stderr)
    for warning in caught:
        print(f"pbs: warning: {_one_line(str(warning.message))}", file=sys.stderr)


if __name__ == "__main__":
    raise SystemExit(main())
