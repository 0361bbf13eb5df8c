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
Output is deterministic (the test regenerates it and compares bytes).
Usage: python scripts/anisotropy_rotation_standin.py [OUT_FOLDER]
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


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else OUT)
