"""The whole pipeline against the float64 ray-caster: the GPU's linear HDR of a
scene of analytic primitives, compared on interior pixels with app/frame/raycast.py's
reference of the same scene (app/bench/metrics.py ``interior_errors``).

``five_spheres`` is the measuring scene: five spheres of the default model
(GGX, Smith height-correlated, Schlick, Lambert) under two directional lights, and two point
lights where asked; its two settings that matter, ``subdivisions`` (None: the analytic
sphere) and ``gbuffer`` (None: the default encoding), are arguments.
scripts/raycast_table.py prints docs/accuracy.md's table from it.

``every_pixel_errors`` compares every pixel instead, edges included, with the
pixel-area-integrated truth (``reference_scene`` with many samples per pixel): the mean
FLIP over the whole image and split into edge and interior pixels, for the renderer under
any settings overrides (``with_settings``); scripts/accuracy_doc.py tabulates it.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np

from app.bench.metrics import interior_errors
from app.frame.raycast import reference_scene
from app.gl.context import GLContext
from app.reference.raycast import RaycastImage, edge_mask
from app.reference.tonemap import post_process
from app.render.renderer import Renderer
from app.scene.loader import LoadedScene, load_scene, parse_scene
from app.scene.model import Light

# (base_color, metallic, roughness): a spread of roughness over dielectrics and metals,
# none below 0.3 so that no highlight is sharper than a few pixels at 640x360.
FIVE_SPHERES = [
    ((0.80, 0.20, 0.15), 0.0, 0.30),
    ((0.20, 0.60, 0.25), 0.0, 0.50),
    ((0.90, 0.90, 0.90), 0.0, 0.90),
    ((1.00, 0.78, 0.34), 1.0, 0.35),
    ((0.95, 0.64, 0.54), 1.0, 0.60),
]


def five_spheres(
    subdivisions: int | None = None, gbuffer: str | None = None, point_lights: bool = False
) -> LoadedScene:
    """Five unit-diameter spheres in a row, 1.2 m apart, seen from 6 m, lit by a warm key
    light from the upper left and a cool fill from the right (and, with ``point_lights``,
    two point lights with a range close in front of them); ``subdivisions`` None keeps the
    analytic sphere, ``gbuffer`` None the default encoding."""
    materials = {
        f"m{i}": {"base_color": list(c), "metallic": m, "roughness": r}
        for i, (c, m, r) in enumerate(FIVE_SPHERES)
    }
    objects = []
    for i in range(len(FIVE_SPHERES)):
        obj: dict = {
            "shape": "sphere",
            "radius": 0.5,
            "position": [1.2 * (i - 2), 0.0, 0.0],
            "material": f"m{i}",
        }
        if subdivisions is not None:
            obj["subdivisions"] = subdivisions
        objects.append(obj)
    data = {
        "background": [0.02, 0.02, 0.03],
        "render": {"width": 640, "height": 360},
        "camera": {"position": [0.0, 0.6, 6.0], "target": [0.0, 0.0, 0.0], "fov_y": 35.0},
        "materials": materials,
        "lights": [
            {"type": "directional", "direction": [0.5, -0.6, -0.62], "intensity": 3.0},
            {
                "type": "directional",
                "direction": [-0.8, -0.1, -0.6],
                "color": [0.6, 0.7, 1.0],
                "intensity": 1.0,
            },
        ],
        "objects": objects,
    }
    if gbuffer is not None:
        data["render"]["gbuffer"] = gbuffer
    if point_lights:
        data["lights"] += [
            {"type": "point", "position": [-1.4, 1.0, 1.4], "intensity": 6.0, "range": 6.0},
            {"type": "point", "position": [1.8, -0.4, 1.2], "color": [1.0, 0.85, 0.6],
             "intensity": 4.0, "range": 5.0},
        ]  # fmt: skip
    return parse_scene(data, Path("five_spheres.toml"))


def scene_with_spheres(
    path: Path, subdivisions: int | None = None, gbuffer: str | None = None
) -> LoadedScene:
    """A scene file with its analytic spheres drawn as icospheres of ``subdivisions``
    (None: kept analytic) and ``render.gbuffer`` set (None: the file's own): the same
    scene as the pipeline drew it with icospheres, or with another encoding."""
    data = tomllib.loads(Path(path).read_text())
    for obj in data.get("objects", []):
        if obj.get("shape") == "sphere" and subdivisions is not None:
            obj.setdefault("subdivisions", subdivisions)
    if gbuffer is not None:
        data.setdefault("render", {})["gbuffer"] = gbuffer
    return parse_scene(data, Path(path))


def gpu_hdr(
    gl: GLContext, loaded: LoadedScene, size: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray]:
    """The renderer's linear HDR of ``loaded`` at ``size``, float64 (H, W, 3), and its
    coverage (H, W): the pixels some sample of whose G-buffer holds a surface (depth > 0)."""
    r = Renderer(gl, loaded, size)
    try:
        r.render()
        hdr = r.read_hdr().astype(np.float64)
        depth = r.read_gbuffer().depth
    finally:
        r.release()
    f = loaded.scene.render.supersample
    w, h = size
    covered = (depth > 0.0).reshape(h, f, w, f).any(axis=(1, 3))
    return hdr, covered


def raycast_errors(
    gl: GLContext, loaded: LoadedScene, size: tuple[int, int], flip: bool = True
) -> dict[str, float | None]:
    """``interior_errors`` of the renderer's HDR of ``loaded`` against the ray-caster's,
    on the pixels 2 px or more inside a silhouette (``interior_mask``), plus the share of
    pixels covered by one and not the other (``coverage_mismatch``). The renderer draws
    the pixel-centre image (``pixel_centres``), the one this comparison is about."""
    loaded = pixel_centres(loaded)
    ref = reference_scene(loaded, size)
    hdr, covered = gpu_hdr(gl, loaded, size)
    cam, render = loaded.scene.camera, loaded.scene.render
    errors = interior_errors(hdr, ref.hdr, ref.interior(), cam.exposure, render.tonemap, flip)
    errors["coverage_mismatch"] = float(np.mean(covered != ref.covered))
    return errors


# The every-pixel comparison ---------------------------------------------------------------


def pixel_centres(loaded: LoadedScene) -> LoadedScene:
    """``loaded`` with ``render.antialiasing = "none"`` where the settings have that key:
    one sample at each pixel centre (``render.supersample`` aside), the image the
    interior-pixel comparison holds to its targets (docs/accuracy.md)."""
    render = loaded.scene.render
    if "antialiasing" not in type(render).model_fields:
        return loaded
    return with_settings(loaded, {"render.antialiasing": "none"})


def unshadowed(loaded: LoadedScene) -> LoadedScene:
    """``loaded`` with every light's shadow off (the shadow keys at their defaults): a
    shadow map's filtered edge is not the ray-caster's hard shadow-ray edge, and shadows
    are measured on their own (docs/shadows.md)."""
    keys = {key for key in Light.model_fields if key.startswith("shadow")}
    lights = [
        type(light).model_validate(light.model_dump(exclude=keys)) for light in loaded.scene.lights
    ]
    return LoadedScene(loaded.scene.model_copy(update={"lights": lights}), loaded.path)


def parse_overrides(text: str) -> dict[str, object]:
    """``"render.supersample=2,render.gbuffer=f16"`` -> {"render.supersample": 2, ...}: each
    value read as a TOML value where it is one (numbers, booleans, quoted strings), else
    kept as the bare string (``render.antialiasing=fxaa``); "" is no override."""
    out: dict[str, object] = {}
    for item in filter(None, (part.strip() for part in text.split(","))):
        key, sep, value = item.partition("=")
        if not sep or "." not in key:
            raise ValueError(f"setting {item!r}: expected SECTION.KEY=VALUE")
        try:
            out[key.strip()] = tomllib.loads(f"v = {value.strip()}")["v"]
        except tomllib.TOMLDecodeError:
            out[key.strip()] = value.strip()
    return out


def with_settings(loaded: LoadedScene, overrides: dict[str, object]) -> LoadedScene:
    """``loaded`` with each ``SECTION.KEY`` of ``overrides`` set (``render.supersample``,
    ``render.antialiasing``...), validated as a scene file's value is: a ValueError names
    the key it refuses."""
    scene = loaded.scene
    for dotted, value in overrides.items():
        section, key = dotted.split(".", 1)
        sub = getattr(scene, section, None)
        if sub is None or not hasattr(sub, "model_dump"):
            raise ValueError(f"{dotted}: no settings section {section!r}")
        try:
            new = type(sub).model_validate({**sub.model_dump(), key: value})
        except Exception as exc:  # pydantic's ValidationError, one line of it
            raise ValueError(f"{dotted}: {str(exc).splitlines()[-1].strip()}") from exc
        scene = scene.model_copy(update={section: new})
    return LoadedScene(scene, loaded.path)


def settings_label(overrides: dict[str, object]) -> str:
    """``render.supersample=2`` style, "defaults" for none."""
    return ", ".join(f"{k}={v}" for k, v in overrides.items()) or "defaults"


def gpu_images(
    gl: GLContext, loaded: LoadedScene, size: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray]:
    """The renderer's resolved linear HDR (H, W, 3) float64 and its display image (H, W, 3)
    in [0, 1] (the 8-bit sRGB the user gets, after every post pass) of ``loaded``."""
    r = Renderer(gl, loaded, size)
    try:
        r.render()
        ldr = r.read_ldr().astype(np.float64) / 255.0
        hdr = r.read_hdr().astype(np.float64)
    finally:
        r.release()
    return hdr, ldr


def _flip(reference: np.ndarray, test: np.ndarray) -> np.ndarray:
    """NVIDIA's FLIP (LDR) map (H, W) between two display images in [0, 1]."""
    import flip_evaluator

    error_map, _, _ = flip_evaluator.evaluate(
        np.ascontiguousarray(reference, np.float32),
        np.ascontiguousarray(test, np.float32),
        "LDR",
        applyMagma=False,
    )
    return np.asarray(error_map, np.float64).reshape(reference.shape[:2])


def _mean(a: np.ndarray, sel: np.ndarray) -> float | None:
    return float(a[sel].mean()) if np.any(sel) else None


def every_pixel_errors(
    hdr: np.ndarray,
    truth: RaycastImage,
    exposure_ev: float,
    tonemap: str,
    display: np.ndarray | None = None,
    margin: int = 1,
) -> dict[str, float | None]:
    """``hdr`` against the pixel-area-integrated ``truth`` over every pixel:

    * ``flip_mean``: mean FLIP (LDR) of the whole image, both tone mapped by the scene's
      exposure and tone map in float64 (app/bench/metrics.py ``flip_map``'s convention);
      ``flip_edge`` and ``flip_interior`` the same map averaged over the edge pixels
      (``edge_mask(truth.ids, margin)``: pixels a silhouette or a boundary between
      primitives crosses, and their neighbours) and over the rest;
    * ``rel_rmse``: RMS of the linear HDR error over the RMS of the truth, all pixels and
      channels (``rel_rmse_edge``: the edge pixels' RMS error, same denominator);
    * ``display_flip_mean`` (with ``display``, the renderer's 8-bit display image in
      [0, 1]): mean FLIP against the truth's display image rounded to 8 bits as the
      display target rounds it, so that post passes on the display image count, and
      ``display_flip_edge`` / ``display_flip_interior`` that map over the edge pixels and
      the rest;
    * ``edge_share``: the fraction of the image's pixels that are edge pixels."""
    want = np.asarray(truth.hdr, np.float64)
    got = np.asarray(hdr, np.float64)
    ref_ldr = np.clip(post_process(want, exposure_ev, tonemap), 0.0, 1.0)
    test_ldr = np.clip(post_process(got, exposure_ev, tonemap), 0.0, 1.0)
    flip = _flip(ref_ldr, test_ldr)
    edge = edge_mask(truth.ids, margin)
    err2 = ((got - want) ** 2).sum(axis=-1)
    norm = float(np.sqrt(np.mean(want * want)))
    out: dict[str, float | None] = {
        "flip_mean": float(flip.mean()),
        "flip_edge": _mean(flip, edge),
        "flip_interior": _mean(flip, ~edge),
        "rel_rmse": float(np.sqrt(err2.mean() / 3.0)) / norm if norm > 0 else None,
        "rel_rmse_edge": (
            float(np.sqrt(err2[edge].mean() / 3.0)) / norm if norm > 0 and edge.any() else None
        ),
        "display_flip_mean": None,
        "display_flip_edge": None,
        "display_flip_interior": None,
        "edge_share": float(edge.mean()),
    }
    if display is not None:
        quantised = np.round(ref_ldr * 255.0) / 255.0
        shown = _flip(quantised, display)
        out["display_flip_mean"] = float(shown.mean())
        out["display_flip_edge"] = _mean(shown, edge)
        out["display_flip_interior"] = _mean(shown, ~edge)
    return out


def truth_errors(a: RaycastImage, b: RaycastImage, exposure_ev: float, tonemap: str) -> dict:
    """How far two truths (e.g. 8 x 8 and 16 x 16 samples per pixel) are apart, by
    ``every_pixel_errors`` of one against the other: the truth's own convergence."""
    return every_pixel_errors(a.hdr, b, exposure_ev, tonemap)


def analytic_scenes(scenes: Path, environments: bool = False) -> list[Path]:
    """The bundled scenes the ray-caster takes whose spheres are all analytic, lit by
    punctual lights only (``environments``: a uniform environment allowed too; its
    quadrature per sample makes a supersampled truth 10 to 100 times dearer). Scenes lit
    by an image, sky or studio are left out: the split sum is an approximation by design
    (docs/ibl.md)."""
    out = []
    for path in sorted(Path(scenes).glob("*.toml")):
        loaded = load_scene(path)
        env = loaded.scene.environment
        if env is not None and (env.source != "uniform" or not environments):
            continue
        try:
            reference_scene(loaded, (4, 4))
        except ValueError:
            continue
        if all(obj.subdivisions is None for obj in loaded.scene.objects):
            out.append(path)
    return out


def every_pixel_row(
    gl: GLContext,
    loaded: LoadedScene,
    size: tuple[int, int],
    truth: RaycastImage,
    overrides: dict[str, object],
) -> dict[str, float | None]:
    """``every_pixel_errors`` of the renderer's image of ``loaded`` under ``overrides``
    against ``truth`` (which the overrides do not change: it is the scene's)."""
    variant = with_settings(loaded, overrides)
    hdr, ldr = gpu_images(gl, variant, size)
    cam, render = variant.scene.camera, variant.scene.render
    return every_pixel_errors(hdr, truth, cam.exposure, render.tonemap, ldr)


# What the every-pixel error is made of --------------------------------------------------

# The rows of ``every_pixel_floor``: the default, the aliased frame, and box filters of 4 x 4
# and 8 x 8 samples (the last two the floor a converging image reaches at this size).
FLOOR_ROWS = {
    "defaults": {},
    "none": {"render.antialiasing": "none"},
    "4x4": {"render.antialiasing": "none", "render.supersample": 4},
    "8x8": {"render.antialiasing": "none", "render.supersample": 8},
}


def every_pixel_floor(
    gl: GLContext,
    loaded: LoadedScene,
    size: tuple[int, int],
    truth: RaycastImage,
    finer: RaycastImage | None = None,
) -> dict[str, float | None]:
    """Where the every-pixel FLIP of ``loaded`` at ``size`` comes from, against ``truth``:

    * ``quantisation``: the truth's own display image in float against it rounded to 8 bits
      (what FLIP makes of rounding alone, where only one side is rounded);
    * ``truth``: ``truth`` against ``finer`` (twice the rays per side), its convergence;
    * per row of ``FLOOR_ROWS``: ``<row>_8bit`` (the display image against the rounded
      truth, the issue's number), ``<row>_edge`` and ``<row>_interior`` (that map over the
      edge pixels and the rest), and ``<row>_float`` (the resolved HDR through the tone map
      in float64 against the unrounded truth: no rounding on either side; None for the
      defaults, whose edge resolve is in the 8-bit display image only)."""
    cam, render = loaded.scene.camera, loaded.scene.render
    ref = np.clip(post_process(truth.hdr, cam.exposure, render.tonemap), 0.0, 1.0)
    rounded = np.round(ref * 255.0) / 255.0
    edge = edge_mask(truth.ids, 1)
    out: dict[str, float | None] = {
        "quantisation": float(_flip(ref, rounded).mean()),
        "truth": None,
        "edge_share": float(edge.mean()),
    }
    if finer is not None:
        out["truth"] = truth_errors(truth, finer, cam.exposure, render.tonemap)["flip_mean"]
    for label, overrides in FLOOR_ROWS.items():
        hdr, ldr = gpu_images(gl, with_settings(loaded, overrides), size)
        shown = _flip(rounded, ldr)
        out[f"{label}_8bit"] = float(shown.mean())
        out[f"{label}_edge"] = _mean(shown, edge)
        out[f"{label}_interior"] = _mean(shown, ~edge)
        out[f"{label}_float"] = None
        if label != "defaults":
            test = np.clip(post_process(hdr, cam.exposure, render.tonemap), 0.0, 1.0)
            out[f"{label}_float"] = float(_flip(ref, test).mean())
    return out
