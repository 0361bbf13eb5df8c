"""glTF files built in tests with pygltflib: a buffer, accessors, images and materials
added one call at a time, then saved as .glb (one BIN chunk) or .gltf (a .bin file
beside it, or a data: URI). ``quad`` adds the usual test surface.

The quad lies in the XY plane facing +Z, 2 x 2 metres; glTF UVs put (0, 0) at its top
left corner, so the top of an image lands on its top edge and +u runs along +x.
"""

from __future__ import annotations

import base64
import io
import struct
from pathlib import Path

import numpy as np
import pygltflib
from PIL import Image

FLOAT, UBYTE, USHORT, UINT, BYTE, SHORT = 5126, 5121, 5123, 5125, 5120, 5122
_COMPONENT = {
    np.dtype(np.float32): FLOAT,
    np.dtype(np.uint8): UBYTE,
    np.dtype(np.uint16): USHORT,
    np.dtype(np.uint32): UINT,
    np.dtype(np.int8): BYTE,
    np.dtype(np.int16): SHORT,
}
_TYPE = {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4"}

QUAD_POSITIONS = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)
QUAD_UV = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)  # glTF: v down the image
QUAD_INDICES = np.array([0, 1, 2, 0, 2, 3], np.uint16)


class GltfBuilder:
    """One glTF document and its single buffer, grown by the add_* methods."""

    def __init__(self) -> None:
        self.doc = pygltflib.GLTF2(asset=pygltflib.Asset(version="2.0"))
        self.blob = bytearray()
        self.nodes: list[int] = []  # the scene's root nodes

    def view(self, data: bytes, stride: int | None = None) -> int:
        """A bufferView holding ``data`` (4-byte aligned in the buffer)."""
        self.blob += b"\0" * (-len(self.blob) % 4)
        self.doc.bufferViews.append(
            pygltflib.BufferView(
                buffer=0, byteOffset=len(self.blob), byteLength=len(data), byteStride=stride
            )
        )
        self.blob += data
        return len(self.doc.bufferViews) - 1

    def accessor(self, values: np.ndarray, normalized: bool = False, **fields: object) -> int:
        """An accessor over ``values`` ((N,) or (N, k)), tightly packed in its own view."""
        values = np.ascontiguousarray(values)
        k = 1 if values.ndim == 1 else values.shape[1]
        acc = pygltflib.Accessor(
            bufferView=self.view(values.tobytes()),
            componentType=_COMPONENT[values.dtype],
            count=len(values),
            type=_TYPE[k],
            normalized=normalized or None,
        )
        if k == 3 and values.dtype == np.float32:
            acc.min = values.min(axis=0).tolist()
            acc.max = values.max(axis=0).tolist()
        for name, value in fields.items():
            setattr(acc, name, value)
        self.doc.accessors.append(acc)
        return len(self.doc.accessors) - 1

    def image(self, image: Image.Image, how: str = "view", folder: Path | None = None) -> int:
        """A PNG image stored in a bufferView (``how="view"``), a data: URI ("data") or a
        file in ``folder`` ("file")."""
        png = io.BytesIO()
        image.save(png, format="PNG")
        data = png.getvalue()
        index = len(self.doc.images)
        if how == "view":
            entry = pygltflib.Image(bufferView=self.view(data), mimeType="image/png")
        elif how == "data":
            entry = pygltflib.Image(uri="data:image/png;base64," + base64.b64encode(data).decode())
        else:
            assert folder is not None
            name = f"image{index}.png"
            (folder / name).write_bytes(data)
            entry = pygltflib.Image(uri=name)
        self.doc.images.append(entry)
        return index

    def texture(self, image: Image.Image, sampler: dict | None = None, how: str = "view") -> int:
        """A texture of a new image, with a sampler of ``sampler``'s fields where given."""
        source = self.image(image, how)
        s = None
        if sampler is not None:
            self.doc.samplers.append(pygltflib.Sampler(**sampler))
            s = len(self.doc.samplers) - 1
        self.doc.textures.append(pygltflib.Texture(source=source, sampler=s))
        return len(self.doc.textures) - 1

    def material(self, material: pygltflib.Material) -> int:
        self.doc.materials.append(material)
        return len(self.doc.materials) - 1

    def mesh(self, *primitives: pygltflib.Primitive) -> int:
        self.doc.meshes.append(pygltflib.Mesh(primitives=list(primitives)))
        return len(self.doc.meshes) - 1

    def node(self, root: bool = True, **fields: object) -> int:
        self.doc.nodes.append(pygltflib.Node(**fields))
        index = len(self.doc.nodes) - 1
        if root:
            self.nodes.append(index)
        return index

    def quad(
        self,
        material: int | None = None,
        normals: bool = True,
        uv1: np.ndarray | None = None,
        colors: np.ndarray | None = None,
        tangents: np.ndarray | None = None,
        **node: object,
    ) -> int:
        """The test quad as a node of its own (``node``: its fields); returns the node."""
        attrs = pygltflib.Attributes(
            POSITION=self.accessor(QUAD_POSITIONS), TEXCOORD_0=self.accessor(QUAD_UV)
        )
        if normals:
            attrs.NORMAL = self.accessor(np.tile(np.float32([0, 0, 1]), (4, 1)))
        if uv1 is not None:
            attrs.TEXCOORD_1 = self.accessor(uv1)
        if colors is not None:
            attrs.COLOR_0 = self.accessor(colors, normalized=colors.dtype != np.float32)
        if tangents is not None:
            attrs.TANGENT = self.accessor(tangents)
        prim = pygltflib.Primitive(
            attributes=attrs, indices=self.accessor(QUAD_INDICES), material=material
        )
        return self.node(mesh=self.mesh(prim), **node)

    def draco_quad(self) -> int:
        """The test quad (POSITION, TEXCOORD_0) as a KHR_draco_mesh_compression primitive
        (16-bit positions), required by the file; returns the bufferView of the stream."""
        import DracoPy

        faces = QUAD_INDICES.reshape(-1, 3)
        uv = QUAD_UV.astype(np.float64)
        data = DracoPy.encode(
            QUAD_POSITIONS, faces, tex_coord=uv, preserve_order=True, quantization_bits=16
        )
        ids = {a["attribute_type"]: a["unique_id"] for a in DracoPy.decode(data).attributes}
        view = self.view(data)
        first = len(self.doc.accessors)
        box = {"min": [-1, -1, 0], "max": [1, 1, 0]}
        self.doc.accessors += [
            pygltflib.Accessor(componentType=FLOAT, count=4, type="VEC3", **box),
            pygltflib.Accessor(componentType=FLOAT, count=4, type="VEC2"),
            pygltflib.Accessor(componentType=USHORT, count=6, type="SCALAR"),
        ]
        # Draco's attribute types: 0 POSITION, 3 TEX_COORD.
        ext = {"bufferView": view, "attributes": {"POSITION": ids[0], "TEXCOORD_0": ids[3]}}
        attrs = pygltflib.Attributes(POSITION=first, TEXCOORD_0=first + 1)
        prim = pygltflib.Primitive(
            attributes=attrs, indices=first + 2, extensions={"KHR_draco_mesh_compression": ext}
        )
        self.node(mesh=self.mesh(prim))
        self.doc.extensionsUsed = self.doc.extensionsRequired = ["KHR_draco_mesh_compression"]
        return view

    def save(self, path: Path, buffer: str = "file") -> Path:
        """Write ``path`` (.glb: the buffer is its BIN chunk; .gltf: ``buffer`` "file"
        writes ``<stem>.bin`` beside it, "data" a data: URI)."""
        self.blob += b"\0" * (-len(self.blob) % 4)
        self.doc.scenes = [pygltflib.Scene(nodes=list(self.nodes))]
        self.doc.scene = 0
        data = bytes(self.blob)
        if path.suffix == ".glb":
            # Written here: pygltflib's save_binary repacks the buffer from the views,
            # dropping bytes only an extension's view (meshopt) points at.
            self.doc.buffers = [pygltflib.Buffer(byteLength=len(data))]
            text = self.doc.gltf_to_json(separators=(",", ":"), indent=None).encode()
            text += b" " * (-len(text) % 4)
            body = struct.pack("<II", len(text), 0x4E4F534A) + text
            body += struct.pack("<II", len(data), 0x004E4942) + data
            path.write_bytes(b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body)
        else:
            if buffer == "data":
                uri = "data:application/octet-stream;base64," + base64.b64encode(data).decode()
            else:
                uri = f"{path.stem}.bin"
                (path.parent / uri).write_bytes(data)
            self.doc.buffers = [pygltflib.Buffer(byteLength=len(data), uri=uri)]
            self.doc.save_json(str(path))
        return path


def png_rgb(rgb: tuple[int, int, int] | np.ndarray, size: int = 4) -> Image.Image:
    """A ``size`` x ``size`` image of one colour (or an (h, w, c) uint8 array)."""
    if isinstance(rgb, np.ndarray):
        return Image.fromarray(rgb)
    return Image.new("RGB", (size, size), tuple(rgb))
