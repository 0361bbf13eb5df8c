"""Labels on rendered images: which object is which model, material or value.

Fonts come from the system through ``fc-match``: DejaVu Sans for English, a Noto Sans
CJK face for Korean (Debian's ``fonts-noto-cjk``). A Hangul font is accepted only if its
'가' really is a glyph: a non-empty mask that differs from the font's missing-glyph box.
Each labelled object's silhouette is found by projecting its mesh's vertices through the
renderer's own view and projection matrices; the text is centred under it (above it
where below would leave the image) on a dark translucent box.
"""

from __future__ import annotations

import shutil
import subprocess
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from app.errors import InputError
from app.render.renderer import Renderer

HANGUL_PACKAGE = "fonts-noto-cjk"
_LATIN_PATTERN = "DejaVu Sans"
_HANGUL_PATTERN = "Noto Sans CJK KR:lang=ko"
_MISSING = "\U0010fffd"  # a private-use code point no font draws: its .notdef box
BOX_RGBA = (0, 0, 0, 170)  # the label's backing box: black at 2/3 opacity
TEXT_RGB = (255, 255, 255)


@dataclass(frozen=True)
class FontFace:
    """A font file and the face's index in it (a .ttc holds several)."""

    path: Path
    index: int = 0

    def at(self, size: int) -> ImageFont.FreeTypeFont:
        return _truetype(str(self.path), self.index, size)


@cache
def _truetype(path: str, index: int, size: int) -> ImageFont.FreeTypeFont:
    return ImageFont.truetype(path, size, index=index)


def _fc_match(pattern: str) -> FontFace | None:
    if shutil.which("fc-match") is None:
        return None
    try:
        out = subprocess.run(
            ["fc-match", "-f", "%{file}\n%{index}", pattern],
            capture_output=True, text=True, timeout=20, check=True,
        ).stdout.splitlines()  # fmt: skip
    except (OSError, subprocess.SubprocessError):
        return None
    if not out or not Path(out[0]).is_file():
        return None
    index = int(out[1]) if len(out) > 1 and out[1].strip().isdigit() else 0
    return FontFace(Path(out[0]), index)


def has_hangul(face: FontFace) -> bool:
    """Whether ``face`` draws '가' as a real glyph: ink, and not its missing-glyph box."""
    try:
        font = face.at(32)
    except OSError:
        return False
    mask = font.getmask("가")
    if mask.getbbox() is None:
        return False
    missing = font.getmask(_MISSING)
    return mask.size != missing.size or bytes(mask) != bytes(missing)


@cache
def find_font(lang: str) -> FontFace:
    """The font for ``lang``'s labels; for Korean one with Hangul glyphs, or an
    ``InputError`` naming the package to install (exit 2)."""
    if lang == "ko":
        face = _fc_match(_HANGUL_PATTERN)
        if face is None or not has_hangul(face):
            raise InputError(
                "--lang ko",
                "",
                f"no font with Hangul glyphs on this system (fc-match '{_HANGUL_PATTERN}'"
                f"{f' gave {face.path}' if face else ' found none'}): install the Debian "
                f"package {HANGUL_PACKAGE}",
            )
        return face
    face = _fc_match(_LATIN_PATTERN)
    if face is None:
        raise InputError(
            "--lang en", "", "no font found with fc-match: install fontconfig and fonts-dejavu-core"
        )
    return face


@dataclass(frozen=True)
class Silhouette:
    """An object's extent in the image, pixels (x right, y down)."""

    left: float
    top: float
    right: float
    bottom: float

    @property
    def centre_x(self) -> float:
        return 0.5 * (self.left + self.right)


def silhouettes(renderer: Renderer) -> dict[int, Silhouette]:
    """Each scene object's screen-space bounding box (object index -> box), from its mesh
    projected with the renderer's view and projection; objects behind the camera are
    left out."""
    w, h = renderer.size
    view_proj = renderer.proj @ renderer.view
    boxes: dict[int, list[np.ndarray]] = {}
    for part in renderer.frame.parts:
        positions = part.surface_points()
        world = part.model @ np.c_[positions, np.ones(len(positions))].T
        clip = view_proj @ world
        front = clip[3] > 1e-9
        if not front.any():
            continue
        ndc = clip[:2, front] / clip[3, front]
        x = (ndc[0] + 1.0) * 0.5 * w
        y = (1.0 - ndc[1]) * 0.5 * h
        boxes.setdefault(part.object_index, []).append(
            np.array([x.min(), y.min(), x.max(), y.max()])
        )
    out = {}
    for index, found in boxes.items():
        b = np.array(found)
        out[index] = Silhouette(b[:, 0].min(), b[:, 1].min(), b[:, 2].max(), b[:, 3].max())
    return out


def font_size(height: int, strip_width: int | None = None) -> int:
    """Label text height for an image ``height`` pixels tall (at least 10 px). An image
    that is one panel of a strip ``strip_width`` wide (a comparison, a sweep), which the
    handout shrinks to the page's width, gets text 1/64 of the strip's width, so it
    reads at the size of a view's labels, within a quarter of the panel's height."""
    size = round(height / 24)
    if strip_width is not None:
        size = min(max(size, round(strip_width / 64)), height // 4)
    return max(10, size)


def _overlap(box: tuple[float, float, float, float], shape: Silhouette) -> bool:
    left, top, right, bottom = box
    return left < shape.right and shape.left < right and top < shape.bottom and shape.top < bottom


@dataclass(frozen=True)
class PlacedLabel:
    """A label's text lines and its box, pixels (left, top, right, bottom)."""

    lines: tuple[str, ...]
    box: tuple[int, int, int, int]
    size: int


def _layout(text: str, face: FontFace, size: int, width: float) -> tuple[tuple[str, ...], int]:
    """Lines and font size that fit ``width``: one line, else broken at ', ', else
    smaller (down to 9 px)."""
    candidates = [(text,)]
    if ", " in text:
        candidates.append(tuple(part.strip() for part in text.split(", ")))
    for s in range(size, 8, -1):
        font = face.at(s)
        for lines in candidates:
            if max(font.getlength(line) for line in lines) <= width:
                return lines, s
    return candidates[-1], 9


def place(
    text: str,
    silhouette: Silhouette,
    image_size: tuple[int, int],
    face: FontFace,
    size: int,
    room: float,
    others: tuple[Silhouette, ...] = (),
) -> PlacedLabel:
    """Where ``text`` goes for an object: centred under its silhouette, above it where
    below leaves the image or covers one of ``others`` (the other objects in view),
    inside it where neither fits; kept within the image. ``room``: the widest the text
    may be (the gap to the neighbouring objects)."""
    w, h = image_size
    lines, size = _layout(text, face, size, max(room, 4 * size))
    font = face.at(size)
    pad = max(2, size // 4)
    line_h = round(size * 1.2)
    box_w = round(max(font.getlength(line) for line in lines)) + 2 * pad
    box_h = line_h * len(lines) + 2 * pad
    gap = max(2, size // 3)
    top = silhouette.bottom + gap
    below = (silhouette.centre_x - 0.5 * box_w, top, silhouette.centre_x + 0.5 * box_w, top + box_h)
    if top + box_h > h or any(_overlap(below, o) for o in others):
        top = silhouette.top - gap - box_h
        if top < 0:
            top = 0.5 * (silhouette.top + silhouette.bottom) - 0.5 * box_h
    left = silhouette.centre_x - 0.5 * box_w
    left = min(max(left, 0.0), max(w - box_w, 0.0))
    top = min(max(top, 0.0), max(h - box_h, 0.0))
    box = (round(left), round(top), round(left) + box_w, round(top) + box_h)
    return PlacedLabel(lines, box, size)


def draw_labels(image: np.ndarray, labels: list[PlacedLabel], face: FontFace) -> np.ndarray:
    """``image`` (H, W, 3) uint8 with each label's translucent box and white text."""
    base = Image.fromarray(image, "RGB").convert("RGBA")
    overlay = Image.new("RGBA", base.size, (0, 0, 0, 0))
    draw = ImageDraw.Draw(overlay)
    for label in labels:  # box = (left, top, right, bottom), right and bottom exclusive
        left, top, right, bottom = label.box
        draw.rectangle((left, top, right - 1, bottom - 1), fill=BOX_RGBA)
    base = Image.alpha_composite(base, overlay)
    draw = ImageDraw.Draw(base)
    for label in labels:
        font = face.at(label.size)
        pad = max(2, label.size // 4)
        line_h = round(label.size * 1.2)
        left, top, right, _ = label.box
        for k, line in enumerate(label.lines):
            x = 0.5 * (left + right)
            y = top + pad + k * line_h + 0.5 * line_h
            draw.text((x, y), line, font=font, fill=TEXT_RGB, anchor="mm")
    return np.asarray(base.convert("RGB"))


def label_objects(
    image: np.ndarray, renderer: Renderer, texts: dict[int, str], face: FontFace
) -> tuple[np.ndarray, list[PlacedLabel]]:
    """``image`` with ``texts`` (object index -> text) drawn at their objects, and where.
    An object that is not in view gets no label."""
    h, w = image.shape[:2]
    shapes = silhouettes(renderer)
    # Labels collide only with labels: the room of each is set by the labelled objects.
    centres = sorted(shapes[i].centre_x for i in texts if i in shapes)
    placed = []
    for index, text in texts.items():
        shape = shapes.get(index)
        if shape is None or shape.right < 0 or shape.left > w or shape.bottom < 0 or shape.top > h:
            continue
        # Room: up to the nearest other labelled object's centre in x (0.95 of it).
        gaps = [abs(c - shape.centre_x) for c in centres if abs(c - shape.centre_x) > 1.0]
        room = min(gaps) * 0.95 if gaps else float(w)
        room = max(room, shape.right - shape.left)
        others = tuple(s for i, s in shapes.items() if i != index)
        placed.append(place(text, shape, (w, h), face, font_size(h), room, others))
    return draw_labels(image, placed, face), placed


def caption_band(
    image: np.ndarray, text: str, face: FontFace, size: int, where: str = "top"
) -> np.ndarray:
    """A one-line label boxed at the top-left corner of ``image`` (a comparison's side), or
    centred in a dark band added under it (a sweep's value)."""
    w = image.shape[1]
    font = face.at(size)
    pad = max(2, size // 4)
    if where == "top":
        box_w = round(font.getlength(text)) + 2 * pad
        box = (pad, pad, pad + box_w, pad + round(size * 1.2) + 2 * pad)
        label = PlacedLabel((text,), box, size)
        return draw_labels(image, [label], face)
    band_h = round(size * 1.2) + 2 * pad
    band = Image.new("RGB", (w, band_h), (24, 24, 24))
    ImageDraw.Draw(band).text((w / 2, band_h / 2), text, font=font, fill=TEXT_RGB, anchor="mm")
    return np.concatenate([image, np.asarray(band)], axis=0)
