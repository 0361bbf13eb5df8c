"""Suite ``shadows`` (docs/shadows.md): the frame time of a shadowed light by
filter (no shadow, PCF, PCSS) and light type, and the shadow map's resolution against its
error, on a time-vs-error front.

Scene: the accuracy scene of tests/test_shadows.py (two spheres, one on and one over an
8 m floor) under one light. Time: the deferred frame (G-buffer, lighting) plus the shadow
pass redrawn every frame (``ShadowPass.invalidate``), so the row is what a frame costs
when its maps must be rendered (a moved light); ``passes_ms`` separates the two. Error:
the fraction of the lit pixels (those the unshadowed render lights) whose lit/unlit state
differs from the float64 ray-caster's shadow rays (app/reference/raycast.py
``shadow_visibility``), the metric of tests/test_shadows.py; lit on the GPU means the
shadowed render over the unshadowed one above 0.5. PCSS is measured against the same hard
reference: its wider penumbra counts as error here (its own accuracy, the penumbra's width
against an area light, is tests/test_shadows.py's).

Case ``showcase``: scenes/showcase.toml's whole frame (``Renderer.render``, the maps drawn
once, as a still camera has them) as it is and with every ``shadow`` off, in alternating
rounds; app/bench/report.py's target asks the shadowed frame for at most 1.5x the other.
"""

from __future__ import annotations

import copy

import numpy as np

from app.bench.context import Context, Settings, make_row
from app.bench.timing import Pass
from app.frame.camera import camera_frame
from app.frame.lights import frame_lights
from app.frame.raycast import primitive
from app.reference.raycast import cast, shadow_visibility
from app.render.renderer import Renderer
from app.resources import scenes_dir
from app.scene.loader import LoadedScene, parse_scene, read_toml

LIGHTS = {
    "directional": {"type": "directional", "direction": [-1.0, -0.6, -0.3], "intensity": 2.0},
    "spot": {
        "type": "spot", "position": [0.8, 3.0, 1.2], "direction": [-0.1, -1.0, -0.2],
        "intensity": 12.0, "range": 8.0, "inner_angle": 30.0, "outer_angle": 40.0,
    },
    "point": {"type": "point", "position": [0.9, 2.0, 0.9], "intensity": 10.0, "range": 9.0},
}  # fmt: skip
# PCSS's light size per type: a 5 cm bulb, a sun of 1 degree angular radius.
PCSS_SIZE = {
    "directional": {"shadow_light_angle": 1.0},
    "spot": {"shadow_light_radius": 0.05},
    "point": {"shadow_light_radius": 0.05},
}
FILTERS = ("off", "pcf", "pcss")


def shadow_scene(light: dict, size: tuple[int, int]) -> dict:
    """The two spheres over a floor under ``light`` (tests/test_shadows.py's scene)."""
    return {
        "render": {"width": size[0], "height": size[1]},
        "camera": {"position": [0.0, 2.5, 5.0], "target": [0.0, 0.3, 0.0], "fov_y": 40.0},
        "materials": {"m": {"base_color": [0.8, 0.8, 0.8], "roughness": 0.6}},
        "objects": [
            {"shape": "plane", "size": [8.0, 8.0], "material": "m"},
            {"shape": "sphere", "radius": 0.5, "position": [-0.8, 0.5, 0.0], "material": "m"},
            {"shape": "sphere", "radius": 0.35, "position": [0.7, 0.8, -0.4], "material": "m"},
        ],
        "lights": [light],
    }


def with_shadow(light: dict, kind: str, shadow_filter: str, resolution: int) -> dict:
    """``light`` (of type ``kind``) with ``shadow_filter`` ("off": no shadow) at
    ``resolution`` texels a side."""
    if shadow_filter == "off":
        return dict(light)
    extra = PCSS_SIZE[kind] if shadow_filter == "pcss" else {}
    return {
        **light, "shadow": True, "shadow_filter": shadow_filter,
        "shadow_resolution": resolution, **extra,
    }  # fmt: skip


def _load(data: dict) -> LoadedScene:
    return parse_scene(copy.deepcopy(data), scenes_dir() / "bench_shadows.toml")


def frame_passes(r: Renderer) -> list[Pass]:
    """The shadow pass (every map redrawn) where the light casts shadows, G-buffer and
    lighting."""
    background = np.asarray(r.scene.background, np.float64)
    passes = []
    if r.shadows is not None:
        shadows = r.shadows

        def redraw() -> None:
            shadows.invalidate()
            shadows.run(r.proj @ r.view)

        passes.append(Pass("shadows", redraw, shadows.fbo))
    passes.append(
        Pass(
            "gbuffer",
            lambda: r.gbuffer_pass.run(r.gbuffer, r.view, r.proj, r.camera),
            r.gbuffer.fbo,
        )
    )
    passes.append(
        Pass("lighting", lambda: r.lighting.run(r.gbuffer, r.camera, background), r.lighting.fbo)
    )
    return passes


def reference_lit(data: dict, size: tuple[int, int]) -> np.ndarray:
    """(H, W) bool: the ray-caster's shadow ray reaches the light (covered pixels)."""
    scene = _load(data).scene
    prims = [primitive(i, obj) for i, obj in enumerate(scene.objects)]
    hits = cast(prims, camera_frame(scene.camera, *size), size)
    light = dict(scene.lights[0].model_dump(), shadow=True)
    lights = frame_lights([type(scene.lights[0]).model_validate(light)])
    return shadow_visibility(prims, hits, lights)[0] > 0.5


def mismatch(image: np.ndarray, plain: np.ndarray, lit_ref: np.ndarray) -> tuple[float, int]:
    """(fraction, count) of the pixels the unshadowed render lights whose lit state (the
    ratio of ``image`` to ``plain`` over 0.5) differs from ``lit_ref``."""
    lum, lum_plain = image.sum(axis=-1), plain.sum(axis=-1)
    lit = lum_plain > 1e-3 * lum_plain.max()
    gpu = lum / np.maximum(lum_plain, 1e-30) > 0.5
    wrong = (gpu != lit_ref) & lit
    return float(wrong.sum() / max(int(lit.sum()), 1)), int(lit.sum())


def shadows_tasks(settings: Settings) -> int:
    """Progress steps: per light type the filters at the largest map, then the others; the
    showcase."""
    return len(LIGHTS) * (1 + int(len(settings.shadow_resolutions) > 1)) + 1


SHOWCASE = "showcase"  # the case of the showcase's rows (app/bench/report.py's target)
SHOWCASE_VARIANTS = ("shadows", "no shadows")


def run_showcase(ctx: Context) -> None:
    """scenes/showcase.toml at ``shadow_showcase_size``: the whole frame with its shadows
    and with every light's ``shadow`` off, in alternating rounds."""
    size = ctx.settings.shadow_showcase_size
    ctx.progress.start("shadows showcase: on and off")
    data = read_toml(scenes_dir() / "showcase.toml")
    plain = copy.deepcopy(data)
    for light in plain.get("lights", []):
        light.pop("shadow", None)
    scenes = {"shadows": data, "no shadows": plain}
    renderers = {}
    try:
        for name, d in scenes.items():
            renderers[name] = Renderer(
                ctx.gl, parse_scene(copy.deepcopy(d), scenes_dir() / "showcase.toml"), size
            )
        times = ctx.time_interleaved(
            {name: [Pass("frame", r.render, None)] for name, r in renderers.items()}
        )
        shadowed = sum(bool(light.get("shadow")) for light in data.get("lights", []))
        for name in SHOWCASE_VARIANTS:
            ctx.rows.append(
                make_row("shadows", SHOWCASE, name, size, len(data.get("lights", [])),
                         times[name], shadowed_lights=shadowed if name == "shadows" else 0)
            )  # fmt: skip
    finally:
        for r in renderers.values():
            r.release()
    ctx.progress.done()


def run_shadows(ctx: Context) -> None:
    """Per light type: no shadow, PCF and PCSS at the default resolution timed in
    alternating rounds; then PCF and PCSS at each of ``shadow_resolutions``; each row's
    mismatch fraction against the ray-caster."""
    s = ctx.settings
    size = s.shadow_size
    default_res = s.shadow_resolutions[-1]
    for kind, light in LIGHTS.items():
        lit_ref = reference_lit(shadow_scene(light, size), size)
        cases = [("filters", f, default_res) for f in FILTERS]
        cases += [("resolution", f, res) for res in s.shadow_resolutions[:-1] for f in FILTERS[1:]]
        for group in ("filters", "resolution"):
            chosen = [c for c in cases if c[0] == group]
            if not chosen:
                continue
            ctx.progress.start(f"shadows {kind}: {group}")
            renderers = {}
            try:
                for _, f, res in chosen:
                    data = shadow_scene(with_shadow(light, kind, f, res), size)
                    renderers[(f, res)] = Renderer(ctx.gl, _load(data), size)
                times = ctx.time_interleaved(
                    {f"{f}@{res}": frame_passes(r) for (f, res), r in renderers.items()}
                )
                images = {}
                for key, r in renderers.items():
                    r.render()
                    images[key] = r.read_hdr().astype(np.float64)
            finally:
                for r in renderers.values():
                    r.release()
            plain = images.get(("off", default_res))
            if plain is None:
                off = Renderer(ctx.gl, _load(shadow_scene(light, size)), size)
                try:
                    off.render()
                    plain = off.read_hdr().astype(np.float64)
                finally:
                    off.release()
            for (f, res), image in images.items():
                frac, lit = mismatch(image, plain, lit_ref)
                ctx.rows.append(
                    make_row(
                        "shadows", kind, f if f == "off" else f"{f} {res}", size, 1,
                        times[f"{f}@{res}"], shadow_filter=f, shadow_resolution=res,
                        mismatch=frac if f != "off" else None, lit_pixels=lit,
                        error_reference="lit/unlit vs the float64 ray-caster's shadow rays",
                    )
                )  # fmt: skip
            ctx.progress.done()
    run_showcase(ctx)
