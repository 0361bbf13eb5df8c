"""A small glTF 2.0 "stage": a floor, a camera and three KHR_lights_punctual lights, for
scenes/gltf_stage.toml (docs/gltf-lights-cameras.md).

Why generate it: the file is the example of what ``camera.from_file`` and
``import_lights`` read, so its numbers are written here where they can be read
(positions, aims, intensities in candela and lux), and ``tests/test_gltf_lights_cameras.py``
checks the checked-in file still matches a fresh build. The floor's buffer is a
``data:`` URI, so the .gltf is one self-contained text file.

Run ``python -m app.assets.gltf_stage`` to rewrite ``scenes/meshes/stage.gltf``.
"""

from __future__ import annotations

import base64
import json
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parents[2] / "scenes" / "meshes" / "stage.gltf"
EXT = "KHR_lights_punctual"
FLOOR_HALF = 4.0  # m: the floor is 8 m x 8 m at y = 0


def aim(direction: list[float]) -> list[float]:
    """The unit quaternion (x, y, z, w) that turns glTF's forward, local -Z, onto
    ``direction``: axis -Z x d, angle acos(-Z . d), from the half-way form
    q = normalize(a x b, 1 + a . b) (valid unless d is +Z, not used here)."""
    a = np.array([0.0, 0.0, -1.0])
    b = np.asarray(direction, np.float64)
    b = b / np.linalg.norm(b)
    q = np.array([*np.cross(a, b), 1.0 + float(a @ b)])
    return [round(float(x), 9) for x in q / np.linalg.norm(q)]


def _floor_buffer() -> tuple[bytes, dict]:
    """Positions, normals, UVs (float32) and indices (uint16) of the floor's two triangles,
    facing +Y (counter-clockwise seen from above)."""
    h = FLOOR_HALF
    positions = np.array([[-h, 0, -h], [-h, 0, h], [h, 0, h], [h, 0, -h]], np.float32)
    normals = np.tile(np.array([0, 1, 0], np.float32), (4, 1))
    uvs = np.array([[0, 0], [0, 1], [1, 1], [1, 0]], np.float32)
    indices = np.array([0, 1, 2, 0, 2, 3], np.uint16)
    blobs = [positions.tobytes(), normals.tobytes(), uvs.tobytes(), indices.tobytes()]
    views, offset = [], 0
    for blob in blobs:
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(blob)})
        offset += len(blob)
    accessors = [
        {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
         "min": [-h, 0.0, -h], "max": [h, 0.0, h]},
        {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
        {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
        {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"},
    ]  # fmt: skip
    return b"".join(blobs), {"bufferViews": views, "accessors": accessors}


def build() -> str:
    """The stage as glTF JSON text."""
    data, tables = _floor_buffer()
    uri = "data:application/octet-stream;base64," + base64.b64encode(data).decode("ascii")
    doc = {
        "asset": {"version": "2.0", "generator": "pbs app/assets/gltf_stage.py"},
        "extensionsUsed": [EXT],
        "extensions": {
            EXT: {
                "lights": [
                    # candela: c_light = intensity / pi at 1 m (docs/gltf-lights-cameras.md)
                    {
                        "name": "Key",
                        "type": "spot",
                        "color": [1.0, 0.85, 0.65],
                        "intensity": 80.0,
                        "range": 12.0,
                        "spot": {"innerConeAngle": 0.25, "outerConeAngle": 0.45},
                    },
                    {
                        "name": "Bulb",
                        "type": "point",
                        "color": [0.55, 0.75, 1.0],
                        "intensity": 6.0,
                        "range": 4.0,
                    },
                    # lux: a dim sky from above and behind
                    {
                        "name": "Sky",
                        "type": "directional",
                        "color": [0.7, 0.8, 1.0],
                        "intensity": 0.5,
                    },
                ]
            }
        },
        "scene": 0,
        "scenes": [{"name": "stage", "nodes": [0, 1, 2, 3, 4]}],
        "nodes": [
            {"name": "Floor", "mesh": 0},
            {
                "name": "Camera",
                "camera": 0,
                "translation": [0.0, 2.2, 5.5],
                "rotation": aim([0.0, -1.7, -5.5]),
            },
            {
                "name": "KeyLight",
                "translation": [-2.5, 3.5, 1.5],
                "rotation": aim([2.5, -3.0, -1.5]),
                "extensions": {EXT: {"light": 0}},
            },
            {
                "name": "BulbLight",
                "translation": [2.0, 1.0, 1.2],
                "extensions": {EXT: {"light": 1}},
            },
            {
                "name": "SkyLight",
                "rotation": aim([0.3, -1.0, -0.6]),
                "extensions": {EXT: {"light": 2}},
            },
        ],
        "cameras": [
            {
                "name": "Camera_0",
                "type": "perspective",
                "perspective": {"yfov": 0.6, "znear": 0.1, "zfar": 50.0},
            },
        ],
        "meshes": [
            {
                "name": "floor",
                "primitives": [
                    {"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3}
                ],
            },
        ],
        "buffers": [{"byteLength": len(data), "uri": uri}],
        **tables,
    }
    return json.dumps(doc, indent=1) + "\n"


def main() -> None:
    OUT.write_text(build(), encoding="utf-8")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
