"""Suite ``peers``: pbs against pygfx, PyVista (VTK) and pyrender on one scene, side by side.

``peers_scene``: 35 spheres of radius 0.5 m (7 columns x 5 rows, 1.2 m apart) standing
on a 14 x 10 m floor, seen from above and in front with a 45 degree vertical field of
view; the rows alternate dielectric and metal and the roughness sweeps 0.1-0.9 along a
row; ``lights`` white point lights (1: one above the middle; more: a grid 3 m above the
floor) sharing one total intensity, with a range far beyond the scene (no window in
view). The spheres are icospheres of ``SUBDIVISIONS`` (5,120 triangles) in every renderer:
each peer is given the very triangles pbs draws (app/bench/peer_child.py). The tone map is
``linear`` (the exposed radiance clipped and sRGB-encoded), the output of the peers, which
have none; ``render.antialiasing`` is left at pbs's default.

``run_peers``: per light count, pbs (``Renderer.render`` then the 8-bit ``read_ldr``,
pass by pass) and each peer, a served child process (app/bench/peer_child.py: render and
read the 8-bit image back into numpy per frame), one frame of each per round with the
order rotated (timing.time_interleaved), so a change of the machine's load falls on all
alike; the ratio peer/pbs is taken per round. A peer that cannot run (not installed: the
optional ``peers`` extra; no offscreen device) gives a row without times whose
``skipped`` says why. Then each image, pbs's included, against the float64 ray-cast of
the same scene with analytic spheres (app/frame/raycast.py ``area_reference_scene``: the
pixel-area-integrated truth, more rays on edge pixels), as a display image (exposed,
clipped, sRGB) over the whole image: ``flip_mean`` (FLIP, LDR) and ``rel_rmse`` (on the
linear values decoded from both 8-bit images); and a contact sheet per light count,
``peers-N.png`` in the output folder (pbs, each peer, the ray-cast).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from app.bench.context import Context, make_row
from app.bench.peer_child import PeerChild
from app.bench.sphere_grid import SUBDIVISIONS, sphere_grid
from app.bench.timing import Pass, round_ratios

PEER_NAMES = ("pygfx", "pyvista", "pyrender")
CASE = "35 spheres + floor"
PBS = "pbs"
TOTAL_INTENSITY = 16.0  # candela, shared by the lights
# A peer shading the scene it was given lands within 0.1 of the ray-cast's FLIP (a black
# or mis-lit image near 0.4-0.7): past this the run's notes ask for a look.
FAR_FLIP = 0.2
# Per mode: the image and the light counts (tiny: the test's).
SIZES = {"full": (1280, 720), "quick": (640, 360), "tiny": (64, 36)}
LIGHTS = {"full": (1, 4, 32), "quick": (1, 4, 32), "tiny": (1,)}
# The ray-cast's rays per pixel (n x n) and on edge pixels (n x n, where a silhouette
# crosses): the renderers differ by far more than the reference's noise; about two
# minutes at 1280x720 and 32 lights on two loaded cores.
REFERENCE_SAMPLES = {"full": (1, 4), "quick": (2, 4), "tiny": (2, 4)}


def _light_positions(count: int) -> list[list[float]]:
    if count == 1:
        return [[0.0, 4.0, 1.5]]
    cols = int(np.ceil(np.sqrt(count * 2.0)))  # a grid wider than deep, over the spheres
    rows = int(np.ceil(count / cols))
    out = []
    for k in range(count):
        i, j = k % cols, k // cols
        x = -4.5 + 9.0 * (i + 0.5) / cols
        z = -3.0 + 6.0 * (j + 0.5) / rows
        out.append([round(x, 4), 3.0, round(z, 4)])
    return out


def peers_scene(lights: int, size: tuple[int, int]) -> dict:
    """The suite's scene (module docstring) with ``lights`` point lights, as a scene dict."""
    spheres, grid = sphere_grid(on_floor=True)
    materials = {"floor": {"base_color": [0.45, 0.45, 0.45], "roughness": 0.8}, **spheres}
    objects = [{"shape": "plane", "size": [14.0, 10.0], "material": "floor"}, *grid]
    return {
        "background": [0.05, 0.05, 0.06],
        "camera": {"position": [0.0, 5.5, 8.5], "target": [0.0, 0.2, 0.3], "fov_y": 45.0},
        "render": {"width": size[0], "height": size[1], "tonemap": "linear"},
        "materials": materials,
        "lights": [
            {"type": "point", "position": p, "intensity": TOTAL_INTENSITY / lights, "range": 100.0}
            for p in _light_positions(lights)
        ],
        "objects": objects,
    }


def pbs_passes(r) -> list[Pass]:
    """pbs's frame to the 8-bit image, pass by pass (app/bench/spheres.py) where those
    passes draw the very image ``Renderer.render`` and ``read_ldr`` give, else whole (an
    antialiasing mode with passes the split does not know: it would time less than the
    frame)."""
    from app.bench.spheres import pbs_frame_passes

    whole = [Pass("render", r.render, r.post.fbo), Pass("read-back", r.read_ldr)]
    try:
        passes = pbs_frame_passes(r)
    except ValueError:
        return whole
    r.render()
    expected = r.read_ldr()
    for p in passes[:-1]:
        p.run()
    return passes if np.array_equal(r.read_ldr(), expected) else whole


def display_errors(image: np.ndarray, reference_hdr: np.ndarray, exposure: float) -> dict:
    """``rel_rmse``, ``max_rel_err`` (linear, decoded from the 8-bit sRGB) and ``flip_mean``
    (LDR) of an (H, W, 3) uint8 display image against the ray-cast's HDR shown as the
    linear tone map shows it (exposed, clipped, sRGB), over every pixel."""
    from app.bench.metrics import image_errors
    from app.reference.tonemap import srgb_decode

    shown = np.clip(np.asarray(reference_hdr, np.float64) * 2.0**exposure, 0.0, 1.0)
    got = srgb_decode(np.asarray(image, np.float64) / 255.0)
    every = np.ones(shown.shape[:2], bool)
    return image_errors(got, shown, every, 0.0, "linear")


def contact_sheet(tiles: list[tuple[np.ndarray, str]], out: Path) -> None:
    """The images at half size in a grid of three columns, each labelled underneath."""
    from PIL import Image, ImageDraw

    images = []
    for image, label in tiles:
        im = Image.fromarray(np.ascontiguousarray(image, np.uint8))
        if im.width > 640:
            im = im.resize((im.width // 2, im.height // 2), Image.Resampling.LANCZOS)
        images.append((im, label))
    label_h = 22
    cols = min(3, len(images))
    rows = -(-len(images) // cols)
    tw, th = images[0][0].width, images[0][0].height + label_h
    sheet = Image.new("RGB", (cols * tw, rows * th), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    for k, (im, label) in enumerate(images):
        x, y = (k % cols) * tw, (k // cols) * th
        sheet.paste(im, (x, y))
        draw.text((x + 6, y + im.height + 5), label, fill=(0, 0, 0))
    sheet.save(out)


def _reference(data: dict, size: tuple[int, int], mode: str):
    from app.bench.scenes import load
    from app.frame.raycast import area_reference_scene

    samples, edge = REFERENCE_SAMPLES.get(mode, REFERENCE_SAMPLES["full"])
    return area_reference_scene(load(data), size, samples, edge)


def peers_tasks(settings) -> int:
    """Progress tasks: per light count, the interleaved frames and the ray-cast."""
    return 2 * len(LIGHTS.get(settings.mode, LIGHTS["full"]))


def run_peers(ctx: Context, peers: tuple[str, ...] = PEER_NAMES) -> None:
    """Suite ``peers`` (module docstring): per light count, a row for pbs and one per peer."""
    from app.bench.scenes import load
    from app.reference.tonemap import srgb_encode
    from app.render.renderer import Renderer

    mode = ctx.settings.mode
    size = SIZES.get(mode, SIZES["full"])
    out_dir = ctx.out
    for count in LIGHTS.get(mode, LIGHTS["full"]):
        data = peers_scene(count, size)
        with tempfile.TemporaryDirectory(prefix="pbs-peers-") as tmp:
            children: dict[str, PeerChild] = {}
            skipped: dict[str, str] = {}
            for peer in peers:
                ctx.progress.start(f"peers, {count} light(s): starting {peer}")
                try:
                    children[peer] = PeerChild(peer, data, size, Path(tmp) / f"{peer}.npy")
                except (OSError, RuntimeError) as exc:
                    skipped[peer] = str(exc)
            r = Renderer(ctx.gl, load(data), size)
            results: dict[str, dict] = {}
            try:
                ctx.progress.start(f"peers, {count} light(s): pbs, {', '.join(children)}")
                variants = {PBS: pbs_passes(r)}
                variants |= {p: [Pass("frame", c.frame)] for p, c in children.items()}
                times = ctx.time_interleaved(variants)
                pbs_image = r.read_ldr()
                for peer, child in children.items():
                    results[peer] = child.finish()
            finally:
                ctx.progress.done()
                for child in children.values():
                    child.close()
                antialiasing = r.antialiasing
                r.release()
            images = {PBS: pbs_image}
            for peer in children:
                path = Path(tmp) / f"{peer}.npy"
                if results[peer].get("ok") and path.is_file():
                    images[peer] = np.load(path)
            ctx.progress.start(f"peers, {count} light(s): the float64 ray-cast")
            ref = _reference(data, size, mode)
            ctx.progress.done()
        exposure = float(load(data).scene.camera.exposure)
        errors = {name: display_errors(img, ref.hdr, exposure) for name, img in images.items()}
        common = {"triangles_per_sphere": 20 * 4**SUBDIVISIONS}
        ctx.rows.append(
            make_row("peers", CASE, PBS, size, count, times[PBS], **errors[PBS],
                     antialiasing=antialiasing, version="this checkout", **common)
        )  # fmt: skip
        for peer in peers:
            if peer in skipped:
                ctx.rows.append(make_row("peers", CASE, peer, size, count, None,
                                         skipped=skipped[peer]))  # fmt: skip
                ctx.notes.append(f"peers: {peer} skipped: {skipped[peer]}")
                continue
            info = {k: v for k, v in results[peer].items() if k not in ("ok", "ms", "ready")}
            flip = errors.get(peer, {}).get("flip_mean")
            if flip is not None and flip > FAR_FLIP and not info.get("lights_dropped"):
                far = f"FLIP {flip:.2f} against the ray-cast: look at its contact sheet"
                ctx.notes.append(f"peers: {peer}'s image at {count} light(s) is far off ({far})")
            ctx.rows.append(
                make_row("peers", CASE, peer, size, count, times[peer], **errors.get(peer, {}),
                         over_pbs=round_ratios(times[peer], times[PBS]),
                         timer="wall clock around a frame request to the served child: render"
                         " and 8-bit read-back, and the pipe's round trip", **info, **common)
            )  # fmt: skip
        if out_dir is not None:
            shown = srgb_encode(np.clip(ref.hdr * 2.0**exposure, 0.0, 1.0))
            tiles = [(images[PBS], f"pbs ({antialiasing})")]
            for p in (p for p in peers if p in images):
                dropped = results[p].get("lights_dropped") or 0
                shaded = f" ({count - dropped} of {count} lights)" if dropped else ""
                tiles.append((images[p], f"{p}{shaded}"))
            tiles.append((np.round(shown * 255.0).astype(np.uint8), "float64 ray-cast"))
            contact_sheet(tiles, Path(out_dir) / f"peers-{count}.png")
