"""Image-based lighting against brute force, whole images (docs/ibl.md): the renderer's
split-sum image of a few spheres against a float64 image of the same G-buffer in which
every covered pixel is ``reference_radiance`` (the BRDF times the environment, summed
over every texel of the map), and suite ``ibl`` of ``pbs bench``: the prefilter's time
and memory against face size and sample count, and each choice's frame time and error
on a time-vs-error front.

The environments are the sky, the studio and the window room made at the map width
asked for (128 by default: the brute-force sum visits every texel for every pixel),
written as EXR and lit through ``source = "image"``, so the renderer prefilters exactly
the texels the reference sums.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.assets.window_room import window_room
from app.bench.context import Context, deferred_passes, make_row
from app.bench.metrics import flip_map, image_errors
from app.common.models import Model
from app.gl.context import GLContext
from app.reference.ibl import reference_radiance
from app.reference.illumination import decode_gbuffer
from app.reference.material import Surface
from app.render import ibl as render_ibl
from app.render.renderer import Renderer
from app.scene.loader import load_scene
from app.textures.environment import preetham_sky, studio

MAP_WIDTH = 128
IMAGE_SIZE = (96, 64)
SKY_SUN = (0.5, 0.6, -0.6)
# (face size, samples) the suite sweeps; the renderer's own choice is (128, 256).
CHOICES = ((32, 64), (64, 64), (64, 256), (128, 64), (128, 256), (128, 1024))
TINY_CHOICES = ((16, 16), (32, 64))
DEFAULT_CHOICE = (render_ibl.FACE_SIZE, render_ibl.SAMPLES)

# Gold and a red dielectric at two roughnesses, side by side, seen from the front.
_SCENE = """background = [0.0, 0.0, 0.0]
[environment]
source = "image"
file = "{file}"
[render]
width = {width}
height = {height}
tonemap = "neutral"
[camera]
position = [0.0, 0.0, 7.0]
target = [0.0, 0.0, 0.0]
fov_y = 24.0
exposure = 0.0
[materials.gold-rough]
preset = "gold"
roughness = 0.6
[materials.gold-smooth]
preset = "gold"
roughness = 0.3
[materials.red-rough]
base_color = [0.6, 0.05, 0.04]
metallic = 0.0
roughness = 0.6
[materials.red-smooth]
base_color = [0.6, 0.05, 0.04]
metallic = 0.0
roughness = 0.3
"""
_SPHERES = (
    ("gold-smooth", -0.55, 0.5),
    ("gold-rough", 0.55, 0.5),
    ("red-smooth", -0.55, -0.5),
    ("red-rough", 0.55, -0.5),
)


def environments(width: int = MAP_WIDTH) -> list[tuple[str, np.ndarray]]:
    """(name, equirect map (width/2, width, 3)) of the sky, the studio and the window room."""
    return [
        ("sky", preetham_sky(np.array(SKY_SUN), 3.0, width) * np.float32(0.1)),
        ("studio", studio(width)),
        ("image", window_room(width)),
    ]


def write_scene(folder: Path, name: str, env: np.ndarray, size: tuple[int, int]) -> Path:
    """The spheres' scene lit by ``env``, written with its EXR to ``folder``."""
    import OpenEXR

    exr = folder / f"{name}.exr"
    with OpenEXR.File({"type": OpenEXR.scanlineimage}, {"RGB": env.astype(np.float32)}) as f:
        f.write(str(exr))
    text = _SCENE.format(file=exr.name, width=size[0], height=size[1])
    for material, x, y in _SPHERES:
        text += f'[[objects]]\nshape = "sphere"\nradius = 0.5\nposition = [{x}, {y}, 0.0]\n'
        text += f'material = "{material}"\n'
    path = folder / f"{name}.toml"
    path.write_text(text)
    return path


def brute_force_image(env: np.ndarray, gbuffer: dict, camera: object) -> np.ndarray:
    """The float64 image of the G-buffer: reference_radiance at every covered pixel (the
    standard model, the map unrotated at intensity 1, as write_scene writes it), 0 elsewhere."""
    dec = decode_gbuffer(gbuffer, camera)
    out = np.zeros((*dec.covered.shape, 3))
    values = np.empty((int(dec.covered.sum()), 3))
    sf = dec.surface
    for i in range(len(values)):
        s = Surface(sf.base_color[i], float(sf.metallic[i]), float(sf.perceptual_roughness[i]),
                    float(sf.f0_dielectric[i]), 0.0)  # fmt: skip
        values[i] = reference_radiance(env, 0.0, s, dec.n[i], dec.v[i], Model())
    out[dec.covered] = values
    return out


@dataclass
class Rendered:
    """One split-sum render: the HDR image, its G-buffer and camera, exposure, tone map."""

    hdr: np.ndarray
    gbuffer: dict
    camera: object
    exposure: float
    tonemap: str


def render(
    gl: GLContext, path: Path, time_frames: Callable | None = None
) -> tuple[Rendered, object]:
    """Render ``path`` once (prefiltering under the current prefilter_settings); with
    ``time_frames`` (a callable taking the Renderer) also time its frames and return them."""
    loaded = load_scene(path)
    renderer = Renderer(gl, loaded)
    try:
        renderer.render()
        times = time_frames(renderer) if time_frames is not None else None
        cam = loaded.scene.camera
        out = Rendered(
            renderer.read_hdr().astype(np.float64),
            renderer.read_gbuffer(),
            renderer.camera,
            cam.exposure,
            loaded.scene.render.tonemap,
        )
        return out, times
    finally:
        renderer.release()


def errors(image: Rendered, ref: np.ndarray) -> dict[str, float | None]:
    """Relative RMSE over the covered pixels and the mean FLIP over them (the background is
    black in both, so the whole image's mean would only dilute it)."""
    covered = decode_gbuffer(image.gbuffer, image.camera).covered
    stats = image_errors(image.hdr, ref, covered, image.exposure, image.tonemap, flip=False)
    fmap = flip_map(image.hdr, ref, image.exposure, image.tonemap)[0]
    return {"rel_rmse": stats["rel_rmse"], "flip_mean": float(fmap[covered].mean())}


@contextmanager
def scenes(width: int, size: tuple[int, int]) -> Iterator[list[tuple[str, np.ndarray, Path]]]:
    """The three environments' scenes in a temporary folder: (name, map, scene path)."""
    with tempfile.TemporaryDirectory() as tmp:
        yield [(n, env, write_scene(Path(tmp), n, env, size)) for n, env in environments(width)]


def flip_table(
    gl: GLContext, width: int = MAP_WIDTH, size: tuple[int, int] = IMAGE_SIZE
) -> list[dict]:
    """Per environment: the renderer's split-sum image (its own face size and samples)
    against the brute-force image: relative RMSE and mean FLIP over the covered pixels."""
    rows = []
    with scenes(width, size) as cases:
        # A uniform map first: there the split sum is exact (A + B = E, L_pre = L, SH9
        # exact), so what is left is the comparison's floor (float32, the G-buffer's
        # quantisation, the brute-force sum's own quadrature of narrow lobes on the texels).
        uniform = np.full((width // 2, width, 3), 0.5, np.float32)
        floor = ("uniform (floor)", uniform, write_scene(cases[0][2].parent, "u", uniform, size))
        for name, env, path in [floor, *cases]:
            image, _ = render(gl, path)
            ref = brute_force_image(env, image.gbuffer, image.camera)
            rows.append({"environment": name, **errors(image, ref)})
    return rows


def prefilter_ms(gl: GLContext, env: np.ndarray, base: int, samples: int) -> float:
    """Wall time of one uncached prefilter of ``env`` (read back included)."""
    from app.gl.shaders import ShaderCache

    shaders = ShaderCache(gl.ctx)
    try:
        render_ibl.prefilter(gl.ctx, shaders, env, base=16, samples=1)  # compile outside
        render_ibl.clear_cache()
        gl.ctx.finish()
        start = time.perf_counter()
        render_ibl.prefilter(gl.ctx, shaders, env, base=base, samples=samples)
        gl.ctx.finish()
        return (time.perf_counter() - start) * 1e3
    finally:
        render_ibl.clear_cache()
        shaders.release()


def run_ibl(ctx: Context) -> None:
    """Suite ``ibl``: for each (face size, samples) and environment, the prefilter's time
    and memory, the frame time, and the error against the brute-force image (one reference
    per environment: it depends on the G-buffer only, the same for every choice)."""
    tiny = ctx.settings.mode == "tiny"
    width = 32 if tiny else MAP_WIDTH
    size = (24, 16) if tiny else IMAGE_SIZE
    choices = TINY_CHOICES if tiny else CHOICES
    with scenes(width, size) as cases:
        for name, env, path in cases:
            ref = None
            for base, samples in choices:
                pre_ms = prefilter_ms(ctx.gl, env, base, samples)
                with render_ibl.prefilter_settings(base, samples):
                    image, times = render(ctx.gl, path, lambda r: ctx.time(deferred_passes(r)))
                render_ibl.clear_cache()
                if ref is None:
                    ref = brute_force_image(env, image.gbuffer, image.camera)
                ctx.rows.append(
                    make_row(
                        "ibl", name, f"face {base}, {samples} samples", size, 0, times,
                        face_size=base, samples=samples, prefilter_ms=pre_ms,
                        prefilter_bytes=render_ibl.levels_bytes(base), map_width=width,
                        error_reference="float64 brute force over every texel",
                        comparison=f"IBL prefilter under the {name} (face size, samples)"
                        " vs brute force",
                        default=(base, samples) == DEFAULT_CHOICE,
                        **errors(image, ref),
                    )
                )  # fmt: skip
                ctx.progress.done()


def ibl_tasks(settings: object) -> int:
    """The progress bar's share: one tick per (environment, choice)."""
    tiny = getattr(settings, "mode", "") == "tiny"
    return 3 * len(TINY_CHOICES if tiny else CHOICES)
