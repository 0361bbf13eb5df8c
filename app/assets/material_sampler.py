"""A small glTF 2.0 sample asset made by the project: every core material feature the
renderer reads, on procedural textures, for scenes/gltf_material_sampler.toml.

Why generate it: users need a file to try the glTF path on without downloading sample
models, and the screenshot needs one whose every texture is known. The primitives:

- a sphere (UV sphere, radius 0.5): base colour map with painted bands, a
  metallic-roughness map (metal and dielectric stripes, rough to smooth), a normal map of
  rivets, an occlusion map darkening the rivets' rims;
- a rounded panel (a bevelled slab): the same rivets, an emissive pattern (a glowing
  ring of dots) with ``KHR_materials_emissive_strength``;
- a grate (a quad, ``alphaMode`` MASK): holes cut where the base colour's alpha is low;
- a leaf (a quad, ``doubleSided``): seen from both sides.

Run ``python -m app.assets.material_sampler`` to rewrite
``scenes/meshes/material_sampler.glb``; tests/test_material_sampler.py checks the
checked-in file equals a fresh build (so it stays reproducible byte for byte).
"""

from __future__ import annotations

import io
import json
import math
import struct
from pathlib import Path

import numpy as np
from PIL import Image

OUT = Path(__file__).resolve().parents[2] / "scenes" / "meshes" / "material_sampler.glb"
TEX = 128  # texture size (texels): keeps the file small
FLOAT, USHORT = 5126, 5123


def uv_sphere(
    radius: float, rings: int, segments: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(positions, normals, glTF UVs, uint16 indices) of a UV sphere about the origin: u
    runs once round +Y (from +Z towards +X), v from the north pole (0) to the south (1);
    the seam column is duplicated so that u reaches 1. Triangles wind counter-clockwise
    seen from outside (glTF front faces)."""
    theta = np.linspace(0.0, np.pi, rings + 1)  # from +Y
    phi = np.linspace(0.0, 2.0 * np.pi, segments + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    normals = np.stack([np.sin(t) * np.sin(p), np.cos(t), np.sin(t) * np.cos(p)], axis=-1)
    uv = np.stack([p / (2.0 * np.pi), t / np.pi], axis=-1)
    cols = segments + 1
    quads = []
    for i in range(rings):
        for j in range(segments):
            a, b = i * cols + j, i * cols + j + 1
            c, d = a + cols, b + cols
            quads += [a, c, b, b, c, d]
    n = normals.reshape(-1, 3).astype(np.float32)
    return (
        (n * np.float32(radius)).astype(np.float32),
        n,
        uv.reshape(-1, 2).astype(np.float32),
        np.array(quads, np.uint16),
    )


def rounded_panel(
    half: float, depth: float, bevel: float, n: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(positions, normals, glTF UVs, uint16 indices) of a panel facing +Z: an n x n grid
    over [-half, half]^2 whose height rises from 0 at the rim to ``depth`` over a rounded
    bevel of width ``bevel`` (a quarter circle's profile), so its edge catches the light.
    Normals are the height field's (-dz/dx, -dz/dy, 1), normalised."""
    xs = np.linspace(-half, half, n)
    x, y = np.meshgrid(xs, xs[::-1])  # row 0 at the top (+y), as glTF's v = 0

    def height(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        d = np.clip((half - np.maximum(np.abs(x), np.abs(y))) / bevel, 0.0, 1.0)
        return depth * np.sqrt(1.0 - (1.0 - d) ** 2)

    z = height(x, y)
    e = 1e-4  # central differences of the profile (it is smooth inside the rim)
    dzdx = (height(x + e, y) - height(x - e, y)) / (2 * e)
    dzdy = (height(x, y + e) - height(x, y - e)) / (2 * e)
    normals = np.stack([-dzdx, -dzdy, np.ones_like(z)], axis=-1)
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    uv = np.stack([(x + half) / (2 * half), (half - y) / (2 * half)], axis=-1)
    quads = []
    for i in range(n - 1):
        for j in range(n - 1):
            a, b = i * n + j, i * n + j + 1
            c, d = a + n, b + n
            quads += [a, c, b, b, c, d]  # counter-clockwise seen from +Z
    positions = np.stack([x, y, z], axis=-1)
    return (
        positions.reshape(-1, 3).astype(np.float32),
        normals.reshape(-1, 3).astype(np.float32),
        uv.reshape(-1, 2).astype(np.float32),
        np.array(quads, np.uint16),
    )


def quad(half: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A 2 half x 2 half quad facing +Z, UV (0, 0) at its top left."""
    h = half
    positions = np.array([[-h, -h, 0], [h, -h, 0], [h, h, 0], [-h, h, 0]], np.float32)
    normals = np.tile(np.float32([0, 0, 1]), (4, 1))
    uv = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)
    return positions, normals, uv, np.array([0, 1, 2, 0, 2, 3], np.uint16)


# --- procedural textures (TEX x TEX, row 0 at the image's top = glTF v = 0) -------------

_CENTRES = (np.arange(TEX) + 0.5) / TEX
_U, _V = np.meshgrid(_CENTRES, _CENTRES)


def _u8(x: np.ndarray) -> np.ndarray:
    return np.round(np.clip(x, 0.0, 1.0) * 255.0).astype(np.uint8)


def _rivets(cells: int) -> tuple[np.ndarray, np.ndarray]:
    """(height in [0, 1], distance to the nearest rivet centre in cell units) of a grid of
    ``cells`` x ``cells`` round rivets (radius 0.22 cell, a spherical cap)."""
    fu, fv = (_U * cells) % 1.0 - 0.5, (_V * cells) % 1.0 - 0.5
    r = np.hypot(fu, fv)
    cap = np.sqrt(np.clip(1.0 - (r / 0.22) ** 2, 0.0, 1.0))
    return cap, r


def normal_texture(cells: int = 6, strength: float = 1.2) -> np.ndarray:
    """Tangent-space normals (RGB, glTF's +X right along u, +Y up the image) of the
    rivets: n = normalize(-dh/du, dh/dv, 1/strength) from the height field's gradient
    per texel (v runs down the image, so up is -v)."""
    h, _ = _rivets(cells)
    dv, du = np.gradient(h)  # per texel, along rows (v) and columns (u)
    n = np.stack([-du, dv, np.full_like(h, 1.0 / strength)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return _u8(n * 0.5 + 0.5)


def occlusion_texture(cells: int = 6) -> np.ndarray:
    """Ambient occlusion (R; G, B the same): dark rings where each rivet meets the plate,
    lighter towards the plate between rivets."""
    _, r = _rivets(cells)
    ring = np.exp(-(((r - 0.25) / 0.05) ** 2))
    ao = 1.0 - 0.65 * ring
    return np.dstack([_u8(ao)] * 3)


def painted_base(cells: int = 6) -> np.ndarray:
    """RGBA base colour of the sphere: painted bands along v (teal, cream, rust) with the
    rivets bare steel; opaque."""
    bands = np.array([[0.05, 0.35, 0.38], [0.8, 0.74, 0.6], [0.55, 0.2, 0.08]])
    band = bands[(np.floor(_V * 9).astype(int)) % 3]
    h, _ = _rivets(cells)
    steel = np.array([0.62, 0.62, 0.64])
    rgb = np.where((h > 0.0)[..., None], steel, band)
    srgb = np.where(rgb <= 0.0031308, 12.92 * rgb, 1.055 * rgb ** (1 / 2.4) - 0.055)
    return np.dstack([_u8(srgb), np.full((TEX, TEX), 255, np.uint8)])


def metal_roughness(cells: int = 6) -> np.ndarray:
    """glTF metallic-roughness (G roughness, B metallic): paint is dielectric and fairly
    rough (0.55), rivets are brushed metal, 0.5 at their tops and 0.6 at their rims (not
    smoother: a sharper lobe would show the environment's sample directions one by
    one)."""
    h, _ = _rivets(cells)
    rivet = h > 0.0
    rough = np.where(rivet, 0.6 - 0.1 * h, 0.55)
    metal = np.where(rivet, 1.0, 0.0)
    return np.dstack([np.zeros((TEX, TEX), np.uint8), _u8(rough), _u8(metal)])


def emissive_ring() -> np.ndarray:
    """The panel's glow (sRGB): a ring of 24 dots round the centre and a thin inner
    circle, cyan."""
    du, dv = _U - 0.5, _V - 0.5
    r, a = np.hypot(du, dv), np.arctan2(dv, du)
    sector = (a / (2 * np.pi) * 24) % 1.0 - 0.5
    dots = np.hypot((r - 0.36) / 0.03, sector * 2 * np.pi * 0.36 / 24 / 0.03) < 1.0
    circle = np.abs(r - 0.26) < 0.012
    glow = (dots | circle).astype(np.float64)
    return np.dstack([_u8(0.1 * glow), _u8(0.9 * glow), _u8(1.0 * glow)])


def grate_base() -> np.ndarray:
    """RGBA of the grate: dark steel with a 5 x 5 grid of round holes (alpha 0 inside,
    a smooth edge over about two texels, so MASK cuts round holes)."""
    fu, fv = (_U * 5) % 1.0 - 0.5, (_V * 5) % 1.0 - 0.5
    r = np.hypot(fu, fv)
    alpha = np.clip((r - 0.33) * TEX / 5 / 2 + 0.5, 0.0, 1.0)
    rgb = np.full((TEX, TEX, 3), 0.32)
    return np.dstack([_u8(rgb), _u8(alpha)])


def leaf_base() -> np.ndarray:
    """RGBA of the leaf: a pointed oval (alpha 1 inside), green with a pale midrib and
    veins; MASK cuts its outline."""
    x, y = (_U - 0.5) * 2.0, (_V - 0.5) * 2.0  # y down the image, the stem at the bottom
    width = 0.55 * np.clip(1.0 - y**2, 0.0, 1.0) ** 0.8
    inside = np.abs(x) < width
    vein = (np.abs(x) < 0.02) | (np.abs(((y + 2 * np.abs(x)) * 5) % 1.0 - 0.5) < 0.04)
    green = np.array([0.2, 0.5, 0.08])
    rgb = np.where(vein[..., None], [0.55, 0.7, 0.3], green)
    srgb = np.where(rgb <= 0.0031308, 12.92 * rgb, 1.055 * rgb ** (1 / 2.4) - 0.055)
    return np.dstack([_u8(srgb), _u8(inside.astype(np.float64))])


# --- the file -----------------------------------------------------------------------


def _png(pixels: np.ndarray) -> bytes:
    """PNG bytes of ``pixels`` (deterministic: no metadata, zlib level 9)."""
    out = io.BytesIO()
    Image.fromarray(pixels).save(out, format="PNG", compress_level=9)
    return out.getvalue()


class _Blob:
    """The one buffer and its views and accessors, grown in order."""

    def __init__(self) -> None:
        self.data = bytearray()
        self.views: list[dict] = []
        self.accessors: list[dict] = []

    def view(self, data: bytes) -> int:
        self.data += b"\0" * (-len(self.data) % 4)
        self.views.append({"buffer": 0, "byteOffset": len(self.data), "byteLength": len(data)})
        self.data += data
        return len(self.views) - 1

    def accessor(self, values: np.ndarray) -> int:
        k = 1 if values.ndim == 1 else values.shape[1]
        acc: dict = {
            "bufferView": self.view(values.tobytes()),
            "componentType": USHORT if values.dtype == np.uint16 else FLOAT,
            "count": len(values),
            "type": {1: "SCALAR", 2: "VEC2", 3: "VEC3"}[k],
        }
        if k == 3 and values.dtype == np.float32:  # POSITION needs its bounds
            acc["min"] = [float(v) for v in values.min(axis=0)]
            acc["max"] = [float(v) for v in values.max(axis=0)]
        self.accessors.append(acc)
        return len(self.accessors) - 1


def _texture_info(index: int, **fields: object) -> dict:
    return {"index": index, **fields}


def build() -> bytes:
    """The sample asset as .glb bytes: JSON chunk, then one BIN chunk with the geometry
    and the PNG textures."""
    blob = _Blob()
    images = [
        painted_base(),  # 0
        metal_roughness(),  # 1
        normal_texture(),  # 2
        occlusion_texture(),  # 3
        emissive_ring(),  # 4
        grate_base(),  # 5
        leaf_base(),  # 6
    ]
    image_entries = [{"bufferView": blob.view(_png(p)), "mimeType": "image/png"} for p in images]
    # 0: repeat, trilinear (9987 LINEAR_MIPMAP_LINEAR, 9729 LINEAR); 1: clamp (the ring)
    samplers = [
        {"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497},
        {"magFilter": 9729, "minFilter": 9987, "wrapS": 33071, "wrapT": 33071},
    ]
    textures = [{"source": i, "sampler": 1 if i == 4 else 0} for i in range(len(images))]
    materials = [
        {
            "name": "riveted_paint",
            "pbrMetallicRoughness": {
                "baseColorTexture": _texture_info(0),
                "metallicRoughnessTexture": _texture_info(1),
            },
            "normalTexture": _texture_info(2, scale=1.0),
            "occlusionTexture": _texture_info(3, strength=1.0),
        },
        {
            "name": "glowing_panel",
            "pbrMetallicRoughness": {
                "baseColorFactor": [0.12, 0.13, 0.15, 1.0],
                "metallicRoughnessTexture": _texture_info(1),
            },
            "normalTexture": _texture_info(2, scale=0.8),
            "occlusionTexture": _texture_info(3, strength=0.8),
            "emissiveTexture": _texture_info(4),
            "emissiveFactor": [1.0, 1.0, 1.0],
            "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}},
        },
        {
            "name": "grate",
            "pbrMetallicRoughness": {
                "baseColorTexture": _texture_info(5),
                "metallicFactor": 1.0,
                "roughnessFactor": 0.4,
            },
            "alphaMode": "MASK",
            "alphaCutoff": 0.5,
            "doubleSided": True,
        },
        {
            "name": "leaf",
            "pbrMetallicRoughness": {
                "baseColorTexture": _texture_info(6),
                "metallicFactor": 0.0,
                "roughnessFactor": 0.6,
            },
            "alphaMode": "MASK",
            "alphaCutoff": 0.5,
            "doubleSided": True,
        },
    ]
    shapes = [
        ("sphere", uv_sphere(0.5, 24, 48), 0),
        ("panel", rounded_panel(0.5, 0.06, 0.08, 33), 1),
        ("grate", quad(0.5), 2),
        ("leaf", quad(0.35), 3),
    ]
    meshes = []
    for name, (positions, normals, uv, indices), material in shapes:
        attributes = {
            "POSITION": blob.accessor(positions),
            "NORMAL": blob.accessor(normals),
            "TEXCOORD_0": blob.accessor(uv),
        }
        primitive = {"attributes": attributes, "indices": blob.accessor(indices)}
        meshes.append({"name": name, "primitives": [primitive | {"material": material}]})
    # Left to right on a floor at y = 0: the sphere, the panel standing up, the grate
    # tilted back; the leaf in front, turned so that the camera sees its back.
    tilt = math.radians(-20.0)  # about X
    turn = math.radians(150.0)  # about Y: the leaf's front faces away
    nodes = [
        {"name": "Sphere", "mesh": 0, "translation": [-1.15, 0.5, 0.0]},
        {"name": "Panel", "mesh": 1, "translation": [0.0, 0.55, -0.1]},
        {
            "name": "Grate",
            "mesh": 2,
            "translation": [1.15, 0.55, 0.0],
            "rotation": [math.sin(tilt / 2), 0.0, 0.0, math.cos(tilt / 2)],
        },
        {
            "name": "Leaf",
            "mesh": 3,
            "translation": [0.55, 0.4, 0.75],
            "rotation": [0.0, math.sin(turn / 2), 0.0, math.cos(turn / 2)],
        },
    ]
    data = bytes(blob.data) + b"\0" * (-len(blob.data) % 4)
    doc = {
        "asset": {"version": "2.0", "generator": "pbs app/assets/material_sampler.py"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"name": "material_sampler", "nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "textures": textures,
        "samplers": samplers,
        "images": image_entries,
        "accessors": blob.accessors,
        "bufferViews": blob.views,
        "buffers": [{"byteLength": len(data)}],
    }
    text = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text  # "JSON"
    body += struct.pack("<II", len(data), 0x004E4942) + data  # "BIN\0"
    return b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body


def main() -> None:
    OUT.write_bytes(build())
    print(f"wrote {OUT} ({OUT.stat().st_size} bytes)")


if __name__ == "__main__":
    main()
