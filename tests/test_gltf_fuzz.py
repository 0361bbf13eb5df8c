"""Damaged glTF files are bad input, never a crash or a hang.

A seeded loop of mutations of one valid, feature-rich file (tests/gltf_builder.py):
truncated GLBs and buffers, flipped bytes, garbage JSON, and JSON values replaced by
wrong ones (out-of-range indices, wrong counts, NaN and huge factors, wrong types).
Every case read in-process either builds its parts or raises ``InputError``; anything
else fails the test with the case that caused it. A few cases run through ``pbs render``
in a subprocess: exit 2 and one line on stderr.
"""

from __future__ import annotations

import json
import random
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pygltflib
import pytest

from app.errors import InputError
from app.scene.geometry import build_parts
from app.scene.loader import load_scene
from tests.gltf_builder import QUAD_UV, GltfBuilder, png_rgb
from tests.test_gltf import SCENE

REPO = Path(__file__).resolve().parent.parent
CASES = 240  # in-process mutations (about 5 s on llvmpipe's machine; no GL is needed)
# Replacement values: indices past every table, negatives, huge counts, non-finite and
# out-of-range numbers, wrong types.
BAD_VALUES = [
    -1,
    0,
    1,
    2,
    3,
    7,
    99,
    2**31,
    2**40,
    -(2**31),
    0.5,
    1e300,
    -1e300,
    float("nan"),
    float("inf"),
    "x",
    None,
    [],
    {},
    [1, 2],
    True,
]


def _valid(folder: Path) -> Path:
    """A GLB with textures (bufferView images, samplers, a transform), TEXCOORD_1,
    COLOR_0, TANGENT, a sparse accessor and a child node."""
    b = GltfBuilder()
    base = b.texture(png_rgb((200, 100, 30)), {"wrapS": 33071, "minFilter": 9987})
    mr = b.texture(png_rgb((0, 128, 64)))
    normal = b.texture(png_rgb((128, 128, 255)))
    mat = pygltflib.Material(
        pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(
            baseColorFactor=[0.5, 0.6, 0.7, 0.8],
            baseColorTexture=pygltflib.TextureInfo(
                index=base, extensions={"KHR_texture_transform": {"offset": [0.1, 0.2]}}
            ),
            metallicRoughnessTexture=pygltflib.TextureInfo(index=mr),
        ),
        normalTexture=pygltflib.NormalMaterialTexture(index=normal, scale=0.8),
        occlusionTexture=pygltflib.OcclusionTextureInfo(index=mr, strength=0.5),
        emissiveFactor=[0.1, 0.2, 0.3],
        alphaMode="MASK",
    )
    colors = np.full((4, 4), 0.5, np.float32)
    tangents = np.tile(np.float32([1, 0, 0, 1]), (4, 1))
    child = b.quad(b.material(mat), root=False, uv1=QUAD_UV, colors=colors, tangents=tangents)
    b.node(translation=[0.0, 0.0, -1.0], children=[child])
    b.doc.accessors[0].sparse = pygltflib.Sparse(
        count=1,
        indices=pygltflib.AccessorSparseIndices(
            bufferView=b.view(bytes([1, 0, 0, 0])), componentType=5121
        ),
        values=pygltflib.AccessorSparseValues(
            bufferView=b.view(np.float32([1, -1, 0.5]).tobytes())
        ),
    )
    return b.save(folder / "valid.glb")


def _chunks(data: bytes) -> tuple[dict, bytes]:
    (n,) = struct.unpack("<I", data[12:16])
    doc = json.loads(data[20 : 20 + n])
    return doc, data[28 + n :]


def _json(doc: object) -> bytes:
    """Compact JSON (NaN and Infinity written as Python's json writes them)."""
    return json.dumps(doc, separators=(",", ":")).encode()


def _glb(text: bytes, blob: bytes) -> bytes:
    text += b" " * (-len(text) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text
    body += struct.pack("<II", len(blob), 0x004E4942) + blob
    return b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body


def _leaves(node: object, path: tuple = ()) -> list[tuple]:
    """Every path to a value in the JSON tree (containers included)."""
    out = [path] if path else []
    if isinstance(node, dict):
        for k, v in node.items():
            out += _leaves(v, (*path, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += _leaves(v, (*path, i))
    return out


def _mutate(valid: bytes, rng: random.Random) -> tuple[str, bytes]:
    """One damaged copy of ``valid`` and a description of the damage."""
    doc, blob = _chunks(valid)
    kind = rng.choice(["json", "json", "json", "truncate", "flip", "blob", "garbage"])
    if kind == "truncate":
        cut = rng.randrange(0, len(valid))
        return f"truncated at {cut}", valid[:cut]
    if kind == "flip":
        data = bytearray(valid)
        for _ in range(rng.randint(1, 8)):
            data[rng.randrange(len(data))] = rng.randrange(256)
        return "flipped bytes", bytes(data)
    if kind == "blob":
        cut = rng.randrange(0, len(blob))
        return f"BIN chunk cut to {cut}", _glb(_json(doc), blob[:cut])
    if kind == "garbage":
        text = _json(doc)
        cut = rng.randrange(1, len(text))
        return f"JSON cut at {cut}", _glb(text[:cut], blob)
    path = rng.choice(_leaves(doc))
    target = doc
    for key in path[:-1]:
        target = target[key]
    value = rng.choice(BAD_VALUES)
    if rng.random() < 0.2 and isinstance(target, list):
        del target[path[-1]]
        return f"deleted {path}", _glb(_json(doc), blob)
    target[path[-1]] = value
    return f"{path} = {value!r}", _glb(_json(doc), blob)


def test_mutated_gltf_is_input_error_or_parts(tmp_path: Path) -> None:
    valid = _valid(tmp_path).read_bytes()
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE.format(file="case.glb"), encoding="utf-8")
    (tmp_path / "case.glb").write_bytes(valid)
    assert len(build_parts(load_scene(scene))) == 1  # the unmutated file reads
    rng = random.Random(17)
    outcomes = {"parts": 0, "error": 0}
    for case in range(CASES):
        what, data = _mutate(valid, rng)
        (tmp_path / "case.glb").write_bytes(data)
        try:
            build_parts(load_scene(scene))
            outcomes["parts"] += 1
        except InputError as exc:
            assert "\n" not in str(exc), (case, what, str(exc))
            outcomes["error"] += 1
        except Exception as exc:  # the point: nothing else escapes
            pytest.fail(f"case {case} ({what}): {type(exc).__name__}: {exc}")
    # Both outcomes occur, so the mutations neither all miss nor all break the file.
    assert outcomes["parts"] >= 5 and outcomes["error"] > CASES // 2, outcomes


def test_damaged_draco_stream_is_input_error_or_parts(tmp_path: Path) -> None:
    """Flipped bytes and truncations inside a Draco stream (DracoPy decodes or refuses;
    the reader checks what it returns)."""
    b = GltfBuilder()
    view = b.draco_quad()
    start, length = b.doc.bufferViews[view].byteOffset, b.doc.bufferViews[view].byteLength
    stream = bytes(b.blob[start : start + length])
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE.format(file="d.glb"), encoding="utf-8")
    rng = random.Random(3)
    refused = 0
    for case in range(60):
        damaged = bytearray(stream)
        if case % 2:
            damaged = damaged[: rng.randrange(len(damaged))]
        else:
            for _ in range(rng.randint(1, 4)):
                damaged[rng.randrange(len(damaged))] = rng.randrange(256)
        b.blob[start : start + length] = bytes(damaged).ljust(length, b"\0")
        b.doc.bufferViews[view].byteLength = len(damaged) or 1
        b.save(tmp_path / "d.glb")
        try:
            build_parts(load_scene(scene))
        except InputError as exc:
            assert "\n" not in str(exc)
            refused += 1
        except Exception as exc:  # the point: nothing else escapes
            pytest.fail(f"case {case}: {type(exc).__name__}: {exc}")
    assert refused >= 30  # every truncation at least


@pytest.mark.parametrize(
    ("name", "damage", "fragment"),
    [
        ("truncated", lambda d: d[: len(d) // 2], "not a glTF 2.0 file"),
        ("nan-factor", lambda d: d.replace(b"0.5,0.6", b"NaN,0.6", 1), "baseColorFactor"),
        (
            "index-out-of-range",
            lambda d: d.replace(b'"material":0', b'"material":5', 1),
            "material",
        ),
    ],
    ids=["truncated", "nan-factor", "index-out-of-range"],
)
def test_cli_exits_2_with_one_line(tmp_path: Path, name: str, damage, fragment: str) -> None:
    data = _valid(tmp_path).read_bytes()
    doc, blob = _chunks(data)
    damaged = damage(_glb(_json(doc), blob))
    assert damaged != _glb(_json(doc), blob), "the damage did not apply"
    (tmp_path / "bad.glb").write_bytes(damaged)
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE.format(file="bad.glb"), encoding="utf-8")
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "app",
            "render",
            str(scene),
            "-o",
            str(tmp_path / "o.png"),
            "--size",
            "16x16",
        ],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    if result.returncode == 1 and "no headless OpenGL" in result.stderr:
        pytest.skip("no headless OpenGL context here")
    assert result.returncode == 2, result.stderr
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    assert "objects[0].file" in lines[0] and fragment in lines[0], lines[0]
    assert not (tmp_path / "o.png").exists()
