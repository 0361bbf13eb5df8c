"""Writes tests/assets/anisotropy_rotation/: a stand-in for Khronos' AnisotropyRotationTest
(glTF-Sample-Assets), whose .bin and textures cannot be had on this machine, with the same
cases on spheres of our own (tests/test_anisotropy_rotation.py renders it; docs/gltf.md).

Ten UV spheres in two columns of five, in the original's places (left column from the
bottom: plain, "Tangents + Rotation", plain, "Tangents + Texture", plain; right column:
plain, "Tangents + Texture + Rotation", plain, "Normal map of grooves", plain), each with
its own TANGENT attribute. Every anisotropic material is a white-ish metal with its
roughness stretched along TANGENT (KHR_materials_anisotropy, strength ``STRENGTH``):

- plain: TANGENT = dP/du, horizontal (east) everywhere; the highlight is a horizontal
  streak.
- "Tangents + Rotation": TANGENT turned 30 degrees clockwise about the normal (seen from
  outside: towards -b, b = n x t), undone by ``anisotropyRotation`` = +30 degrees.
- "Tangents + Texture": the same tilt, undone by an ``anisotropyTexture`` whose RG holds
  (cos 30, sin 30) (linear, 2 rg - 1) and B the full strength.
- "Tangents + Texture + Rotation": the same tilt, 10 degrees from the texture and 20
  from ``anisotropyRotation``.
- "Normal map of grooves": no anisotropy; an isotropic metal whose normal map has
  ``GROOVES`` grooves around the sphere (constant along v, so the grooves run pole to pole:
  vertical), each a scallop whose slope across it is uniform within +-``GROOVE_DEGREES``.
  Seen from afar it should spread a light horizontally as its anisotropic neighbours do.

The roughness is larger than the original's 0.1 so that a sphere some 40 pixels across
resolves the lobe's narrow width (alpha_b = 0.01 would be a fraction of a pixel there).
Output is deterministic (the test regenerates it and compares it with the committed files).

``view_scene`` is the view the tests measure: straight ahead from 1 km away, one
directional light, no environment. ``--figure PNG`` renders docs/gltf.md's figure of the
stand-in: as ``pbs render MODEL --view front`` shows it (the studio environment, a key and
a fill light; its normal filtering the default ``auto``, which picks ``lean`` for the
grooves), then in ``view_scene``'s light with ``variance`` normal filtering (what the
default was), with ``lean``, and the reference from the maps' level 0 (8 x 8 samples).
``--grooves`` prints docs/filtering.md's table of the grooved sphere's highlight
(``highlight_shape``) by normal filter.
Usage: python scripts/anisotropy_rotation_standin.py [OUT_FOLDER]
       python scripts/anisotropy_rotation_standin.py --figure PNG
       python scripts/anisotropy_rotation_standin.py --grooves
"""

from __future__ import annotations

import io
import json
import math
import sys
from pathlib import Path

import numpy as np
from PIL import Image

NAME = "AnisotropyRotationStandIn"
OUT = Path(__file__).resolve().parent.parent / "tests" / "assets" / "anisotropy_rotation"
RADIUS = 0.4  # metres
COLUMN_X = 0.625  # the columns' centres at -+COLUMN_X
ROW_Y = 1.0  # the rows' spacing, row 0 at the bottom (y = -2)
SEGMENTS = (48, 24)  # around (u), pole to pole (v)
TILT_DEGREES = 30.0  # the TANGENT attribute's clockwise tilt on the three turned meshes
ROUGHNESS = 0.3
STRENGTH = 0.6
GROOVE_ROUGHNESS = 0.15
GROOVES = 128  # around the sphere
GROOVE_TEXELS = 8  # texels across one groove
GROOVE_DEGREES = 30.0  # the steepest slope across a groove
BASE_COLOR = [0.9, 0.9, 0.9, 1.0]
VIEW_SIZE = (128, 256)  # the whole stand-in in view_scene
VIEW_SCALE = 48.0  # view_scene's pixels per metre on the file's z = 0 plane
VIEW_DISTANCE = 1000.0  # metres
FLOAT, USHORT = 5126, 5123

# (node name, column -1 left / +1 right, row 0..4 from the bottom, mesh name)
NODES = [
    ("Plain 1L", -1, 0, "plain"),
    ("Tangents + Rotation", -1, 1, "rotation"),
    ("Plain 3L", -1, 2, "plain"),
    ("Tangents + Texture", -1, 3, "texture"),
    ("Plain 5L", -1, 4, "plain"),
    ("Plain 1R", 1, 0, "plain"),
    ("Tangents + Texture + Rotation", 1, 1, "texture_rotation"),
    ("Plain 3R", 1, 2, "plain"),
    ("Normal map of grooves", 1, 3, "grooves"),
    ("Plain 5R", 1, 4, "plain"),
]


def node_centre(column: int, row: int) -> tuple[float, float]:
    """A sphere's centre in the file's XY plane (z = 0), metres."""
    return column * COLUMN_X, (row - 2) * ROW_Y


def view_scene(
    size: tuple[int, int] = VIEW_SIZE, centre: tuple[float, float] = (0.0, 0.0), **render: object
) -> dict:
    """A scene (a scene file's keys, relative to OUT) that shows the stand-in from +z,
    ``centre`` (x, y) in the middle of a ``size`` image at ``VIEW_SCALE`` pixels a metre:
    from ``VIEW_DISTANCE`` away, so every sphere is seen (and lit) from within 0.1 degrees
    of the same direction and the spheres' centres fall on whole pixels. One directional
    light from the upper right, behind the camera; no environment, so the metals show
    their highlights alone. ``render`` adds render settings."""
    fov = math.degrees(2.0 * math.atan(size[1] / 2.0 / (VIEW_SCALE * VIEW_DISTANCE)))
    return {
        "camera": {"position": [*centre, VIEW_DISTANCE], "target": [*centre, 0.0],
                   "fov_y": fov, "near": VIEW_DISTANCE - 10, "far": VIEW_DISTANCE + 10},
        "lights": [{"type": "directional", "direction": [-0.25, -0.2, -1.0], "intensity": 3.0}],
        "objects": [{"shape": "mesh", "file": f"{NAME}.gltf"}],
        "render": {"width": size[0], "height": size[1], **render},
    }  # fmt: skip


def highlight_shape(tile: np.ndarray) -> tuple[float, float]:
    """The highlight's principal direction (degrees counter-clockwise from the image's +x,
    in (-90, 90]) and elongation (the square root of the ratio of the luminance-weighted
    second moments' eigenvalues: 1 for a round highlight)."""
    lum = tile @ np.array([0.2126, 0.7152, 0.0722])
    h, w = lum.shape
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    y = -y  # image rows run down, angles count up
    p = lum / lum.sum()
    dx, dy = x - (p * x).sum(), y - (p * y).sum()
    cov = np.array([[(p * dx * dx).sum(), (p * dx * dy).sum()],
                    [(p * dx * dy).sum(), (p * dy * dy).sum()]])  # fmt: skip
    angle = 0.5 * math.degrees(math.atan2(2.0 * cov[0, 1], cov[0, 0] - cov[1, 1]))
    low, high = np.linalg.eigvalsh(cov)
    return angle, math.sqrt(high / low)


def sphere(tilt_degrees: float) -> dict[str, np.ndarray]:
    """A UV sphere of ``RADIUS`` about the origin, poles on y, u = 0.5 facing +z: float32
    POSITION, NORMAL, TANGENT (dP/du turned ``tilt_degrees`` clockwise about the normal,
    w = +1: the bitangent n x t points north, towards decreasing glTF v), TEXCOORD_0
    (glTF's v down from the north pole) and uint16 triangle indices (counter-clockwise
    seen from outside)."""
    nu, nv = SEGMENTS
    u = np.linspace(0.0, 1.0, nu + 1)
    v = np.linspace(0.0, 1.0, nv + 1)
    uu, vv = np.meshgrid(u, v)  # (nv + 1, nu + 1)
    phi = (uu - 0.5) * 2.0 * math.pi  # 0 faces +z, increasing towards +x
    theta = vv * math.pi  # 0 at the north pole (+y)
    n = np.stack([np.sin(theta) * np.sin(phi), np.cos(theta), np.sin(theta) * np.cos(phi)], -1)
    t = np.stack([np.cos(phi), np.zeros_like(phi), -np.sin(phi)], -1)  # d/dphi, unit
    b = np.cross(n, t)  # north
    a = math.radians(-tilt_degrees)  # clockwise: from t away from b
    t = math.cos(a) * t + math.sin(a) * b
    # the poles' normal is exact (0, +-1, 0); their tangent stays the unit d/dphi turned
    grid = (nv + 1, nu + 1)
    i = np.arange(np.prod(grid)).reshape(grid)
    quads = np.stack([i[:-1, :-1], i[1:, :-1], i[1:, 1:], i[:-1, 1:]], -1).reshape(-1, 4)
    faces = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    # drop the pole rows' degenerate triangles (two corners on the pole)
    p = n.reshape(-1, 3)
    edges = p[faces[:, 1:]] - p[faces[:, :1]]
    area = np.linalg.norm(np.cross(edges[:, 0], edges[:, 1]), axis=1)
    faces = faces[area > 1e-9]
    return {
        "POSITION": (RADIUS * p).astype(np.float32),
        "NORMAL": p.astype(np.float32),
        "TANGENT": np.hstack([t.reshape(-1, 3), np.ones((p.shape[0], 1))]).astype(np.float32),
        "TEXCOORD_0": np.stack([uu, vv], -1).reshape(-1, 2).astype(np.float32),
        "indices": faces.reshape(-1).astype(np.uint16),
    }


def direction_png(degrees: float) -> bytes:
    """A 4x4 anisotropyTexture of constant direction ``degrees`` counter-clockwise from
    the tangent: RG = (cos, sin) encoded 0.5 + 0.5 x to 8 bits (linear), B = 1 (the full
    ``anisotropyStrength``)."""
    a = math.radians(degrees)
    rg = [round(255.0 * (0.5 + 0.5 * c)) for c in (math.cos(a), math.sin(a))]
    return _png(np.full((4, 4, 3), (*rg, 255), np.uint8))


def groove_slopes() -> np.ndarray:
    """The slope dh/du across one groove at each texel centre: uniform within
    +-tan(GROOVE_DEGREES), a scallop (h parabolic), so the normals under a footprint of
    whole grooves spread evenly along the tangent and not at all along the bitangent."""
    x = (np.arange(GROOVE_TEXELS) + 0.5) / GROOVE_TEXELS * 2.0 - 1.0
    return x * math.tan(math.radians(GROOVE_DEGREES))


def groove_png() -> bytes:
    """The grooves' tangent-space normal map (RGB 8-bit, n = 0.5 + 0.5 n): n = (-s, 0, 1)
    normalised; 16 texels tall, as it is constant along v."""
    s = np.tile(groove_slopes(), GROOVES)
    n = np.stack([-s, np.zeros_like(s), np.ones_like(s)], -1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    row = np.round(255.0 * (0.5 + 0.5 * n)).astype(np.uint8)
    return _png(np.repeat(row[None], 16, axis=0))


def _png(pixels: np.ndarray) -> bytes:
    out = io.BytesIO()
    Image.fromarray(pixels).save(out, format="PNG", optimize=True)
    return out.getvalue()


class _Buffer:
    """The one .bin and its bufferViews and accessors, grown per array."""

    def __init__(self) -> None:
        self.blob = bytearray()
        self.views: list[dict] = []
        self.accessors: list[dict] = []

    def add(self, values: np.ndarray, indices: bool = False) -> int:
        self.blob += b"\0" * (-len(self.blob) % 4)
        data = np.ascontiguousarray(values).tobytes()
        self.views.append({"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data),
                           "target": 34963 if indices else 34962})  # fmt: skip
        self.blob += data
        width = 1 if values.ndim == 1 else values.shape[1]
        accessor = {
            "bufferView": len(self.views) - 1,
            "componentType": USHORT if indices else FLOAT,
            "count": len(values),
            "type": {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4"}[width],
        }
        if width == 3:
            accessor["min"] = [float(x) for x in values.min(axis=0)]
            accessor["max"] = [float(x) for x in values.max(axis=0)]
        self.accessors.append(accessor)
        return len(self.accessors) - 1


def build() -> dict[str, bytes]:
    """Every file of the stand-in by name: the .gltf, its .bin and three PNGs."""
    buf = _Buffer()
    plain = sphere(0.0)
    shared = {k: buf.add(plain[k]) for k in ("POSITION", "NORMAL", "TEXCOORD_0")}
    indices = buf.add(plain["indices"], indices=True)
    straight = buf.add(plain["TANGENT"])
    tilted = buf.add(sphere(TILT_DEGREES)["TANGENT"])

    def aniso(rotation_degrees: float = 0.0, texture: int | None = None) -> dict:
        ext: dict = {"anisotropyStrength": STRENGTH}
        if rotation_degrees:
            ext["anisotropyRotation"] = math.radians(rotation_degrees)
        if texture is not None:
            ext["anisotropyTexture"] = {"index": texture}
        return {"KHR_materials_anisotropy": ext}

    def metal(name: str, roughness: float = ROUGHNESS, **more: object) -> dict:
        pbr = {"baseColorFactor": BASE_COLOR, "metallicFactor": 1.0, "roughnessFactor": roughness}
        return {"name": name, "pbrMetallicRoughness": pbr, **more}

    images = {
        "direction30.png": direction_png(TILT_DEGREES),
        "direction10.png": direction_png(10.0),
        "grooves_normal.png": groove_png(),
    }
    materials = {
        "plain": metal("Anisotropy along TANGENT", extensions=aniso()),
        "rotation": metal("Tilted TANGENT + rotation", extensions=aniso(TILT_DEGREES)),
        "texture": metal("Tilted TANGENT + texture", extensions=aniso(texture=0)),
        "texture_rotation": metal(
            "Tilted TANGENT + texture + rotation", extensions=aniso(TILT_DEGREES - 10.0, texture=1)
        ),
        "grooves": metal("Groove normal map", GROOVE_ROUGHNESS, normalTexture={"index": 2}),
    }
    names = list(materials)
    meshes = []
    for name in names:
        attributes = dict(shared)
        attributes["TANGENT"] = straight if name in ("plain", "grooves") else tilted
        primitive = {"attributes": attributes, "indices": indices, "material": names.index(name)}
        meshes.append({"name": name, "primitives": [primitive]})
    nodes = [
        {"name": label, "mesh": names.index(mesh), "translation": [*node_centre(col, row), 0.0]}
        for label, col, row, mesh in NODES
    ]
    blob = bytes(buf.blob)
    doc = {
        "asset": {"version": "2.0", "generator": "pbs scripts/anisotropy_rotation_standin.py"},
        "extensionsUsed": ["KHR_materials_anisotropy"],
        "scene": 0,
        "scenes": [{"name": NAME, "nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": list(materials.values()),
        "textures": [{"sampler": 0, "source": i} for i in range(len(images))],
        "samplers": [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}],
        "images": [{"uri": name, "mimeType": "image/png"} for name in images],
        "accessors": buf.accessors,
        "bufferViews": buf.views,
        "buffers": [{"uri": f"{NAME}.bin", "byteLength": len(blob)}],
    }
    text = json.dumps(doc, indent=1) + "\n"
    return {f"{NAME}.gltf": text.encode(), f"{NAME}.bin": blob, **images}


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    for name, data in build().items():
        (out / name).write_bytes(data)
        print(f"{out / name}: {len(data)} bytes")


def _render_hdr(gl: object, data: dict) -> np.ndarray:
    """The linear HDR image (H, W, 3), float64, of ``view_scene``'s dict ``data``."""
    from app.render.renderer import Renderer
    from app.scene.sources import scene_from

    r = Renderer(gl, scene_from(data, base_dir=OUT))
    try:
        r.render()
        return r.read_hdr()[..., :3].astype(np.float64)
    finally:
        r.release()


def grooves() -> None:
    """docs/filtering.md's table: the grooved sphere alone (48 x 48, ``view_scene``'s
    scale) with each normal filter and the reference from level 0 (16 x 16 samples): its
    highlight's elongation and direction, and mean FLIP against the reference."""
    from app.bench.metrics import image_errors
    from app.gl.context import create_context

    gl = create_context("egl")
    col, row = next((c, r) for name, c, r, _ in NODES if name == "Normal map of grooves")
    centre = node_centre(col, row)
    ref = _render_hdr(gl, view_scene((48, 48), centre, normal_filter="none", supersample=16))
    angle, elongation = highlight_shape(ref)
    print(f"| reference | {elongation:.2f} | {angle:.1f} | |")
    for name in ("auto", "lean", "variance", "toksvig", "naive"):
        hdr = _render_hdr(gl, view_scene((48, 48), centre, normal_filter=name))
        angle, elongation = highlight_shape(hdr)
        flip = image_errors(hdr, ref, np.ones((48, 48), bool), 0.0, "neutral")["flip_mean"]
        print(f"| {name} | {elongation:.2f} | {angle:.1f} | {flip:.3f} |")


def figure(path: Path) -> None:
    """docs/gltf.md's figure (module docstring): four panels of ``VIEW_SIZE`` side by side,
    from the committed stand-in in OUT."""
    from app.gl.context import create_context
    from app.reference.tonemap import post_process
    from app.render.renderer import Renderer
    from app.scene.look import Look
    from app.scene.sources import scene_from

    gl = create_context("egl")
    look = Look(view="front")
    r = Renderer(gl, scene_from(OUT / f"{NAME}.gltf", look=look, size=VIEW_SIZE), VIEW_SIZE)
    try:
        r.render()
        panels = [np.ascontiguousarray(r.read_ldr()[..., :3])]
    finally:
        r.release()
    variance, lean = {"normal_filter": "variance"}, {"normal_filter": "lean"}
    for render in (variance, lean, {"normal_filter": "none", "supersample": 8}):
        hdr = _render_hdr(gl, view_scene(**render))
        ldr = np.clip(post_process(hdr, 0.0, "neutral"), 0.0, 1.0)
        panels.append((ldr * 255.0 + 0.5).astype(np.uint8))
    gap = np.full((VIEW_SIZE[1], 2, 3), 255, np.uint8)
    row = [x for panel in panels for x in (panel, gap)][:-1]
    Image.fromarray(np.concatenate(row, axis=1)).save(path, optimize=True)
    print(f"{path}: {path.stat().st_size} bytes")


if __name__ == "__main__":
    if sys.argv[1:2] == ["--figure"]:
        figure(Path(sys.argv[2]))
    elif sys.argv[1:2] == ["--grooves"]:
        grooves()
    else:
        main(Path(sys.argv[1]) if len(sys.argv) > 1 else OUT)
