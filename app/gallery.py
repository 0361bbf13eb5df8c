"""``pbs gallery``: a contact sheet of model files framed as ``pbs render MODEL`` frames
them (no scene file: app/scene/model_file.py) but lit and exposed as the reference viewer
shows them (``reference_look``: the glTF Sample Viewer's image-based light only, fixed
exposure, neutral tone map), beside their reference screenshots.

A gallery folder holds one sample model per subfolder, as the Khronos glTF sample
repositories lay them out: ``NAME/glTF/NAME.gltf`` (or ``NAME/glTF-Binary/NAME.glb``, or a
.gltf/.glb directly in ``NAME/``) and the reference image ``NAME/screenshot/screenshot.png``
(or .jpg, .jpeg, .gif: its first frame; or ``NAME/screenshot.*``). A model file directly
in the folder is a model too, its reference ``NAME.png``/``.jpg`` beside it. Each model
becomes one cell: this renderer's image on the left, the reference on the right (letterboxed
into the same square), the model's name under both (docs/gltf.md, "Conformance gallery").
A model that the view covers no pixel of (a flat model seen edge-on) is shown from
``FALLBACK_VIEW`` instead, its label saying so.

Every model is loaded, validated and rendered before the sheet is written, so a bad model
or reference image is one ``InputError`` naming its file (exit 2) and no sheet.
"""

from __future__ import annotations

import dataclasses
import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image, UnidentifiedImageError

from app.errors import InputError
from app.gl.context import GLContext
from app.render.renderer import Renderer
from app.scene.gltf_document import GltfError, open_gltf
from app.scene.loader import LoadedScene
from app.scene.look import Look
from app.scene.model_file import backdrop_radiance, fill_light
from app.scene.sources import scene_from
from app.untrusted import RefusedError, files
from app.walkthrough.labels import caption_band, find_font, font_size

__all__ = ["GalleryModel", "contact_sheet", "find_models", "render_gallery"]

MODEL_SUFFIXES = (".gltf", ".glb")
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".gif")
# Where a sample model's folder keeps its file, first found wins (the Khronos layout).
MODEL_FOLDERS = ("glTF", "glTF-Binary", ".")
REFERENCE_NAMES = ("screenshot/screenshot", "screenshot")
REFERENCE_BYTES = 64 << 20  # a reference screenshot larger than this is refused
REFERENCE_PIXELS = 64 << 20
BACKDROP = (40, 40, 40)  # around a letterboxed reference, and where a model has none
GUTTER = 4  # pixels between cells
# The view of a model that the asked view does not see at all (a plane edge-on).
FALLBACK_VIEW = "three-quarter"
# The reference viewer's look (docs/gltf.md, "Conformance gallery"): the glTF Sample
# Viewer renders at a fixed exposure, with image-based light only (its default key and
# fill lights come on only with the environment's light off) and the Khronos PBR Neutral
# tone map. The gallery does the same with the studio: this fixed exposure (EV), not the
# default look's metering, and no key or fill light.
REFERENCE_EXPOSURE = 0.0
REFERENCE_TONEMAP = "neutral"


def reference_look(loaded: LoadedScene, look: Look) -> LoadedScene:
    """A model file's default scene (``scene_from``) in the reference viewer's look: its
    own lights only (the default key and fill lights dropped), ``REFERENCE_EXPOSURE`` and
    ``REFERENCE_TONEMAP``, and the studio's backdrop kept at its light grey."""
    scene = loaded.scene
    lights = list(scene.lights)
    fill = fill_light(look.angles()[0])
    if (
        len(lights) >= 2
        and lights[-1].type == "directional"
        and np.allclose(lights[-1].direction, fill["direction"])
        and lights[-2].type == "spot"
    ):
        lights = lights[:-2]  # the default look's key and fill (the file has no lights)
    data = scene.model_dump(exclude_unset=True)
    data["lights"] = [light.model_dump(exclude_unset=True) for light in lights]
    data["camera"] = {**data.get("camera", {}), "exposure": REFERENCE_EXPOSURE}
    data["render"] = {**data.get("render", {}), "tonemap": REFERENCE_TONEMAP}
    if look.env == "studio" and "background" in data:
        data["background"] = [backdrop_radiance(REFERENCE_EXPOSURE, REFERENCE_TONEMAP)] * 3
    return loaded.with_scene(scene.model_validate(data))


@dataclass(frozen=True)
class GalleryModel:
    """One cell's inputs: its name, model file and reference image (None: no reference)."""

    name: str
    model: Path
    reference: Path | None


def _first(folder: Path, stems: tuple[str, ...], suffixes: tuple[str, ...]) -> Path | None:
    for stem in stems:
        for suffix in suffixes:
            path = folder / f"{stem}{suffix}"
            if path.is_file():
                return path
    return None


def _model_in(folder: Path) -> Path | None:
    """The model file of a sample model's folder: the first .gltf/.glb of ``MODEL_FOLDERS``
    (the one named after the folder where there are several)."""
    for sub in MODEL_FOLDERS:
        place = folder / sub
        if not place.is_dir():
            continue
        found = sorted(p for p in place.iterdir() if p.suffix.lower() in MODEL_SUFFIXES)
        named = [p for p in found if p.stem == folder.name]
        if named or found:
            return (named or found)[0]
    return None


def find_models(folder: Path) -> list[GalleryModel]:
    """The models of a gallery folder in name order (the layout in the module's docstring),
    or an ``InputError`` where the folder is missing or holds none."""
    if not folder.is_dir():
        raise InputError(str(folder), "", "no such folder")
    models = []
    for entry in sorted(folder.iterdir(), key=lambda p: p.name.lower()):
        if entry.is_dir():
            model = _model_in(entry)
            if model is not None:
                reference = _first(entry, REFERENCE_NAMES, IMAGE_SUFFIXES)
                models.append(GalleryModel(entry.name, model, reference))
        elif entry.suffix.lower() in MODEL_SUFFIXES:
            reference = _first(folder, (entry.stem,), IMAGE_SUFFIXES)
            models.append(GalleryModel(entry.stem, entry, reference))
    if not models:
        raise InputError(
            str(folder), "", "holds no .gltf/.glb model (NAME/glTF/NAME.gltf, NAME/NAME.glb...)"
        )
    return models


def read_reference(path: Path) -> np.ndarray:
    """A reference screenshot as (H, W, 3) uint8 sRGB (a GIF's first frame; alpha over the
    backdrop), or an ``InputError`` naming the file."""
    try:
        data = files.read_bytes(path, REFERENCE_BYTES)
        with Image.open(io.BytesIO(data)) as image:
            if image.width * image.height > REFERENCE_PIXELS:
                raise InputError(str(path), "", f"{image.width}x{image.height} is too large")
            image.seek(0)
            rgba = image.convert("RGBA")
    except RefusedError as exc:
        raise InputError(str(path), "", str(exc).removeprefix(f"{path}: ")) from None
    except (UnidentifiedImageError, OSError, ValueError) as exc:
        raise InputError(str(path), "", f"not a readable image ({exc})") from None
    backdrop = Image.new("RGBA", rgba.size, (*BACKDROP, 255))
    return np.asarray(Image.alpha_composite(backdrop, rgba).convert("RGB"))


def letterbox(image: np.ndarray, size: int) -> np.ndarray:
    """``image`` scaled to fit a ``size`` square (aspect kept, Lanczos), centred on the
    backdrop."""
    h, w = image.shape[:2]
    scale = size / max(h, w)
    fit = (max(1, round(w * scale)), max(1, round(h * scale)))
    scaled = Image.fromarray(image).resize(fit, Image.Resampling.LANCZOS)
    square = Image.new("RGB", (size, size), BACKDROP)
    square.paste(scaled, ((size - fit[0]) // 2, (size - fit[1]) // 2))
    return np.asarray(square)


def _animated(path: Path) -> bool:
    """Whether the glTF file at ``path`` has an animation to pose it by (a file that does not
    read is left to ``scene_from``, which names what is wrong with it)."""
    try:
        return bool(open_gltf(path).animations)
    except GltfError:
        return True


def posed_look(model: GalleryModel, look: Look) -> Look:
    """``look`` for ``model``: ``--animation``/``--time`` pose the models that have
    animations (CesiumMan's reference is a frame of its walk) and leave the rest at rest,
    where ``pbs render`` would refuse a time for a file without animations."""
    if (look.animation is None and look.time is None) or _animated(model.model):
        return look
    return dataclasses.replace(look, animation=None, time=None)


def render_model(
    gl: GLContext, model: GalleryModel, size: int, look: Look, **policy: object
) -> tuple[np.ndarray, bool]:
    """``pbs render MODEL --size SIZExSIZE``'s image of ``model`` (H, W, 3) uint8, and
    whether it covers any pixel (a flat model seen edge-on covers none)."""
    loaded = scene_from(model.model, look=look, size=(size, size), **policy)
    loaded = reference_look(loaded, look)
    renderer = Renderer(gl, loaded, (size, size))
    try:
        renderer.render()
        image = np.ascontiguousarray(renderer.read_ldr()[..., :3])
        return image, bool(renderer.read_gbuffer().covered.any())
    finally:
        renderer.release()


def contact_sheet(
    cells: list[tuple[str, np.ndarray, np.ndarray | None]], size: int, columns: int
) -> np.ndarray:
    """The sheet of ``cells`` (name, render, reference or None), ``columns`` cells a row:
    each cell the two ``size`` squares side by side and a band under them naming the
    model, "pbs" and "reference"."""
    face = find_font("en")
    text = max(font_size(size), size // 16)
    tiles = []
    for name, rendered, reference in cells:
        right = np.full((size, size, 3), BACKDROP, np.uint8)
        if reference is not None:
            right = letterbox(reference, size)
        pair = np.concatenate([rendered, np.full((size, GUTTER, 3), 0, np.uint8), right], axis=1)
        caption = f"{name}: pbs | {'reference' if reference is not None else 'no reference'}"
        tiles.append(caption_band(pair, caption, face, text, where="bottom"))
    height = max(t.shape[0] for t in tiles)
    width = tiles[0].shape[1]
    rows = math.ceil(len(tiles) / columns)
    sheet = np.zeros((rows * (height + GUTTER) - GUTTER, columns * (width + GUTTER) - GUTTER, 3))
    sheet = sheet.astype(np.uint8)
    for k, tile in enumerate(tiles):
        y, x = (k // columns) * (height + GUTTER), (k % columns) * (width + GUTTER)
        sheet[y : y + tile.shape[0], x : x + width] = tile
    return sheet


def render_gallery(
    gl: GLContext,
    models: list[GalleryModel],
    size: int = 256,
    columns: int = 3,
    look: Look | None = None,
    **policy: object,
) -> np.ndarray:
    """The contact sheet of ``models`` (``find_models``). References are read first (cheap),
    then each model rendered; any bad input is an ``InputError`` before the sheet exists.
    ``policy``: ``scene_from``'s ``allow_paths`` and ``max_memory``."""
    references = [read_reference(m.reference) if m.reference else None for m in models]
    cells = []
    look = look or Look()
    for model, reference in zip(models, references, strict=True):
        shown = posed_look(model, look)
        rendered, covered = render_model(gl, model, size, shown, **policy)
        name = model.name
        if not covered and look.azimuth is None and look.elevation is None:
            # a flat model the named view sees edge-on (TwoSidedPlane from the front)
            seen = dataclasses.replace(shown, view=FALLBACK_VIEW)
            rendered, _ = render_model(gl, model, size, seen, **policy)
            name = f"{name} ({FALLBACK_VIEW})"
        cells.append((name, rendered, reference))
    return contact_sheet(cells, size, min(columns, len(cells)))
