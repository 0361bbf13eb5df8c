"""Normal and roughness filtering measured against a supersampled reference (seed
section 13: measured, not asserted by eye).

Each option renders scenes/sec13_filtering.toml (or any scene with normal maps); the
reference renders the same view with ``supersample`` x ``supersample`` samples per pixel
from the unfiltered level 0 of every map (``normal_filter = "none"``), box-filtered
down. Per option: relative RMSE and mean FLIP against the reference, and shimmer, the
per-pixel standard deviation of the displayed luminance over a small sideways sweep of
the camera, averaged over the image.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.bench.metrics import image_errors
from app.gl.context import GLContext
from app.reference.tonemap import post_process
from app.render.renderer import Renderer
from app.scene.loader import LoadedScene

# (variant name, render-setting overrides): the options a scene can choose.
OPTIONS: list[tuple[str, dict]] = [
    ("none", {"normal_filter": "none"}),
    ("naive", {"normal_filter": "naive"}),
    ("toksvig", {"normal_filter": "toksvig"}),
    ("variance", {"normal_filter": "variance"}),
    ("naive+specular_aa", {"normal_filter": "naive", "specular_aa": True}),
    ("variance+specular_aa", {"normal_filter": "variance", "specular_aa": True}),
]
SWEEP_METRES = 0.02  # the camera's sideways travel over the shimmer sweep


@dataclass
class FilteringResult:
    variant: str
    hdr: np.ndarray  # (H, W, 3) at the sweep's first position
    ms: float  # median frame time (G-buffer to post), milliseconds
    rel_rmse: float | None
    flip_mean: float | None
    shimmer: float


def with_settings(
    loaded: LoadedScene, size: tuple[int, int], offset: float = 0.0, **render: object
) -> LoadedScene:
    """``loaded`` at ``size`` with render settings replaced and the camera (and its
    target) moved ``offset`` metres along its right axis."""
    scene = loaded.scene
    cam = scene.camera
    forward = np.subtract(cam.target, cam.position)
    right = np.cross(forward, cam.up)
    right /= np.linalg.norm(right)
    move = right * offset
    camera = cam.model_copy(
        update={
            "position": [float(x) for x in np.add(cam.position, move)],
            "target": [float(x) for x in np.add(cam.target, move)],
        }
    )
    settings = scene.render.model_copy(update={"width": size[0], "height": size[1], **render})
    return LoadedScene(scene.model_copy(update={"render": settings, "camera": camera}), loaded.path)


def render_hdr(gl: GLContext, loaded: LoadedScene) -> np.ndarray:
    """One frame's linear HDR image (supersampling resolved)."""
    return _render(gl, loaded)[0]


def _render(gl: GLContext, loaded: LoadedScene, repeats: int = 1) -> tuple[np.ndarray, float]:
    r = Renderer(gl, loaded)
    try:
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            r.render()
            r.read_ldr()  # waits for the GPU
            times.append((time.perf_counter() - start) * 1e3)
        return r.read_hdr(), float(np.median(times))
    finally:
        r.release()


def _luminance(hdr: np.ndarray, loaded: LoadedScene) -> np.ndarray:
    ldr = np.clip(
        post_process(
            hdr.astype(np.float64), loaded.scene.camera.exposure, loaded.scene.render.tonemap
        ),
        0.0,
        1.0,
    )
    return ldr @ np.array([0.2126, 0.7152, 0.0722])


def shimmer(frames: list[np.ndarray], loaded: LoadedScene) -> float:
    """Mean over pixels of the standard deviation over frames of displayed luminance."""
    lum = np.stack([_luminance(f, loaded) for f in frames])
    return float(lum.std(axis=0).mean())


def measure(
    gl: GLContext,
    loaded: LoadedScene,
    size: tuple[int, int],
    supersample: int = 8,
    sweep: int = 5,
    options: list[tuple[str, dict]] | None = None,
    repeats: int = 3,
    reference_shimmer: bool = False,
) -> tuple[list[FilteringResult], dict]:
    """Every option's error against the supersampled reference and its shimmer; also the
    reference's own row (its shimmer only when ``reference_shimmer``)."""
    offsets = np.linspace(0.0, SWEEP_METRES, sweep)
    ref_settings = {"normal_filter": "none", "supersample": supersample}
    ref_loaded = with_settings(loaded, size, 0.0, **ref_settings)
    ref, ref_ms = _render(gl, ref_loaded)
    covered = np.ones(ref.shape[:2], bool)
    exposure, tonemap = loaded.scene.camera.exposure, loaded.scene.render.tonemap
    results = []
    for name, settings in options or OPTIONS:
        frames, ms = [], 0.0
        for k, offset in enumerate(offsets):
            hdr, t = _render(gl, with_settings(loaded, size, float(offset), **settings),
                             repeats if k == 0 else 1)  # fmt: skip
            frames.append(hdr)
            ms = t if k == 0 else ms
        errors = image_errors(frames[0], ref, covered, exposure, tonemap)
        results.append(
            FilteringResult(
                name,
                frames[0],
                ms,
                errors["rel_rmse"],
                errors["flip_mean"],
                shimmer(frames, loaded),
            )
        )
    ref_row = {"hdr": ref, "ms": ref_ms, "shimmer": None}
    if reference_shimmer:
        frames = [ref] + [
            _render(gl, with_settings(loaded, size, float(o), **ref_settings))[0]
            for o in offsets[1:]
        ]
        ref_row["shimmer"] = shimmer(frames, loaded)
    return results, ref_row


def grooves(gl: GLContext, out: Path) -> None:
    """docs/filtering.md's LEAN table: scenes/sec13_grooves.toml at 320x180 against a 16x16
    reference, isotropic ``variance`` mips against ``lean`` (and ``naive``), with the
    floor's Beckmann NDF and again with GGX; ``filtering-grooves.png``: reference,
    variance, lean (Beckmann) over the same with GGX; ``filtering-groove-spheres.png``:
    ``GROOVE_SPHERES`` as the reference, variance and lean draw it."""
    from PIL import Image

    from app.resources import scenes_dir
    from app.scene.loader import load_scene

    loaded = load_scene(scenes_dir() / "sec13_grooves.toml")
    cam, settings = loaded.scene.camera, loaded.scene.render
    options = [(m, {"normal_filter": m}) for m in ("naive", "variance", "lean")]
    print("| NDF | option | ms / frame | rel. RMSE | mean FLIP | shimmer |")
    print("|---|---|---:|---:|---:|---:|")
    rows = []
    for ndf in ("beckmann", "ggx"):
        materials = {
            name: m.model_copy(update={"ndf": ndf}) for name, m in loaded.scene.materials.items()
        }
        scene = LoadedScene(loaded.scene.model_copy(update={"materials": materials}), loaded.path)
        results, ref = measure(gl, scene, (320, 180), supersample=16, options=options)
        tiles = [ref["hdr"]] + [r.hdr for r in results if r.variant != "naive"]
        ldr = [
            np.clip(post_process(h.astype(np.float64), cam.exposure, settings.tonemap), 0, 1)
            for h in tiles
        ]
        rows.append(np.concatenate([(x * 255.0 + 0.5).astype(np.uint8) for x in ldr], axis=1))
        for r in results:
            print(
                f"| {ndf} | {r.variant} | {r.ms:.1f} | {r.rel_rmse:.3f} | {r.flip_mean:.3f} | "
                f"{r.shimmer:.5f} |"
            )
    Image.fromarray(np.concatenate(rows, axis=0)).save(out / "filtering-grooves.png")
    # Khronos AnisotropyRotationTest's point: a groove normal map seen from afar should
    # spread a light like an anisotropic material. An anisotropic sphere (no normal map)
    # beside a grooved one, with each filter and the 8x8 reference from level 0:
    # ``filtering-groove-spheres.png``.
    from app.scene.sources import scene_from

    pair = scene_from(GROOVE_SPHERES, base_dir=scenes_dir())
    tiles, hdrs = [], []
    for render in ({"normal_filter": "none", "supersample": 8}, {"normal_filter": "variance"},
                   {"normal_filter": "lean"}):  # fmt: skip
        hdr = render_hdr(gl, with_settings(pair, (320, 160), **render))
        hdrs.append(hdr)
        ldr = np.clip(post_process(hdr.astype(np.float64), 0.0, "neutral"), 0, 1)
        tiles.append((ldr * 255.0 + 0.5).astype(np.uint8))
    Image.fromarray(np.concatenate(tiles, axis=1)).save(out / "filtering-groove-spheres.png")
    covered = np.ones(hdrs[0].shape[:2], bool)
    for name, hdr in zip(("variance", "lean"), hdrs[1:], strict=True):
        e = image_errors(hdr, hdrs[0], covered, 0.0, "neutral")
        print(f"groove spheres (GGX), {name}: rel. RMSE {e['rel_rmse']:.3f}, "
              f"mean FLIP {e['flip_mean']:.3f}")  # fmt: skip


def models(gl: GLContext, paths: list[str]) -> None:
    """docs/filtering.md's general normal maps: each model file framed as ``pbs render``
    frames it (app/scene/model_file.py), NormalTangentTest-sized square images (384 px for
    the first, 320 for the rest), ``naive``, ``variance`` and ``lean`` against an 8x8
    reference from level 0; one table row per model and option."""
    from app.scene.sources import scene_from

    print("| model | option | rel. RMSE | mean FLIP | shimmer |")
    print("|---|---|---:|---:|---:|")
    options = [(m, {"normal_filter": m}) for m in ("naive", "variance", "lean")]
    for i, path in enumerate(paths):
        side = 384 if i == 0 else 320
        loaded = scene_from(path, size=(side, side))
        results, _ = measure(gl, loaded, (side, side), supersample=8, options=options)
        for r in results:
            print(
                f"| {Path(path).stem} | {r.variant} | {r.rel_rmse:.3f} | {r.flip_mean:.3f} | "
                f"{r.shimmer:.5f} |"
            )


# Two silver spheres: anisotropic (stretched along the bitangent, no normal map) and
# grooved along u (scenes/textures/groove_normal.png, 256 grooves from pole to pole).
GROOVE_SPHERES = {
    "background": [0.05, 0.05, 0.07],
    "camera": {"position": [0.0, 0.0, 12.0], "target": [0.0, 0.0, 0.0], "fov_y": 20.0},
    "materials": {
        "anisotropic": {"preset": "silver", "roughness": 0.35, "anisotropy": -0.8},
        "grooved": {
            "preset": "silver",
            "roughness": 0.15,
            "normal_map": "textures/groove_normal.png",
            "uv_scale": [8.0, 16.0],
        },
    },
    "lights": [{"type": "directional", "direction": [-0.3, -0.2, -1.0], "intensity": 3.0}],
    "objects": [
        {"shape": "sphere", "radius": 1.0, "position": [-1.3, 0.0, 0.0], "material": "anisotropic"},
        {"shape": "sphere", "radius": 1.0, "position": [1.3, 0.0, 0.0], "material": "grooved"},
    ],
}


def main() -> None:
    """``python -m app.bench.filtering [OUT_DIR] [grooves]``: the table and the image grid
    (``filtering-grid.png``) of docs/filtering.md (320x180, 16x16 reference, 5-step
    sweep), and the naive and variance rows again with the floor's NDF switched to GGX;
    with ``grooves``, the LEAN table instead (``grooves``); with ``models PATH...``, the
    general normal maps' table (``models``)."""
    import sys

    from PIL import Image

    from app.gl.context import create_context
    from app.resources import scenes_dir
    from app.scene.loader import load_scene

    out = Path(sys.argv[1] if len(sys.argv) > 1 else "docs/images")
    if sys.argv[2:3] == ["grooves"]:
        gl = create_context()
        grooves(gl, out)
        gl.release()
        return
    if sys.argv[2:3] == ["models"]:
        gl = create_context()
        models(gl, sys.argv[3:])
        gl.release()
        return
    loaded = load_scene(scenes_dir() / "sec13_filtering.toml")
    gl = create_context()
    results, ref = measure(gl, loaded, (320, 180), supersample=16, reference_shimmer=True)
    cam, settings = loaded.scene.camera, loaded.scene.render

    tiles: dict[str, np.ndarray] = {}

    def save(name: str, hdr: np.ndarray) -> None:
        ldr = np.clip(post_process(hdr.astype(np.float64), cam.exposure, settings.tonemap), 0, 1)
        tiles[name] = (ldr * 255.0 + 0.5).astype(np.uint8)

    save("reference", ref["hdr"])
    print("| option | ms / frame | rel. RMSE | mean FLIP | shimmer |")
    print("|---|---:|---:|---:|---:|")
    print(f"| reference (16x16, level 0) | {ref['ms']:.0f} | 0 | 0 | {ref['shimmer']:.5f} |")
    for r in results:
        save(r.variant.replace("+", "-"), r.hdr)
        print(
            f"| {r.variant} | {r.ms:.1f} | {r.rel_rmse:.3f} | {r.flip_mean:.3f} | {r.shimmer:.5f} |"
        )
    # The same floor with GGX: the variance mapping assumes Beckmann's Gaussian slopes.
    materials = {
        name: m.model_copy(update={"ndf": "ggx"}) for name, m in loaded.scene.materials.items()
    }
    ggx = LoadedScene(loaded.scene.model_copy(update={"materials": materials}), loaded.path)
    options = [(m, {"normal_filter": m}) for m in ("naive", "variance")]
    ggx_results, _ = measure(gl, ggx, (320, 180), supersample=16, options=options)
    for r in ggx_results:
        print(
            f"| {r.variant}, GGX floor | {r.ms:.1f} | {r.rel_rmse:.3f} | {r.flip_mean:.3f} | "
            f"{r.shimmer:.5f} |"
        )
    grid = ["reference", "none", "naive", "toksvig", "variance", "naive-specular_aa"]
    rows = [np.concatenate([tiles[n] for n in grid[k : k + 3]], axis=1) for k in (0, 3)]
    Image.fromarray(np.concatenate(rows, axis=0)).save(out / "filtering-grid.png")
    gl.release()


if __name__ == "__main__":
    main()
