"""Labels on rendered images: which object is which model, material or value.

Fonts come from the system through ``fc-match``: DejaVu Sans for English, a Noto Sans
CJK face for Korean (Debian's ``fonts-noto-cjk``). A Hangul font is accepted only if its
'가' really is a glyph: a non-empty mask that differs from the font's missing-glyph box.
Each labelled object's silhouette is found by projecting its mesh's vertices through the
renderer's own view and projection matrices; the text goes on a dark translucent box
centred under it, or over or beside it, or farther out with a leader line back to it,
wherever it overlaps no other label and covers the least of the other objects
(``place_labels``). Every text is wrapped and sized from its own measure (``fit_text``),
so a label or caption is never cut at an edge.
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
HANGUL_FAMILY = "Noto Sans CJK KR"  # the family name matplotlib knows the face by
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


Box = tuple[float, float, float, float]  # left, top, right, bottom (right, bottom exclusive)
MIN_SIZE = 9  # the smallest label text, pixels
LEADER_RGBA = (255, 255, 255, 230)  # a leader line: white on a dark outline
LEADER_OUTLINE_RGBA = (0, 0, 0, 170)


def _intersection(a: Box, b: Box) -> float:
    """The area two boxes share (0 where they are apart or only touch)."""
    w = min(a[2], b[2]) - max(a[0], b[0])
    h = min(a[3], b[3]) - max(a[1], b[1])
    return w * h if w > 0 and h > 0 else 0.0


def _shape_box(shape: Silhouette) -> Box:
    return (shape.left, shape.top, shape.right, shape.bottom)


@dataclass(frozen=True)
class PlacedLabel:
    """A label's text lines, its box (pixels: left, top, right, bottom; right and bottom
    exclusive), its text size, and the leader line from the box to its object where the
    box had to move away from the object ((x0, y0), (x1, y1); None where it sits beside
    the object)."""

    lines: tuple[str, ...]
    box: tuple[int, int, int, int]
    size: int
    leader: tuple[tuple[float, float], tuple[float, float]] | None = None


UNITS = {"m", "nm", "mm", "EV", "%", "°"}  # kept on the line of the number before them


def _breaks_before(word: str) -> bool:
    """Whether a line may break before ``word``: before a word that starts with a letter
    (of any script) and is not a unit, so "sphere 6" and "14.0 m" stay whole."""
    return word[:1].isalpha() and word not in UNITS


def _wrapped(text: str, font: ImageFont.FreeTypeFont, width: float) -> tuple[str, ...]:
    """``text`` broken greedily between words into lines no wider than ``width`` where
    the words allow (a word wider than ``width`` is its own line); never before a number
    or a unit (``_breaks_before``)."""
    lines: list[str] = []
    for word in text.split():
        if lines and (not _breaks_before(word) or font.getlength(f"{lines[-1]} {word}") <= width):
            lines[-1] = f"{lines[-1]} {word}"
        else:
            lines.append(word)
    return tuple(lines) or (text,)


def _by_characters(text: str, font: ImageFont.FreeTypeFont, width: float) -> tuple[str, ...]:
    """The last resort: ``text`` broken between characters, each line within ``width``."""
    lines = [""]
    for ch in text:
        if lines[-1] and font.getlength(lines[-1] + ch) > width:
            lines.append(ch.lstrip())
        else:
            lines[-1] += ch
    return tuple(line for line in lines if line)


def fit_words(
    text: str, face: FontFace, size: int, width: float, max_lines: int = 3
) -> tuple[tuple[str, ...], int] | None:
    """Lines and font size at which ``text`` is no wider than ``width`` pixels, broken
    between words only: one line, else broken at ', ', else between words (at most
    ``max_lines``), each at ``size`` before a smaller size is tried (down to
    ``MIN_SIZE``); None where nothing fits."""
    for s in range(size, MIN_SIZE - 1, -1):
        font = face.at(s)
        candidates = [(text,)]
        if ", " in text:
            candidates.append(tuple(part.strip() for part in text.split(", ")))
        candidates.append(_wrapped(text, font, width))
        for lines in candidates:
            if len(lines) <= max_lines and max(font.getlength(line) for line in lines) <= width:
                return lines, s
    return None


def fit_text(
    text: str, face: FontFace, size: int, width: float, max_lines: int = 3
) -> tuple[tuple[str, ...], int]:
    """``fit_words``, and where nothing fits even at ``MIN_SIZE``, ``text`` broken between
    characters at that size. The text is sized and wrapped from its own measure, so no
    caption or label is ever cut at the edge of its box."""
    fitted = fit_words(text, face, size, width, max_lines)
    if fitted is not None:
        return fitted
    size = min(size, MIN_SIZE)
    font = face.at(size)
    lines = _wrapped(text, font, width)
    if max(font.getlength(line) for line in lines) > width:
        lines = _by_characters(text, font, width)
    return lines, size


def _metrics(size: int) -> tuple[int, int]:
    """A label's padding and line height at text ``size``."""
    return max(2, size // 4), round(size * 1.2)


def _box_size(lines: tuple[str, ...], face: FontFace, size: int) -> tuple[int, int]:
    pad, line_h = _metrics(size)
    font = face.at(size)
    width = round(max(font.getlength(line) for line in lines))
    return width + 2 * pad, line_h * len(lines) + 2 * pad


def _candidates(
    shape: Silhouette, box_w: int, box_h: int, gap: int, levels: int = 4, shifts: int = 4
) -> list[tuple[float, float, bool]]:
    """Where a label may go, in order of preference: (left, top, moved). First at its
    object (the first five: centred under it, over it, right, left of it, on its lower
    part), then off-centre and farther out above and below (``moved``: it needs a
    leader line back to the object), last centred on the object itself."""
    cx = shape.centre_x
    cy = 0.5 * (shape.top + shape.bottom)
    below = shape.bottom + gap
    above = shape.top - gap - box_h
    out: list[tuple[float, float, bool]] = [
        (cx - 0.5 * box_w, below, False),
        (cx - 0.5 * box_w, above, False),
        (shape.right + gap, cy - 0.5 * box_h, False),
        (shape.left - gap - box_w, cy - 0.5 * box_h, False),
        (cx - 0.5 * box_w, shape.bottom - gap - box_h, False),  # on its lower part
    ]
    step_x = 0.5 * box_w + gap
    step_y = box_h + gap
    for level in range(levels):
        for k in range(shifts + 1):
            for sign in (1, -1) if k else (1,):
                if level == 0 and k == 0:
                    continue
                dx = sign * k * step_x
                out.append((cx - 0.5 * box_w + dx, below + level * step_y, True))
                out.append((cx - 0.5 * box_w + dx, above - level * step_y, True))
    out.append((cx - 0.5 * box_w, cy - 0.5 * box_h, False))
    return out


def _coverage(box: Box, shapes: np.ndarray, margin: float = 0.0) -> float:
    """The share of ``box`` that covers the objects ``shapes`` ((N, 4): left, top, right,
    bottom), each taken as the ellipse inscribed in its box (a sphere's outline; a box's
    empty corners are free) grown by ``margin`` pixels, from 16 x 4 points spread over
    the box and its edges."""
    if not len(shapes):
        return 0.0
    xs = np.linspace(box[0], box[2], 16)
    ys = np.linspace(box[1], box[3], 4)
    px, py = (a.ravel()[:, None] for a in np.meshgrid(xs, ys))
    cx, cy = 0.5 * (shapes[:, 0] + shapes[:, 2]), 0.5 * (shapes[:, 1] + shapes[:, 3])
    rx = np.maximum(0.5 * (shapes[:, 2] - shapes[:, 0]), 0.5) + margin
    ry = np.maximum(0.5 * (shapes[:, 3] - shapes[:, 1]), 0.5) + margin
    inside = ((px - cx) / rx) ** 2 + ((py - cy) / ry) ** 2 <= 1.0
    return float(inside.any(axis=1).mean())


def _leader(box: Box, shape: Silhouette) -> tuple[tuple[float, float], tuple[float, float]]:
    """A leader line from the box's edge to the object: towards the silhouette's centre,
    ending on the ellipse inscribed in its bounding box (a sphere's outline)."""
    cx, cy = shape.centre_x, 0.5 * (shape.top + shape.bottom)
    bx = min(max(cx, box[0]), box[2] - 1)
    by = min(max(cy, box[1]), box[3] - 1)
    if box[0] <= cx < box[2]:  # straight above or below: from the middle of the edge
        bx = 0.5 * (box[0] + box[2])
    dx, dy = bx - cx, by - cy
    rx = max(0.5 * (shape.right - shape.left), 1.0)
    ry = max(0.5 * (shape.bottom - shape.top), 1.0)
    scale = 1.0 / max(np.hypot(dx / rx, dy / ry), 1e-9)
    return (bx, by), (cx + dx * min(scale, 1.0), cy + dy * min(scale, 1.0))


def _crosses(
    segment: tuple[tuple[float, float], tuple[float, float]], box: tuple[int, int, int, int]
) -> bool:
    """Whether a leader line passes through ``box`` (sampled every pixel or so)."""
    (x0, y0), (x1, y1) = segment
    n = max(2, int(np.hypot(x1 - x0, y1 - y0)))
    t = np.linspace(0.0, 1.0, n)
    x, y = x0 + t * (x1 - x0), y0 + t * (y1 - y0)
    return bool(((x >= box[0]) & (x < box[2]) & (y >= box[1]) & (y < box[3])).any())


# An object whose box covers this share of the image or more is no obstacle: labels go
# over it (``_background``).
OBSTACLE_SHARE = 0.5


def _background(shape: Silhouette, w: int, h: int) -> bool:
    """Whether an object is scenery rather than a thing to label around: its box is as
    wide or as tall as the image, or covers ``OBSTACLE_SHARE`` of it (a floor, a
    backdrop; a floor's box is often a thin band along the horizon, its near corners
    behind the camera)."""
    width, height = shape.right - shape.left, shape.bottom - shape.top
    inside = _intersection(_shape_box(shape), (0.0, 0.0, float(w), float(h)))
    return width >= w or height >= h or inside >= OBSTACLE_SHARE * w * h


# A position at its object that covers at most BESIDE_COVER of the label with other
# objects is taken at a smaller size (down to BESIDE_SHRINK of the label's size)
# before the label is moved away from its object on a leader line.
BESIDE_SHRINK = 0.75
BESIDE_COVER = 0.1
# The passes at the object, in turn: (how many of the candidates, the most of the label
# that may cover other objects): beside it covering nothing, then on its own lower part
# too, then covering a little.
BESIDE_TIERS = ((4, 0.0), (5, 0.0), (5, BESIDE_COVER))


def place_labels(
    texts: list[tuple[int, str]],
    shapes: dict[int, Silhouette],
    image_size: tuple[int, int],
    face: FontFace,
    size: int,
    rooms: dict[int, float] | None = None,
) -> tuple[list[PlacedLabel], list[int]]:
    """Every label of ``texts`` (object index, text) placed so that no two overlap.

    Each label in turn (the order of ``texts``) takes a position from ``_candidates``
    inside the image that no label placed before it overlaps, grown by a pixel. Among
    those, the cost of a position is the share of the label that covers other objects
    (``_coverage``; not the scenery, ``_background``: a floor, a backdrop), a third of
    that for its own object, a little for each step down the list of preference, and
    one for each placed label its leader line would cross. First the cheapest position
    at its object (``BESIDE_TIERS``: beside it, then on it, covering no other object,
    then covering at most ``BESIDE_COVER`` of the label with others), its text no wider
    than its ``rooms`` entry (the space its neighbours leave); else the cheapest
    position of all, at that size or smaller ones down to ``MIN_SIZE``, its text as
    wide as the image allows; a label moved away from its object gets a leader line.
    The whole image is labelled at ``size``, and, unless every label then sits beside
    its object, again at each smaller size down to ``BESIDE_SHRINK`` of it; the attempt
    with the most labels beside their objects (one on its object counts a half) wins,
    the larger size on a tie, so one image's labels share a size. A label with no free
    position even at ``MIN_SIZE`` is left out (the attempt that leaves out fewest wins
    first). Returns the placed labels and the indices of the objects left without one.
    Deterministic: the order of ``texts`` and the geometry decide everything."""
    w, h = image_size
    placed: list[PlacedLabel] = []  # the labels of the attempt under way

    # Obstacles: every object in view but the large ones (a floor, a backdrop).
    small = {i for i, sh in shapes.items() if not _background(sh, w, h)}

    def best_at(
        index: int, text: str, s: int, first: int = 0, cover: float = 0.0
    ) -> tuple[PlacedLabel | None, float]:
        """The cheapest free position at size ``s``: among the ``first`` candidates
        covering at most ``cover`` of the label with other objects, or (0) among all."""
        beside = first > 0
        shape = shapes[index]
        # Beside its object a label keeps to its room; moved away, to the image.
        room = (rooms or {}).get(index, float(w)) if beside else float(w)
        width = max(min(room, w), 4 * s)
        fitted = fit_words(text, face, s, width) if beside else fit_text(text, face, s, width)
        if fitted is None:
            return None, float("inf")
        lines, s_fit = fitted
        box_w, box_h = _box_size(lines, face, s_fit)
        if box_w > w or box_h > h:
            return None, float("inf")
        others = np.array([_shape_box(shapes[i]) for i in small if i != index]).reshape(-1, 4)
        own = np.array([_shape_box(shape)])
        gap = max(2, s_fit // 3)
        candidates = _candidates(shape, box_w, box_h, gap)
        best, best_cost = None, float("inf")
        for rank, (left, top, moved) in enumerate(candidates[:first] if beside else candidates):
            if left < 0 or top < 0 or left + box_w > w or top + box_h > h:
                continue
            box = (round(left), round(top), round(left) + box_w, round(top) + box_h)
            grown = (box[0] - 1, box[1] - 1, box[2] + 1, box[3] + 1)
            if any(_intersection(grown, p.box) > 0 for p in placed):
                continue
            covered = _coverage(box, others, gap)
            if beside and covered > cover:
                continue
            cost = covered + _coverage(box, own) / 3.0 + 0.01 * rank
            leader = _leader(box, shape) if moved else None
            if leader is not None:
                cost += sum(_crosses(leader, p.box) for p in placed)
            if cost < best_cost:
                best, best_cost = PlacedLabel(lines, box, s_fit, leader), cost
        return best, best_cost

    def attempt(top: int) -> tuple[list[PlacedLabel], list[int], float]:
        """Every label placed with text of at most ``top`` pixels, and the score: one
        for each label beside its object, a half for one on it."""
        placed.clear()
        missing: list[int] = []
        score = 0.0
        for index, text in texts:
            best = None
            for tier, (first, cover) in enumerate(BESIDE_TIERS):
                best, _ = best_at(index, text, top, first, cover)
                if best is not None:
                    score += 1.0 if tier == 0 else 0.5
                    break
            for s in range(top, MIN_SIZE - 1, -1):
                if best is not None:
                    break
                best, _ = best_at(index, text, s)
            if best is None:
                missing.append(index)
            else:
                placed.append(best)
        return list(placed), missing, score

    chosen = attempt(size)
    for top in range(size - 1, max(MIN_SIZE, round(size * BESIDE_SHRINK)) - 1, -1):
        if chosen[2] >= len(texts):
            break
        tried = attempt(top)
        if (-len(tried[1]), tried[2]) > (-len(chosen[1]), chosen[2]):
            chosen = tried
    return chosen[0], chosen[1]


def draw_labels(image: np.ndarray, labels: list[PlacedLabel], face: FontFace) -> np.ndarray:
    """``image`` (H, W, 3) uint8 with each label's leader line, translucent box and white
    text."""
    base = Image.fromarray(image, "RGB").convert("RGBA")
    overlay = Image.new("RGBA", base.size, (0, 0, 0, 0))
    draw = ImageDraw.Draw(overlay)
    for label in labels:  # box = (left, top, right, bottom), right and bottom exclusive
        left, top, right, bottom = label.box
        draw.rectangle((left, top, right - 1, bottom - 1), fill=BOX_RGBA)
        if label.leader is not None:
            draw.line(label.leader, fill=LEADER_OUTLINE_RGBA, width=3)
    base = Image.alpha_composite(base, overlay)
    draw = ImageDraw.Draw(base)
    for label in labels:
        if label.leader is not None:
            draw.line(label.leader, fill=LEADER_RGBA, width=1)
        font = face.at(label.size)
        pad, line_h = _metrics(label.size)
        left, top, right, _ = label.box
        for k, line in enumerate(label.lines):
            x = 0.5 * (left + right)
            y = top + pad + k * line_h + 0.5 * line_h
            draw.text((x, y), line, font=font, fill=TEXT_RGB, anchor="mm")
    return np.asarray(base.convert("RGB"))


def label_objects(
    image: np.ndarray, renderer: Renderer, texts: dict[int, str], face: FontFace
) -> tuple[np.ndarray, list[PlacedLabel], list[int]]:
    """``image`` with ``texts`` (object index -> text) drawn at their objects without
    overlapping (``place_labels``), the labels, and the objects whose label found no
    free place. An object that is not in view gets no label (and is not counted)."""
    h, w = image.shape[:2]
    shapes = silhouettes(renderer)
    visible = {
        i: s
        for i, s in shapes.items()
        if not (s.right < 0 or s.left > w or s.bottom < 0 or s.top > h)
    }
    wanted = [(i, text) for i, text in texts.items() if i in visible]
    # The widest a label may be at first: up to the nearest other labelled object's
    # centre in x (0.95 of it), at least its own object's width; narrower rows of text
    # keep a dense row's labels under their own objects.
    centres = sorted(visible[i].centre_x for i, _ in wanted)
    rooms = {}
    for i, _ in wanted:
        shape = visible[i]
        gaps = [abs(c - shape.centre_x) for c in centres if abs(c - shape.centre_x) > 1.0]
        room = min(gaps) * 0.95 if gaps else float(w)
        rooms[i] = max(room, shape.right - shape.left)
    placed, left_out = place_labels(wanted, visible, (w, h), face, font_size(h), rooms)
    return draw_labels(image, placed, face), placed, left_out


BAND_RGB = (24, 24, 24)  # the band under a sweep's frame


def caption_band(
    image: np.ndarray,
    text: str,
    face: FontFace,
    size: int,
    where: str = "top",
    rows: int = 1,
) -> np.ndarray:
    """A label boxed at the top-left corner of ``image`` (a comparison's side), or centred
    in a dark band added under it (a sweep's value). The text is fitted to the image's
    width (``fit_text``: broken into lines, smaller where it must), never cut; the band
    is as tall as its lines, at least ``rows`` of them (so that a strip's bands match)."""
    w = image.shape[1]
    pad, line_h = _metrics(size)
    if where == "top":
        lines, size = fit_text(text, face, size, w - 4 * pad)
        box_w, box_h = _box_size(lines, face, size)
        label = PlacedLabel(lines, (pad, pad, pad + box_w, pad + box_h), size)
        return draw_labels(image, [label], face)
    lines, size = fit_text(text, face, size, w - 2 * pad)
    pad, line_h = _metrics(size)
    band_h = line_h * max(rows, len(lines)) + 2 * pad
    band = Image.new("RGB", (w, band_h), BAND_RGB)
    draw = ImageDraw.Draw(band)
    font = face.at(size)
    first = 0.5 * band_h - 0.5 * line_h * (len(lines) - 1)
    for k, line in enumerate(lines):
        draw.text((w / 2, first + k * line_h), line, font=font, fill=TEXT_RGB, anchor="mm")
    return np.concatenate([image, np.asarray(band)], axis=0)


def band_layout(texts: list[str], face: FontFace, size: int, width: int) -> tuple[int, int]:
    """One text size and row count for the bands of a strip of frames ``width`` wide, so
    that every band of the strip has the same size and height: the smallest size any of
    ``texts`` needs to fit, and the most lines any takes at it."""
    pad, _ = _metrics(size)
    fitted = min(fit_text(t, face, size, width - 2 * pad)[1] for t in texts)
    pad, _ = _metrics(fitted)
    rows = max(len(fit_text(t, face, fitted, width - 2 * pad)[0]) for t in texts)
    return fitted, rows
