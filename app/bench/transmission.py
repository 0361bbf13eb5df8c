"""The transmission pass against exact refraction (docs/transmission.md), and suite
``transmission`` of ``pbs bench``: its time against its error.

One glass sphere (radius 0.5) in front of a wall of coloured stripes, lit by a sun from the
camera's side. The renderer draws it with the screen-space transmission pass
(app/render/transmission.py); the float64 ray-caster follows each pixel's light through
the sphere exactly (app/reference/refraction.py): straight on for a thin-walled sphere,
two Snell refractions, exact Fresnel and the true Beer-Lambert path for a solid one, the
GGX lobe sampled for a rough one. The error is over the sphere's interior pixels;
``unseen`` is the share of them whose light (the exact ray's) comes from a point the
screen-space method cannot read there: outside the image, or the background colour.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.bench.context import Context, cell, deferred_passes, make_row, table_lines
from app.bench.metrics import image_errors
from app.bench.timing import Pass
from app.frame.camera import camera_frame, projection_matrix, view_matrix
from app.frame.lights import frame_lights
from app.frame.raycast import primitive, primitive_material
from app.gl.context import GLContext
from app.reference.raycast import interior_mask
from app.reference.refraction import reference_with_glass
from app.render.renderer import CameraMatrices, Renderer
from app.scene.loader import parse_scene

SIZE = (160, 120)
TINY_SIZE = (64, 48)
RADIUS = 0.5
STRIPES = ([0.75, 0.1, 0.08], [0.85, 0.82, 0.72], [0.1, 0.25, 0.75], [0.2, 0.6, 0.2])
SUN = {"type": "directional", "direction": [0.2, -0.3, -1.0], "intensity": 2.0}


@dataclass(frozen=True)
class GlassCase:
    """One sphere: its roughness, index, thickness (0: thin-walled) and attenuation."""

    name: str
    roughness: float
    ior: float
    thickness: float = 0.0
    attenuation: tuple[float, float, float] | None = None  # colour at 1 m
    x: float = 0.0  # the sphere's centre along the image's width (m at its depth)

    def material(self) -> dict:
        m = {"base_color": [1.0, 1.0, 1.0], "roughness": self.roughness, "ior": self.ior,
             "transmission": 1.0, "thickness": self.thickness}  # fmt: skip
        if self.attenuation is not None:
            m.update(attenuation_color=list(self.attenuation), attenuation_distance=1.0)
        return m


CASES = (
    GlassCase("thin, smooth", 0.0, 1.5),
    GlassCase("thin, roughness 0.2", 0.2, 1.5),
    GlassCase("thin, roughness 0.5", 0.5, 1.5),
    GlassCase("solid, ior 1.1", 0.0, 1.1, 2 * RADIUS),
    GlassCase("solid, ior 1.33", 0.0, 1.33, 2 * RADIUS),
    GlassCase("solid, ior 1.5", 0.0, 1.5, 2 * RADIUS),
    GlassCase("solid, ior 1.5, roughness 0.2", 0.2, 1.5, 2 * RADIUS),
    GlassCase("solid, ior 1.5, amber", 0.0, 1.5, 2 * RADIUS, (0.9, 0.6, 0.3)),
    GlassCase("solid, ior 1.5, at the image's edge", 0.0, 1.5, 2 * RADIUS, x=0.85),
)
QUICK_CASES = (CASES[0], CASES[2], CASES[5])
TINY_CASES = (CASES[0], CASES[5])


def _plan(mode: str) -> tuple[tuple[GlassCase, ...], tuple[int, int], int]:
    """The cases, image size and rough-lobe strata (n x n rays) of a bench mode."""
    if mode == "tiny":
        return TINY_CASES, TINY_SIZE, 2
    if mode == "quick":
        return QUICK_CASES, SIZE, 8
    return CASES, SIZE, 16


def glass_scene(case: GlassCase, size: tuple[int, int]) -> dict:
    """The scene: the sphere at (x, 0, 0), a wall of 12 stripes 0.4 m wide at z = -1.5."""
    materials = {f"stripe{i}": {"base_color": c, "roughness": 0.7} for i, c in enumerate(STRIPES)}
    objects = [
        {"shape": "plane", "size": [0.4, 3.0], "position": [-2.2 + 0.4 * i, 0.0, -1.5],
         "rotation": [90.0, 0.0, 0.0], "material": f"stripe{i % len(STRIPES)}"}
        for i in range(12)
    ]  # fmt: skip
    objects.append(
        {"shape": "sphere", "radius": RADIUS, "position": [case.x, 0.0, 0.0], "material": "glass"}
    )
    return {
        "background": [0.02, 0.02, 0.03],
        "camera": {"position": [0.0, 0.0, 3.0], "target": [0.0, 0.0, 0.0], "fov_y": 30.0},
        "materials": {**materials, "glass": case.material()},
        "objects": objects,
        "lights": [SUN],
        "render": {"width": size[0], "height": size[1], "gbuffer": "f32", "tonemap": "neutral"},
    }


def reference(data: dict, samples: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The exact image, its primitive ids and, per glass pixel, the share of its light
    that comes from the background or from outside the image (``on_screen``)."""
    loaded = parse_scene(data, Path("inline.toml"))
    scene = loaded.scene
    prims = [primitive(i, obj) for i, obj in enumerate(scene.objects)]
    mats = [primitive_material(o.material, scene.materials[o.material]) for o in scene.objects]
    size = (scene.render.width, scene.render.height)
    camera = camera_frame(scene.camera, *size)
    clip = projection_matrix(scene.camera, size[0] / size[1]) @ view_matrix(scene.camera)

    def on_screen(points: np.ndarray) -> np.ndarray:
        h = np.concatenate([points, np.ones((len(points), 1))], axis=-1) @ clip.T
        with np.errstate(invalid="ignore", divide="ignore"):
            ndc = h[:, :2] / h[:, 3:4]
        return (h[:, 3] > 0.0) & np.all(np.abs(ndc) <= 1.0, axis=-1)

    return reference_with_glass(
        prims, mats, camera, size, frame_lights(scene.lights),
        np.asarray(scene.background, np.float64), samples, on_screen,
    )  # fmt: skip


def gpu_image(gl: GLContext, data: dict) -> np.ndarray:
    r = Renderer(gl, parse_scene(data, Path("inline.toml")))
    try:
        r.render()
        return r.read_hdr()[..., :3].astype(np.float64)
    finally:
        r.release()


def case_errors(gl: GLContext, case: GlassCase, size: tuple[int, int], samples: int) -> dict:
    """The renderer's sphere against the exact one: rel_rmse, max_rel_err (over the
    sphere's interior pixels and channels) and the unseen share."""
    data = glass_scene(case, size)
    ref, ids, unseen = reference(data, samples)
    glass = len(data["objects"]) - 1
    inside = interior_mask(np.where(ids == glass, glass, -1)) & (ids == glass)
    image = gpu_image(gl, data)
    errors = image_errors(image, ref, inside, 0.0, "neutral", flip=False)
    errors["unseen"] = float(unseen[inside].mean())
    errors["pixels"] = int(inside.sum())
    return errors


def transmission_table(gl: GLContext, size: tuple[int, int] = SIZE, samples: int = 16) -> str:
    """docs/transmission.md's error table (markdown)."""
    lines = [
        "| sphere | relative RMSE | largest relative error | unseen share |",
        "|---|---|---|---|",
    ]
    for case in CASES:
        e = case_errors(gl, case, size, samples)
        lines.append(
            f"| {case.name} | {e['rel_rmse']:.3f} | {e['max_rel_err']:.2f} | {e['unseen']:.2f} |"
        )
    return "\n".join(lines)


def run_transmission(ctx: Context) -> None:
    """Suite ``transmission``: per case, the frame (G-buffer, lighting, transmission pass)
    timed, with the opaque frame without the sphere interleaved as its baseline, and the
    error against exact refraction."""
    cases, size, samples = _plan(ctx.settings.mode)
    for case in cases:
        data = glass_scene(case, size)
        opaque = {**data, "objects": data["objects"][:-1]}
        renderers = [Renderer(ctx.gl, parse_scene(d, Path("inline.toml"))) for d in (data, opaque)]
        try:
            glass, plain = renderers
            glass.render()
            plain.render()
            tr = glass.transmission
            assert tr is not None
            m = glass.matrices

            def run_pass(r: Renderer = glass, m: CameraMatrices = m) -> None:
                assert r.transmission is not None
                r.transmission.run(r.gbuffer, r.lighting, m.view, m.proj, m.frame)

            passes = [*deferred_passes(glass), Pass("transmission", run_pass, None)]
            times = ctx.time_interleaved({"glass": passes, "opaque": deferred_passes(plain)})
        finally:
            for r in renderers:
                r.release()
        errors = case_errors(ctx.gl, case, size, samples)
        base = times["opaque"]
        ctx.rows.append(
            make_row(
                "transmission", case.name, "screen-space", size, 1, times["glass"],
                error_reference="float64 ray-caster, exact refraction through the sphere",
                comparison="transmission pass: frame time vs error against exact refraction",
                opaque_ms_median=float(np.median(base.wall_ms)), **errors,
            )
        )  # fmt: skip
        ctx.progress.done()


def transmission_tasks(settings: object) -> int:
    """The progress bar's share: one tick per case."""
    return len(_plan(getattr(settings, "mode", "full"))[0])


def transmission_lines(members: list[dict]) -> list[str]:
    """The report's table of suite ``transmission``'s rows (app/bench/report.py)."""
    header = ["sphere", "size", "frame ms (median)", "opaque frame ms", "rel_rmse",
              "max_rel_err", "unseen share"]  # fmt: skip
    return table_lines(header, [
        [r["case"], f"{r['width']}x{r['height']}", cell(r.get("ms_median"), ".2f"),
         cell(r.get("opaque_ms_median"), ".2f"), cell(r.get("rel_rmse"), ".3f"),
         cell(r.get("max_rel_err"), ".2f"), cell(r.get("unseen"), ".2f")]
        for r in members
    ])  # fmt: skip
