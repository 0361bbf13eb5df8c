"""Writes tests/assets/CesiumMan.glb: a small derivative of the Khronos sample model
"Cesium Man" (CC-BY 4.0, (c) 2017 Cesium) for the animation tests
(tests/test_gltf_animation.py), from a copy of the original glTF folder.

The original (3,273 skinned vertices, 19 joints, one walk cycle of 57 LINEAR channels; a
253 KB buffer and a 210 KB JPEG) is kept whole except for its vertex encodings and its
texture: JOINTS_0 as unsigned bytes, WEIGHTS_0 as normalized unsigned bytes (rounded so
that each vertex's four sum to 255), NORMAL as normalized signed bytes and TEXCOORD_0 as
normalized unsigned shorts (KHR_mesh_quantization), and the texture downscaled to 128^2
JPEG; positions, indices, inverse bind matrices and every animation sampler stay float32
as they were. One GLB. Usage: python scripts/small_cesium_man.py ORIGINAL_FOLDER [OUT]
"""

from __future__ import annotations

import io
import json
import struct
import sys
from pathlib import Path

import numpy as np
from PIL import Image

TEXTURE = 128
QUANTIZATION = "KHR_mesh_quantization"
_DTYPES = {5126: "<f4", 5123: "<u2", 5121: "<u1", 5120: "<i1"}
_WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def _accessor(doc: dict, blob: bytes, index: int) -> np.ndarray:
    """Accessor ``index`` of the original file (tightly packed, as Cesium Man's are)."""
    a = doc["accessors"][index]
    view = doc["bufferViews"][a["bufferView"]]
    assert view.get("byteStride") in (None, 4 * _WIDTHS[a["type"]], 2 * _WIDTHS[a["type"]])
    width = _WIDTHS[a["type"]]
    start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
    values = np.frombuffer(blob, _DTYPES[a["componentType"]], a["count"] * width, start)
    return values.reshape(a["count"], width)


def _weights(weights: np.ndarray) -> np.ndarray:
    """Four weights per vertex as bytes summing to 255 (the largest takes the rounding)."""
    scaled = np.rint(weights / weights.sum(axis=1, keepdims=True) * 255.0).astype(np.int64)
    biggest = np.argmax(scaled, axis=1)
    scaled[np.arange(len(scaled)), biggest] += 255 - scaled.sum(axis=1)
    return scaled.astype(np.uint8)


def main(source: Path, out: Path) -> None:
    doc = json.loads((source / "CesiumMan.gltf").read_text(encoding="utf-8"))
    blob = (source / doc["buffers"][0]["uri"]).read_bytes()
    arrays: dict[int, tuple[np.ndarray, int, bool]] = {}  # accessor -> (values, type, norm)
    for index, a in enumerate(doc["accessors"]):
        arrays[index] = (_accessor(doc, blob, index), a["componentType"], False)
    attrs = doc["meshes"][0]["primitives"][0]["attributes"]
    joints = arrays[attrs["JOINTS_0"]][0]
    arrays[attrs["JOINTS_0"]] = (joints.astype(np.uint8), 5121, False)
    arrays[attrs["WEIGHTS_0"]] = (_weights(arrays[attrs["WEIGHTS_0"]][0]), 5121, True)
    normals = arrays[attrs["NORMAL"]][0]
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    packed = np.zeros((len(normals), 4), np.int8)  # padded to 4 bytes per vertex
    packed[:, :3] = np.clip(np.rint(normals * 127.0), -127, 127)
    arrays[attrs["NORMAL"]] = (packed, 5120, True)
    uv = np.clip(arrays[attrs["TEXCOORD_0"]][0], 0.0, 1.0)
    arrays[attrs["TEXCOORD_0"]] = (np.rint(uv * 65535.0).astype(np.uint16), 5123, True)
    data = bytearray()
    views = []
    for index, a in enumerate(doc["accessors"]):
        values, component, normalized = arrays[index]
        data += b"\0" * (-len(data) % 4)
        raw = np.ascontiguousarray(values).tobytes()
        view = {"buffer": 0, "byteOffset": len(data), "byteLength": len(raw)}
        if index == attrs["NORMAL"]:
            view["byteStride"] = 4
        views.append(view)
        data += raw
        a.pop("byteOffset", None)
        a["bufferView"] = index
        a["componentType"] = component
        if normalized:
            a["normalized"] = True
        if index in (attrs["NORMAL"], attrs["TEXCOORD_0"]):
            a.pop("min", None)
            a.pop("max", None)
    image = Image.open(source / doc["images"][0]["uri"]).convert("RGB")
    encoded = io.BytesIO()
    image.resize((TEXTURE, TEXTURE), Image.LANCZOS).save(encoded, "JPEG", quality=85)
    data += b"\0" * (-len(data) % 4)
    views.append({"buffer": 0, "byteOffset": len(data), "byteLength": encoded.tell()})
    data += encoded.getvalue()
    doc["images"] = [{"bufferView": len(views) - 1, "mimeType": "image/jpeg"}]
    data += b"\0" * (-len(data) % 4)
    doc["bufferViews"] = views
    doc["buffers"] = [{"byteLength": len(data)}]
    for name in ("extensionsUsed", "extensionsRequired"):
        doc[name] = sorted({*doc.get(name, []), QUANTIZATION})
    doc["asset"]["extras"] = {
        "source": "Khronos glTF Sample Models 2.0/CesiumMan, CC-BY 4.0, (c) 2017 Cesium; "
        "reduced by scripts/small_cesium_man.py (tests/assets/LICENSE.md)"
    }
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    chunks = struct.pack("<II", len(text), 0x4E4F534A) + text
    chunks += struct.pack("<II", len(data), 0x004E4942) + bytes(data)
    out.write_bytes(struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks)
    print(f"{out}: {out.stat().st_size} bytes")


if __name__ == "__main__":
    folder = Path(sys.argv[1])
    target = Path(sys.argv[2]) if len(sys.argv) > 2 else Path("tests/assets/CesiumMan.glb")
    main(folder, target)
