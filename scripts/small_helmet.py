"""Writes tests/assets/DamagedHelmet/: a small derivative of the Khronos sample model
"Battle Damaged Sci-fi Helmet - PBR" by theblueturtle_ (CC-BY 4.0) for the real-asset
tests (tests/test_real_assets.py), from a copy of the original glTF folder.

The mesh (14,556 vertices, 46,356 indices: 558 KB of float32 and uint16) becomes one
KHR_draco_mesh_compression buffer (positions 14 bits, normals 10, UVs 12); each 2048^2
JPEG texture becomes a 256^2 JPEG (Lanczos). Everything else in the file (node, material,
samplers) is kept. Usage: python scripts/small_helmet.py ORIGINAL_FOLDER [OUT_FOLDER]
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import DracoPy
import numpy as np
from PIL import Image

SIZE = 256
EXT = "KHR_draco_mesh_compression"


def _accessor(doc: dict, blob: bytes, index: int) -> np.ndarray:
    """Accessor ``index`` of the original file (tightly packed float32 or uint16)."""
    a = doc["accessors"][index]
    view = doc["bufferViews"][a["bufferView"]]
    dtype = {5126: np.float32, 5123: np.uint16, 5125: np.uint32}[a["componentType"]]
    width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3}[a["type"]]
    start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
    values = np.frombuffer(blob, dtype, a["count"] * width, start)
    return values.reshape(a["count"], width)


def main(source: Path, out: Path) -> None:
    doc = json.loads((source / "DamagedHelmet.gltf").read_text(encoding="utf-8"))
    blob = (source / doc["buffers"][0]["uri"]).read_bytes()
    prim = doc["meshes"][0]["primitives"][0]
    attrs = prim["attributes"]
    points = _accessor(doc, blob, attrs["POSITION"])
    normals = _accessor(doc, blob, attrs["NORMAL"]).astype(np.float64)
    uvs = _accessor(doc, blob, attrs["TEXCOORD_0"]).astype(np.float64)
    faces = _accessor(doc, blob, prim["indices"]).reshape(-1, 3).astype(np.uint32)
    data = DracoPy.encode(
        points, faces, quantization_bits=14, compression_level=10, preserve_order=False,
        tex_coord=uvs, normals=normals, tex_coord_quantization_bits=12,
        normal_quantization_bits=10,
    )  # fmt: skip
    ids = {a["name"]: a["unique_id"] for a in _attributes(data)}
    out.mkdir(parents=True, exist_ok=True)
    (out / "DamagedHelmet.bin").write_bytes(data)
    for accessor in doc["accessors"]:
        accessor.pop("bufferView", None)
    doc["bufferViews"] = [{"buffer": 0, "byteOffset": 0, "byteLength": len(data)}]
    doc["buffers"] = [{"byteLength": len(data), "uri": "DamagedHelmet.bin"}]
    prim["extensions"] = {
        EXT: {
            "bufferView": 0,
            "attributes": {"POSITION": ids["position"], "NORMAL": ids["normal"],
                           "TEXCOORD_0": ids["tex_coord"]},
        }
    }  # fmt: skip
    doc["extensionsUsed"] = [EXT]
    doc["extensionsRequired"] = [EXT]
    doc["asset"]["copyright"] = (
        "Battle Damaged Sci-fi Helmet - PBR by theblueturtle_, CC-BY 4.0; reduced copy "
        "(Draco mesh, 256x256 textures)"
    )
    for image in doc["images"]:
        with Image.open(source / image["uri"]) as original:
            small = original.convert("RGB").resize((SIZE, SIZE), Image.Resampling.LANCZOS)
        small.save(out / image["uri"], quality=90 if "normal" in image["uri"] else 85)
    (out / "DamagedHelmet.gltf").write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")


def _attributes(data: bytes) -> list[dict]:
    """The Draco buffer's attributes as DracoPy decodes them, named by what they hold."""
    mesh = DracoPy.decode(data)
    named = []
    for attribute in mesh.attributes:
        kind = {0: "position", 1: "normal", 3: "tex_coord"}.get(attribute["attribute_type"])
        if kind is not None:
            named.append({"name": kind, "unique_id": attribute["unique_id"]})
    return named


if __name__ == "__main__":
    folder = Path(sys.argv[1])
    target = Path(sys.argv[2]) if len(sys.argv) > 2 else Path("tests/assets/DamagedHelmet")
    main(folder, target)
