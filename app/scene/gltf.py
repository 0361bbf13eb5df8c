"""The project's glTF 2.0 reader: every triangle primitive of the shown scene and its
material, read from the JSON and the buffers themselves (app/scene/gltf_document.py parses
and checks the JSON).

trimesh read glTF before: it passed material factors through 8 bits, dropped the normal,
occlusion and emissive maps, samplers, TEXCOORD_1, COLOR_0 and texture transforms, and
could not decode Draco or meshoptimizer. This module reads the file as the glTF 2.0
specification (Khronos, 2021) defines it and checks every index and byte range on the
way, so that a damaged file is one ``GltfError(json key, what)`` (the caller names the
scene and the object) and never another exception or a hang.

What is read (docs/scene-format.md, "Mesh files"):

- Geometry: each primitive of each mesh of each node of the shown scene, with the node's
  world matrix. Accessors of every component type (normalized integers included, as
  KHR_mesh_quantization allows), ``byteStride``, sparse accessors, buffers from the GLB
  BIN chunk, ``data:`` URIs or files; KHR_draco_mesh_compression (DracoPy) and
  EXT_meshopt_compression (the optional ``meshoptimizer`` package). Modes TRIANGLES,
  TRIANGLE_STRIP and TRIANGLE_FAN (the last two converted to triangles); points and lines
  are skipped.
- Attributes: POSITION, NORMAL (absent: flat normals, as the specification requires),
  TANGENT, TEXCOORD_0, TEXCOORD_1, COLOR_0. Texture coordinates are returned with v
  flipped (glTF's origin is the image's top left, the project's the bottom left); the
  tangent's w keeps its meaning (the file's bitangent points up the image in both).
- Materials -> ``SurfaceLayer`` at full float64 precision (``GltfFile.layer``).
- The pose (``PoseRequest``: an animation at a time, a KHR_materials_variants variant):
  animation channels sampled, node matrices recomputed, morph targets and skins applied
  to the decoded attributes in float64 (app/scene/gltf_animation.py), the variant's
  materials given to the primitives.
- Texture images by ``source``, EXT_texture_webp's WebP, or KHR_texture_basisu's
  fallback ``source`` (KTX2 is not decoded; one note per texture).

Untrusted input (docs/stability.md): the document is checked against glTF 2.0's schema
before it is read (app/scene/gltf_document.py); buffer and image URIs are confined to the
file's folder (app/untrusted/files.py); a primitive's declared vertex and index counts are
charged to the scene's ``Budget`` before one is decoded, and so is every buffer read and
image decoded; attribute values past ``MAX_COORDINATE`` are refused.
"""

from __future__ import annotations

import base64
import logging
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from types import SimpleNamespace
from typing import TYPE_CHECKING

import numpy as np
from PIL import Image, features

from app.common.extension_maps import EXTENSION_MAP
from app.common.material_checks import MAX_RADIANCE, material_problems
from app.common.models import MaterialParams
from app.scene import gltf_animation as animation
from app.scene.gltf_animation import PATHS, Pose, PoseRequest
from app.scene.gltf_document import GltfError, JsonObject, open_gltf, world_matrices
from app.scene.gltf_extensions import ExtensionTexture, map_material_extensions
from app.scene.gltf_schema import MAX_COORDINATE
from app.scene.sampled_levels import reduced_levels
from app.textures.lean import AUTO, LEAN, lean_params
from app.textures.maps import (
    SurfaceLayer,
    Texture,
    UvTransform,
    auto_normal_filter,
    channel_texture,
    coat_normal_texture,
    colour_texture,
    direction_texture,
    normal_roughness_map,
    open_image,
    prefetch_map,
    scalar_texture,
    slope_covariance_map,
    wait_decoded,
)
from app.untrusted import RefusedError, files
from app.untrusted.budget import Budget
from app.untrusted.policy import DEFAULT_POLICY, InputPolicy

if TYPE_CHECKING:
    from app.scene.model import FileMaterial

# Accessor componentType -> little-endian numpy type, and the divisor of a normalized
# integer (glTF 2.0 sec. 3.11: signed values are max(c / (2^(n-1) - 1), -1)).
_COMPONENTS: dict[int, tuple[str, float]] = {
    5120: ("<i1", 127.0),
    5121: ("<u1", 255.0),
    5122: ("<i2", 32767.0),
    5123: ("<u2", 65535.0),
    5125: ("<u4", 0.0),  # never normalized
    5126: ("<f4", 0.0),
}
_TYPES = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
# Which accessor types and component types each attribute may have (glTF 2.0 sec. 3.7.2.1,
# widened by KHR_mesh_quantization for positions, normals, tangents and texcoords).
_SEMANTICS: dict[str, tuple[tuple[str, ...], tuple[int, ...]]] = {
    "POSITION": (("VEC3",), (5126, 5120, 5121, 5122, 5123)),
    "NORMAL": (("VEC3",), (5126, 5120, 5122)),
    "TANGENT": (("VEC4",), (5126, 5120, 5122)),
    "TEXCOORD_0": (("VEC2",), (5126, 5120, 5121, 5122, 5123)),
    "TEXCOORD_1": (("VEC2",), (5126, 5120, 5121, 5122, 5123)),
    "COLOR_0": (("VEC3", "VEC4"), (5126, 5121, 5123)),
    "indices": (("SCALAR",), (5121, 5123, 5125)),
    # Skins and morph targets (sec. 3.7.3, 3.7.2.2; KHR_mesh_quantization's integer deltas).
    "JOINTS_0": (("VEC4",), (5121, 5123)),
    "JOINTS_1": (("VEC4",), (5121, 5123)),
    "WEIGHTS_0": (("VEC4",), (5126, 5121, 5123)),
    "WEIGHTS_1": (("VEC4",), (5126, 5121, 5123)),
    "target": (("VEC3",), (5126, 5120, 5121, 5122, 5123)),
    "inverseBindMatrices": (("MAT4",), (5126,)),
    # Animation samplers (sec. 3.11): keyframe times, and the output of each target path.
    "input": (("SCALAR",), (5126,)),
    "translation": (("VEC3",), (5126,)),
    "scale": (("VEC3",), (5126,)),
    "rotation": (("VEC4",), (5126, 5120, 5121, 5122, 5123)),
    "weights": (("SCALAR",), (5126, 5120, 5121, 5122, 5123)),
}
# Integer components of these must be normalized (JOINTS_n never are: they are indices).
_NORMALIZED = ("NORMAL", "TANGENT", "COLOR_0", "WEIGHTS_0", "WEIGHTS_1", "rotation", "weights")
_SKIN_SETS = (("JOINTS_0", "WEIGHTS_0"), ("JOINTS_1", "WEIGHTS_1"))
# Accessors of a pose (morph targets, skins, animations), charged to the budget as read.
_POSE_SEMANTICS = ("target", "inverseBindMatrices", "input", *PATHS)
_DRAWN = ("POSITION", "NORMAL", "TANGENT", "TEXCOORD_0", "TEXCOORD_1", "COLOR_0")
# Extensions read elsewhere or noted where they are met (the material extensions per
# material, KHR_texture_basisu per texture, KHR_lights_punctual by import_lights); any other
# the file uses gets one note that it is not read.
_READ_EXTENSIONS = (
    "KHR_draco_mesh_compression",
    "EXT_meshopt_compression",
    "KHR_mesh_quantization",
    "KHR_texture_transform",
    "KHR_lights_punctual",
    "KHR_materials_variants",
    "EXT_texture_webp",
    "KHR_texture_basisu",
)
_TRIANGLE_MODES = (4, 5, 6)  # TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN
_WRAP = {33071: "clamp", 33648: "mirror", 10497: "repeat"}
_FILTERS = {
    9728: "nearest",
    9729: "linear",
    9984: "nearest_mipmap_nearest",
    9985: "linear_mipmap_nearest",
    9986: "nearest_mipmap_linear",
    9987: "linear_mipmap_linear",
}
_MAG_FILTERS = (9728, 9729)
_FILTER_STRIDES = {"OCTAHEDRAL": (4, 8), "QUATERNION": (8,)}  # EXT_meshopt_compression
_LOG = logging.getLogger("pbs.gltf")  # notes on approximated extension parameters
# KHR_texture_transform's offset and scale: far past any tiling, small enough that a UV
# times it stays finite and meaningful in float32.
MAX_UV_TRANSFORM = 1e6


def meshopt_available() -> bool:
    """Whether the optional ``meshoptimizer`` package (pbs-lab[meshopt]) imports."""
    try:
        import meshoptimizer  # noqa: F401
    except ImportError:
        return False
    return True


@dataclass
class GltfPrimitive:
    """One triangle primitive, float64 arrays in the node's space, v flipped to the
    project's UV convention. ``tangents`` None: the file has none (derive them)."""

    key: str  # meshes[m].primitives[p], for errors
    positions: np.ndarray  # (N, 3)
    normals: np.ndarray  # (N, 3) unit
    faces: np.ndarray  # (M, 3) int64, each index < N
    world: np.ndarray  # (4, 4) node -> file root
    material: int | None
    uv: np.ndarray | None = None  # (N, 2)
    uv1: np.ndarray | None = None  # (N, 2)
    tangents: np.ndarray | None = None  # (N, 4): xyz unit, w = +-1
    colors: np.ndarray | None = None  # (N, 4) linear RGBA


@dataclass
class _Deform:
    """What poses a node's primitives: its morph weights (None: no targets) and its
    skin's joint matrices (None: not skinned)."""

    weights: np.ndarray | None = None
    joints: np.ndarray | None = None


def _int(value: object, key: str, count: int | None = None, low: int = 0) -> int:
    """``value`` as an index (``count``: the number of entries it may name) or a size."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise GltfError(key, f"must be an integer, not {value!r}")
    if value < low or (count is not None and value >= count):
        what = f"one of the {count}" if count is not None else f"at least {low}"
        raise GltfError(key, f"{value} is not {what}")
    return value


def _numbers(value: object, count: int, key: str, low: float = -math.inf, high: float = math.inf):
    """``count`` finite numbers in [low, high] as a float64 array."""
    if not isinstance(value, list | tuple) or len(value) != count:
        raise GltfError(key, f"must be {count} numbers")
    out = []
    for x in value:
        if isinstance(x, bool) or not isinstance(x, int | float) or not math.isfinite(x):
            raise GltfError(key, f"must be {count} finite numbers, not {value!r}")
        if not low <= x <= high:
            raise GltfError(key, f"{x} is outside [{low:g}, {high:g}]")
        out.append(float(x))
    return np.asarray(out, np.float64)


def _number(value: object, key: str, low: float = -math.inf, high: float = math.inf) -> float:
    return float(_numbers([value], 1, key, low, high)[0])


def _object(value: object, key: str) -> dict:
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise GltfError(key, "must be a JSON object")
    return value


class GltfFile:
    """A glTF/GLB opened and its buffers and images read on demand, each once."""

    def __init__(
        self,
        path: Path,
        policy: InputPolicy = DEFAULT_POLICY,
        budget: Budget | None = None,
        pose: PoseRequest | None = None,
        factors: Mapping[int, FileMaterial] | None = None,
    ) -> None:
        """``factors``: the scene's overrides of materials' factors by material index
        (``objects[i].file_materials``: app/scene/file_materials.py)."""
        self.path = path
        self.factors = dict(factors or {})
        self.policy = policy
        self.budget = budget or Budget(policy.limits)
        self.doc = open_gltf(path, policy)
        # The animation, time and variant shown (app/scene/gltf_animation.py).
        self.request = pose or PoseRequest()
        self._noted: set[str] = set()  # notes logged once per file
        self._buffers: dict[int, memoryview] = {}
        self._views: dict[int, memoryview] = {}
        self._accessors: dict[tuple[int, str], np.ndarray] = {}
        self._images: dict[tuple[int, bool], Image.Image] = {}  # by (index, reduced)
        self._layers: dict[tuple[int, str, int], SurfaceLayer] = {}
        # The UV levels of detail a still frame samples of this file's textures at its
        # visible pixels (app/scene/sampled_levels.py ``sampled_uv_lods``), set before any
        # material is read; None: every level (a camera that moves, the viewer, the API).
        self.uv_lods: np.ndarray | None = None

    def still_streamable(self) -> bool:
        """Whether a still frame's bound on the sampled levels (``uv_lods``) covers every
        read of this file's textures: every material opaque (its surfaces hide what lies
        behind them in the G-buffer and nothing is drawn forward, blended or through a
        masked shadow caster), none transmissive, every texture read through TEXCOORD_0
        untransformed (the bound is taken on TEXCOORD_0) and every sampler mipmapped
        (a sampler without mips reads level 0 at any distance). A file without images
        has no bound to take."""
        if not self._table("images") or "KHR_texture_transform" in (self.doc.extensionsUsed or []):
            return False
        for sampler in self._table("samplers"):
            if sampler.minFilter is not None and _FILTERS.get(sampler.minFilter) in (
                "nearest",
                "linear",
            ):
                return False
        forward = ("KHR_materials_transmission", "KHR_materials_volume")
        for material in self._table("materials"):
            if material.alphaMode not in (None, "OPAQUE"):
                return False
            extensions = material.extensions or {}
            if any(name in extensions for name in forward) or any(
                "diffuse_transmission" in name for name in extensions
            ):
                return False
            if _reads_moved_uv(material):
                return False
        return True

    def _reduction(self, width: int, height: int) -> int:
        """How many finest levels of a ``width`` x ``height`` image a still frame never
        samples (0 without a still frame's ``uv_lods``)."""
        if self.uv_lods is None:
            return 0
        return reduced_levels(self.uv_lods, width, height)

    def _first_level(self, image: Image.Image) -> int:
        """The first level a map the project filters from ``image`` (decoded whole) keeps."""
        return self._reduction(image.width, image.height)

    # --- bytes -------------------------------------------------------------------------

    def _table(self, name: str) -> list:
        return getattr(self.doc, name) or []

    def _uri_bytes(self, uri: object, key: str) -> bytes:
        if not isinstance(uri, str):
            raise GltfError(key, "must be a string")
        if uri.startswith("data:"):
            head, sep, data = uri.partition(",")
            if not sep or not head.endswith(";base64"):
                raise GltfError(key, "a data: URI must be base64")
            try:
                return base64.b64decode(data, validate=True)
            except ValueError:
                raise GltfError(key, "a data: URI that is not valid base64") from None
        try:
            file = files.confine_uri(uri, self.path, self.policy)
            data = files.read_bytes(file, self.policy.limits.max_file_bytes)
        except RefusedError as exc:
            raise GltfError(key, str(exc)) from None
        return data

    def _charge(self, units: int, kind: str, key: str, what: str) -> None:
        """Charge the scene's budget for what ``key`` is about to make."""
        try:
            self.budget.charge(units, kind, what)
        except RefusedError as exc:
            raise GltfError(key, str(exc)) from None

    def buffer(self, index: int, key: str) -> memoryview:
        buffers = self._table("buffers")
        i = _int(index, key, len(buffers))
        if i not in self._buffers:
            entry = buffers[i]
            if entry.uri is None:  # the GLB's BIN chunk (only buffers[0] may use it)
                blob = self.doc.binary_blob() if i == 0 else None
                if blob is None:
                    raise GltfError(f"buffers[{i}]", "has no uri and the file no BIN chunk")
                data = bytes(blob)
            else:
                data = self._uri_bytes(entry.uri, f"buffers[{i}].uri")
            length = _int(entry.byteLength, f"buffers[{i}].byteLength", low=1)
            if len(data) < length:
                raise GltfError(f"buffers[{i}].byteLength", f"{length}: the data is shorter")
            self._charge(length, "byte", f"buffers[{i}]", f"a buffer of {length} bytes")
            self._buffers[i] = memoryview(data)[:length]
        return self._buffers[i]

    def view(self, index: int, key: str) -> memoryview:
        """A bufferView's bytes (decompressed where EXT_meshopt_compression packs them)."""
        views = self._table("bufferViews")
        i = _int(index, key, len(views))
        if i not in self._views:
            v = views[i]
            vkey = f"bufferViews[{i}]"
            meshopt = (v.extensions or {}).get("EXT_meshopt_compression")
            if meshopt is not None:
                self._views[i] = memoryview(self._meshopt(_object(meshopt, vkey), vkey))
            else:
                data = self.buffer(v.buffer, f"{vkey}.buffer")
                self._views[i] = _slice(data, v.byteOffset or 0, v.byteLength, vkey)
        return self._views[i]

    def _meshopt(self, ext: dict, vkey: str) -> bytes:
        """EXT_meshopt_compression: decode the compressed bytes of a view (its own
        ``buffer`` is then a fallback that may hold nothing)."""
        key = f"{vkey}.extensions.EXT_meshopt_compression"
        if not meshopt_available():
            raise GltfError(
                key,
                "the file uses EXT_meshopt_compression, which needs the meshoptimizer "
                "package: pip install 'pbs-lab[meshopt]'",
            )
        import meshoptimizer

        data = self.buffer(ext.get("buffer"), f"{key}.buffer")
        source = _slice(data, ext.get("byteOffset", 0), ext.get("byteLength"), key)
        count = _int(ext.get("count"), f"{key}.count", low=1)
        stride = _int(ext.get("byteStride"), f"{key}.byteStride", low=1)
        mode = ext.get("mode")
        filt = ext.get("filter", "NONE")
        # The decoded view is count x stride bytes (4-byte indices at most twice that).
        self._charge(count * max(stride, 4) * 2, "byte", key, f"{count} elements decoded")
        source = bytes(source)
        try:
            if mode == "ATTRIBUTES":
                if stride % 4 or stride > 256:
                    raise GltfError(f"{key}.byteStride", "must be a multiple of 4 up to 256")
                out = meshoptimizer.decode_vertex_buffer(count, stride, source)
                raw = np.frombuffer(out.tobytes(), np.uint8).copy()
                decode = {
                    "NONE": None,
                    "OCTAHEDRAL": meshoptimizer.decode_filter_oct,
                    "QUATERNION": meshoptimizer.decode_filter_quat,
                    "EXPONENTIAL": meshoptimizer.decode_filter_exp,
                }
                if filt not in decode:
                    raise GltfError(f"{key}.filter", f"unknown filter {filt!r}")
                # The strides the extension allows per filter (the C filters assert them).
                if stride not in _FILTER_STRIDES.get(filt, (stride,)):
                    raise GltfError(f"{key}.byteStride", f"{stride} cannot use filter {filt}")
                if decode[filt] is not None:
                    raw = decode[filt](raw, count, stride)
                return raw.tobytes()
            if mode in ("TRIANGLES", "INDICES"):
                if stride not in (2, 4):
                    raise GltfError(f"{key}.byteStride", "must be 2 or 4 for indices")
                # Decoded as 4-byte indices whatever the stride: the C decoder's
                # index_size is the width it writes, and the package's wrapper always
                # hands it a uint32 array (2 would fill only half of it).
                if mode == "TRIANGLES":
                    if count % 3:
                        raise GltfError(f"{key}.count", "must be a multiple of 3")
                    out = meshoptimizer.decode_index_buffer(count, 4, source)
                else:
                    out = meshoptimizer.decode_index_sequence(count, 4, source)
                if stride == 2 and len(out) and int(out.max()) > 0xFFFF:
                    raise GltfError(key, "decodes to indices past 65535 in 2-byte indices")
                return np.asarray(out, "<u2" if stride == 2 else "<u4").tobytes()
        except (RuntimeError, ValueError) as exc:
            raise GltfError(key, f"cannot be decoded ({exc})") from None
        raise GltfError(f"{key}.mode", f"unknown mode {mode!r}")

    # --- accessors ---------------------------------------------------------------------

    def accessor(self, index: int, key: str, semantic: str) -> np.ndarray:
        """Accessor ``index`` as (count, components): float64 for attributes (normalized
        integers scaled to [0, 1] or [-1, 1]), int64 for indices; read once per semantic
        (a mesh that several nodes show is decoded once)."""
        i = _int(index, key, len(self._table("accessors")))
        if (i, semantic) not in self._accessors:
            if semantic in _POSE_SEMANTICS:  # not charged with a primitive's vertices
                a = self._table("accessors")[i]
                count = _int(a.count, f"accessors[{i}].count", low=1)
                size = count * _TYPES.get(a.type, 16) * 8  # float64 values
                self._charge(size, "byte", f"accessors[{i}]", f"{count} {semantic} values")
            self._accessors[(i, semantic)] = self._accessor(i, semantic)
        return self._accessors[(i, semantic)]

    def accessor_count(self, index: object, key: str, semantic: str) -> int:
        """Accessor ``index``'s count, the accessor checked as ``semantic`` from the JSON
        alone (an index in range, a type and componentType the semantic allows, integers
        normalized where they must be): what ``accessor`` would refuse before reading a
        byte, in its words, for data the rest pose checks but does not read."""
        i = _int(index, key, len(self._table("accessors")))
        return self._accessor_checked(i, semantic)

    def _accessor_checked(self, i: int, semantic: str) -> int:
        a = self._table("accessors")[i]
        akey = f"accessors[{i}]"
        types, components = _SEMANTICS[semantic]
        if a.type not in types or a.componentType not in components:
            raise GltfError(
                akey,
                f"{a.type} of componentType {a.componentType} cannot be {semantic} "
                f"(allowed: {'/'.join(types)} of {', '.join(map(str, components))})",
            )
        count = _int(a.count, f"{akey}.count", low=1)
        if semantic != "indices":
            if a.normalized and not _COMPONENTS[a.componentType][1]:
                raise GltfError(f"{akey}.normalized", "only integer components are normalized")
            if not a.normalized and a.componentType != 5126 and semantic in _NORMALIZED:
                raise GltfError(f"{akey}.normalized", f"integer {semantic} must be normalized")
        return count

    def _accessor(self, i: int, semantic: str) -> np.ndarray:
        a = self._table("accessors")[i]
        akey = f"accessors[{i}]"
        count = self._accessor_checked(i, semantic)
        n = _TYPES[a.type]
        dtype, divisor = _COMPONENTS[a.componentType]
        if a.bufferView is None:
            values = np.zeros((count, n), dtype)
        else:
            values = self._strided(a.bufferView, a.byteOffset or 0, count, n, dtype, akey)
        if a.sparse is not None:
            values = self._sparse(a.sparse, values, n, dtype, akey)
        if semantic == "indices":
            return values[:, 0].astype(np.int64)
        out = values.astype(np.float64)
        if a.normalized:
            out = np.maximum(out / divisor, -1.0)
        if not np.all(np.abs(out) <= MAX_COORDINATE):  # NaN and infinities fail too
            raise GltfError(
                akey, f"{semantic} holds NaN, infinite or values past {MAX_COORDINATE:g}"
            )
        return out

    def _strided(
        self, view_index: object, offset: object, count: int, n: int, dtype: str, akey: str
    ) -> np.ndarray:
        views = self._table("bufferViews")
        v = _int(view_index, f"{akey}.bufferView", len(views))
        data = self.view(v, f"{akey}.bufferView")
        item = np.dtype(dtype).itemsize
        size = item * n
        stride_value = views[v].byteStride
        stride = (
            size if stride_value is None else _int(stride_value, f"bufferViews[{v}].byteStride")
        )
        if stride < size:
            raise GltfError(f"bufferViews[{v}].byteStride", f"{stride} is less than {size} bytes")
        start = _int(offset, f"{akey}.byteOffset")
        end = start + stride * (count - 1) + size
        if end > len(data):
            raise GltfError(
                akey,
                f"{count} elements need {end} bytes of bufferViews[{v}], which has {len(data)}",
            )
        raw = np.ndarray((count, n), np.dtype(dtype), data, start, (stride, item))
        return raw.copy()

    def _sparse(
        self, sparse: JsonObject, values: np.ndarray, n: int, dtype: str, akey: str
    ) -> np.ndarray:
        skey = f"{akey}.sparse"
        count = _int(sparse.count, f"{skey}.count", low=1)
        if count > len(values):
            raise GltfError(f"{skey}.count", f"{count} is more than the accessor's {len(values)}")
        idx, vals = sparse.indices, sparse.values
        if idx is None or vals is None:
            raise GltfError(skey, "needs indices and values")
        if idx.componentType not in (5121, 5123, 5125):
            raise GltfError(f"{skey}.indices.componentType", f"{idx.componentType} is not allowed")
        ikey = f"{skey}.indices"
        where = self._strided(
            idx.bufferView, idx.byteOffset or 0, count, 1, _COMPONENTS[idx.componentType][0], ikey
        )[:, 0].astype(np.int64)
        if np.any(where >= len(values)):
            raise GltfError(ikey, f"an index is not below the accessor's count {len(values)}")
        new = self._strided(
            vals.bufferView, vals.byteOffset or 0, count, n, dtype, f"{skey}.values"
        )
        out = values.copy()
        out[where] = new
        return out

    # --- geometry ----------------------------------------------------------------------

    def note(self, text: str) -> None:
        """Log ``text`` about this file once (a note of what is approximated or left out)."""
        if text not in self._noted:
            self._noted.add(text)
            _LOG.warning("%s: %s", self.path, text)

    def pose(self) -> Pose:
        """The pose ``request`` asks for (app/scene/gltf_animation.py), its notes logged."""
        pose = animation.posed(self.doc, self.request, self)
        for text in pose.notes:
            self.note(text)
        return pose

    def primitives(self) -> list[GltfPrimitive]:
        """Every triangle primitive of every node of the shown scene, posed: the chosen
        animation at the chosen time (else the rest pose), morph targets and skins
        applied, each primitive with the chosen variant's material."""
        meshes = self._table("meshes")
        for name in self.doc.extensionsUsed or []:
            if name not in _READ_EXTENSIONS and not name.startswith("KHR_materials_"):
                self.note(f"uses the extension {name}, which pbs does not read (ignored)")
        pose = self.pose()
        notes: list[str] = []
        variant = animation.choose_variant(self.doc, self.request.variant, notes)
        variants = len(animation.variant_names(self.doc))
        for text in notes:
            self.note(text)
        worlds = world_matrices(self.doc, self.policy.limits.max_node_depth, pose.local)
        out = []
        for node_index, world in worlds.items():
            node = self.doc.nodes[node_index]
            if node.mesh is None:
                continue
            m = _int(node.mesh, f"nodes[{node_index}].mesh", len(meshes))
            if not np.all(np.isfinite(world)):  # finite factors whose product overflows
                raise GltfError(f"nodes[{node_index}]", "its world matrix is not finite")
            deform = _Deform()
            targets = animation.target_count(self.doc, node_index)
            deform.weights = animation.morph_weights(self.doc, node_index, m, targets, pose)
            if node.skin is not None:
                skins = self._table("skins")
                skin = _int(node.skin, f"nodes[{node_index}].skin", len(skins))
                deform.joints = animation.joint_matrices(self.doc, skin, worlds, self.accessor)
            for p, prim in enumerate(meshes[m].primitives or []):
                key = f"meshes[{m}].primitives[{p}]"
                material = prim.material
                if variant is not None:
                    chosen = animation.variant_material(
                        prim, key, variant, variants, len(self._table("materials"))
                    )
                    material = material if chosen is None else chosen
                part = self._primitive(prim, key, world, deform, material)
                if part is not None:
                    out.append(part)
        return out

    def _declared(self, prim: JsonObject, key: str) -> tuple[int, int]:
        """(vertices, indices) a primitive's accessors declare, every attribute's count
        equal to POSITION's: known from the JSON before a byte is decoded."""
        accessors = self._table("accessors")

        def count(index: object, where: str) -> int:
            return accessors[_int(index, where, len(accessors))].count

        if prim.attributes.POSITION is None:
            raise GltfError(f"{key}.attributes", "has no POSITION")
        vertices = count(prim.attributes.POSITION, f"{key}.attributes.POSITION")
        for name in (*_DRAWN[1:], *(n for pair in _SKIN_SETS for n in pair)):
            index = prim.attributes.get(name)
            if index is not None and (n := count(index, f"{key}.attributes.{name}")) != vertices:
                raise GltfError(
                    f"{key}.attributes.{name}", f"{n} elements, POSITION has {vertices}"
                )
        indices = vertices if prim.indices is None else count(prim.indices, f"{key}.indices")
        return vertices, indices

    def _primitive(
        self,
        prim: JsonObject,
        key: str,
        world: np.ndarray,
        deform: _Deform | None = None,
        material_index: object = None,
    ) -> GltfPrimitive | None:
        """One primitive decoded, posed by ``deform`` (its node's morph weights and joint
        matrices), with material ``material_index`` (the variant's or its own)."""
        mode = _int(prim.mode if prim.mode is not None else 4, f"{key}.mode")
        if mode not in _TRIANGLE_MODES:
            if mode > 6:
                raise GltfError(f"{key}.mode", f"{mode} is not a glTF primitive mode")
            return None  # points and lines: nothing the G-buffer can draw
        materials = self._table("materials")
        material = None
        if material_index is not None:
            material = _int(material_index, f"{key}.material", len(materials))
        vertices, index_count = self._declared(prim, key)
        triangles = index_count // 3 if mode == 4 else max(index_count - 2, 0)
        # Without NORMAL every triangle gets three vertices of its own (flat normals).
        built = vertices if prim.attributes.NORMAL is not None else 3 * triangles
        try:  # before anything of that size is decoded (a Draco stream must match them)
            what = f"{max(vertices, built)} vertices and {triangles} triangles"
            self.budget.mesh(max(vertices, built), triangles, what)
        except RefusedError as exc:
            raise GltfError(key, str(exc)) from None
        draco = (prim.extensions or {}).get("KHR_draco_mesh_compression")
        if draco is not None:
            attrs, indices = self._draco(prim, _object(draco, key), key)
            decoded = len(attrs["POSITION"]) if "POSITION" in attrs else 0
            if decoded > vertices or len(indices) > index_count:
                raise GltfError(
                    f"{key}.extensions.KHR_draco_mesh_compression",
                    "decodes to more vertices or indices than its accessors declare",
                )
        else:
            attrs = {}
            skinned = deform is not None and deform.joints is not None
            names = (*_DRAWN, *(n for pair in _SKIN_SETS for n in pair)) if skinned else _DRAWN
            for name in names:
                index = getattr(prim.attributes, name, None)
                if index is not None:
                    attrs[name] = self.accessor(index, f"{key}.attributes.{name}", name)
            indices = None
            if prim.indices is not None:
                indices = self.accessor(prim.indices, f"{key}.indices", "indices")
        if "POSITION" not in attrs:
            raise GltfError(f"{key}.attributes", "has no POSITION")
        count = len(attrs["POSITION"])
        for name, values in attrs.items():
            if len(values) != count:
                raise GltfError(
                    f"{key}.attributes.{name}", f"{len(values)} elements, POSITION has {count}"
                )
        if indices is None:
            indices = np.arange(count, dtype=np.int64)
        elif len(indices) and int(indices.max()) >= count:
            raise GltfError(f"{key}.indices", f"an index is not below the {count} vertices")
        faces = _triangles(indices, mode)
        if not len(faces):
            return None
        if deform is not None:
            attrs, world = self._deform(prim, key, attrs, world, deform, draco is not None)
        return _assemble(key, attrs, faces, world, material)

    def _deform(
        self,
        prim: JsonObject,
        key: str,
        attrs: dict[str, np.ndarray],
        world: np.ndarray,
        deform: _Deform,
        draco: bool,
    ) -> tuple[dict[str, np.ndarray], np.ndarray]:
        """The primitive's attributes with its morph targets (weighted) and its skin
        applied (app/scene/gltf_animation.py), and the matrix they are drawn under (the
        identity once skinned: skinned vertices are in the file's root space)."""
        targets = prim.targets or []
        if targets and deform.weights is not None:
            if len(deform.weights) != len(targets):
                raise GltfError(
                    f"{key}.targets", f"{len(targets)} targets for {len(deform.weights)} weights"
                )
            if draco:  # Draco may reorder vertices; the targets' accessors are not
                self.note(f"{key}: morph targets on a Draco primitive are not applied")
            else:
                # Checked from the JSON whatever the weights; read only where one is not 0.
                applied = bool(np.any(deform.weights != 0.0))
                count = len(attrs["POSITION"])
                deltas = []
                for t, target in enumerate(targets):
                    delta = {}
                    for name in ("POSITION", "NORMAL", "TANGENT"):
                        index = target.get(name)
                        if index is None or name not in attrs:
                            continue
                        tkey = f"{key}.targets[{t}].{name}"
                        elements = self.accessor_count(index, tkey, "target")
                        if elements != count:
                            raise GltfError(tkey, f"{elements} elements, POSITION has {count}")
                        if applied:
                            delta[name] = self.accessor(index, tkey, "target")
                    deltas.append(delta)
                if applied:
                    attrs = animation.morph(attrs, deltas, deform.weights)
        if deform.joints is None or "JOINTS_0" not in attrs or "WEIGHTS_0" not in attrs:
            return attrs, world
        sets = []
        for joints_name, weights_name in _SKIN_SETS:
            if joints_name not in attrs or weights_name not in attrs:
                continue
            joints = attrs.pop(joints_name)
            weights = attrs.pop(weights_name)
            if len(joints) and not 0 <= int(joints.max()) < len(deform.joints):
                raise GltfError(
                    f"{key}.attributes.{joints_name}",
                    f"joint {int(joints.max())} is not one of the skin's {len(deform.joints)}",
                )
            if len(joints) and int(joints.min()) < 0:
                raise GltfError(f"{key}.attributes.{joints_name}", "a joint index is negative")
            sets.append((joints.astype(np.int64), weights))
        return animation.skin(attrs, sets, deform.joints), np.eye(4)

    def _draco(
        self, prim: JsonObject, ext: dict, key: str
    ) -> tuple[dict[str, np.ndarray], np.ndarray]:
        """KHR_draco_mesh_compression: the attributes the extension maps to Draco ids,
        decoded by DracoPy; accessors keep only their type and ``normalized``."""
        import DracoPy

        ekey = f"{key}.extensions.KHR_draco_mesh_compression"
        data = self.view(ext.get("bufferView"), f"{ekey}.bufferView")
        try:
            mesh = DracoPy.decode(bytes(data))
        except Exception as exc:  # DracoPy raises its own and plain Exceptions
            raise GltfError(ekey, f"cannot be decoded ({type(exc).__name__}: {exc})") from None
        faces = np.asarray(getattr(mesh, "faces", np.zeros((0, 3))), np.int64).reshape(-1)
        ids = _object(ext.get("attributes"), f"{ekey}.attributes")
        attrs: dict[str, np.ndarray] = {}
        accessors = self._table("accessors")
        for name, unique_id in ids.items():
            if name not in _SEMANTICS or name == "indices":
                continue  # JOINTS_0, WEIGHTS_0, ...: not drawn
            akey = f"{ekey}.attributes.{name}"
            attribute = mesh.get_attribute_by_unique_id(_int(unique_id, akey))
            if attribute is None:
                raise GltfError(akey, f"Draco data has no attribute {unique_id}")
            values = np.asarray(attribute.get("data"))
            if values.ndim == 1:
                values = values[:, None]
            widths = {_TYPES[t] for t in _SEMANTICS[name][0]}
            if values.ndim != 2 or values.shape[1] not in widths or values.dtype.kind not in "iuf":
                raise GltfError(akey, f"Draco attribute {unique_id} is not a {name}")
            values = values.astype(np.float64)
            a_index = getattr(prim.attributes, name, None)
            if a_index is not None:
                a = accessors[_int(a_index, f"{key}.attributes.{name}", len(accessors))]
                divisor = _COMPONENTS.get(a.componentType, ("", 0.0))[1]
                if a.normalized and divisor:
                    values = np.maximum(values / divisor, -1.0)
            if not np.all(np.abs(values) <= MAX_COORDINATE):  # NaN and infinities fail too
                raise GltfError(
                    akey, f"{name} holds NaN, infinite or values past {MAX_COORDINATE:g}"
                )
            attrs[name] = values
        return attrs, faces

    # --- materials ---------------------------------------------------------------------

    def double_sided(self, material: int | None) -> bool:
        """glTF ``doubleSided`` (false by default, also for the default material)."""
        if material is None:
            return False
        return bool(self._table("materials")[material].doubleSided)

    def image(self, index: object, key: str, reduced: bool = False) -> Image.Image:
        """Image ``index`` decoded once (its size checked and charged first,
        app/textures/maps.py ``open_image``). ``reduced``: for a map whose mips the GL
        makes (colour), decoded from the finest level a still frame samples (``uv_lods``;
        a JPEG by DCT scaling); the maps the project filters (the normal/roughness chain,
        metallic, occlusion) read the whole image and keep their levels from there on
        (``_first_level``), the same bits as the whole chain's."""
        images = self._table("images")
        i = _int(index, key, len(images))
        reduced = reduced and self.uv_lods is not None
        if (i, reduced) not in self._images:
            entry = images[i]
            ikey = f"images[{i}]"
            if entry.uri is not None:
                data = self._uri_bytes(entry.uri, f"{ikey}.uri")
            elif entry.bufferView is not None:
                data = bytes(self.view(entry.bufferView, f"{ikey}.bufferView"))
            else:
                raise GltfError(ikey, "has neither uri nor bufferView")
            try:
                reduce = self._reduction if reduced else None
                self._images[i, reduced] = open_image(
                    data, self.budget, None, decode_later=True, reduce=reduce
                )
            except RefusedError as exc:
                raise GltfError(ikey, str(exc)) from None
        return self._images[i, reduced]

    def _decodes_checked(self) -> None:
        """Wait for the decodes of the images opened so far (``image`` starts each on a
        pool, so that a material's images decode side by side); the first broken one,
        in the order they were opened, as the ``GltfError`` naming its key that opening
        it would have raised."""
        for (i, _), image in self._images.items():
            try:
                wait_decoded(image)
            except RefusedError as exc:
                raise GltfError(f"images[{i}]", str(exc)) from None

    def _source(self, tex: JsonObject, tkey: str) -> tuple[object, str]:
        """The image a texture reads and its JSON key: EXT_texture_webp's WebP image
        (Pillow decodes it), else ``source``; KHR_texture_basisu's KTX2 image is not
        decoded (no maintained decoder installs from PyPI here), so its PNG/JPEG
        fallback ``source`` is read, with one note per texture."""
        extensions = _object(tex.extensions, f"{tkey}.extensions")
        webp = extensions.get("EXT_texture_webp")
        if webp is not None and features.check("webp"):
            wkey = f"{tkey}.extensions.EXT_texture_webp"
            return _object(webp, wkey).get("source"), f"{wkey}.source"
        if webp is not None:
            self.note(f"{tkey}: this Pillow decodes no WebP; its fallback source is read")
        if "KHR_texture_basisu" in extensions:
            if tex.source is None:
                raise GltfError(
                    f"{tkey}.source",
                    "is missing: its KHR_texture_basisu (KTX2) image is not decoded by pbs "
                    "and the file gives no PNG or JPEG fallback",
                )
            self.note(
                f"{tkey}: its KHR_texture_basisu (KTX2) image is not decoded; the fallback "
                f"images[{tex.source}] is used"
            )
        if tex.source is None:
            raise GltfError(f"{tkey}.source", "is missing")
        return tex.source, f"{tkey}.source"

    def _map_cost(self, image: Image.Image, kind: str, key: str) -> None:
        """Charge the map of ``kind`` about to be built from ``image``."""
        try:
            self.budget.texture(image.width, image.height, kind, f"{key}'s map")
        except RefusedError as exc:
            raise GltfError(key, str(exc)) from None

    def _texture(
        self, info: object, key: str, reduced: bool = False
    ) -> tuple[Image.Image, dict, UvTransform]:
        """A textureInfo: its image (``reduced``: as ``image``), its sampler's Texture
        fields, its UV transform."""
        textures = self._table("textures")
        t = _int(getattr(info, "index", None), f"{key}.index", len(textures))
        tex = textures[t]
        tkey = f"textures[{t}]"
        source, skey = self._source(tex, tkey)
        image = self.image(source, skey, reduced)
        sampler: dict = {}
        if tex.sampler is not None:
            samplers = self._table("samplers")
            s = samplers[_int(tex.sampler, f"{tkey}.sampler", len(samplers))]
            skey = f"samplers[{tex.sampler}]"
            wrap = []
            for name in ("wrapS", "wrapT"):
                value = getattr(s, name, None)
                value = 10497 if value is None else value
                if value not in _WRAP:
                    raise GltfError(f"{skey}.{name}", f"{value} is not a glTF wrap mode")
                wrap.append(_WRAP[value])
            sampler["wrap"] = (wrap[0], wrap[1])
            if s.minFilter is not None:
                if s.minFilter not in _FILTERS:
                    raise GltfError(f"{skey}.minFilter", f"{s.minFilter} is not a glTF filter")
                sampler["min_filter"] = _FILTERS[s.minFilter]
            if s.magFilter is not None:
                if s.magFilter not in _MAG_FILTERS:
                    raise GltfError(f"{skey}.magFilter", f"{s.magFilter} is not a glTF filter")
                sampler["mag_filter"] = _FILTERS[s.magFilter]
        uv_set = _int(getattr(info, "texCoord", 0) or 0, f"{key}.texCoord")
        transform = UvTransform(uv_set=uv_set)
        ext = (getattr(info, "extensions", None) or {}).get("KHR_texture_transform")
        if ext is not None:
            ekey = f"{key}.extensions.KHR_texture_transform"
            ext = _object(ext, ekey)
            bound = MAX_UV_TRANSFORM
            offset = _numbers(ext.get("offset", [0.0, 0.0]), 2, f"{ekey}.offset", -bound, bound)
            scale = _numbers(ext.get("scale", [1.0, 1.0]), 2, f"{ekey}.scale", -bound, bound)
            # Any finite angle, taken modulo a turn (in float64, before float32 sees it).
            rotation = math.remainder(
                _number(ext.get("rotation", 0.0), f"{ekey}.rotation"), math.tau
            )
            if "texCoord" in ext:
                uv_set = _int(ext["texCoord"], f"{ekey}.texCoord")
            transform = UvTransform(uv_set, (offset[0], offset[1]), rotation, (scale[0], scale[1]))
        if uv_set > 1:
            raise GltfError(
                f"{key}.texCoord", f"TEXCOORD_{uv_set}: only TEXCOORD_0 and _1 are read"
            )
        return image, sampler, transform

    def layer(
        self, material: int | None, fallback: MaterialParams, normal_filter: str
    ) -> SurfaceLayer:
        """Material ``material`` (None: the project's default ``fallback``) as a layer."""
        if material is None:
            return SurfaceLayer(fallback)
        cache_key = (material, normal_filter, id(fallback))
        if cache_key not in self._layers:
            try:
                layer = self._layer(material, fallback, normal_filter)
            except (GltfError, RefusedError):
                self._decodes_checked()  # a broken image opened before the problem first
                raise
            self._decodes_checked()
            self._layers[cache_key] = layer
        return self._layers[cache_key]

    def _layer(self, index: int, fallback: MaterialParams, normal_filter: str) -> SurfaceLayer:
        m = self._table("materials")[index]
        key = f"materials[{index}]"
        pbr = m.pbrMetallicRoughness
        pkey = f"{key}.pbrMetallicRoughness"
        factor = np.ones(4)
        metallic = roughness = 1.0  # glTF 2.0's defaults
        if pbr is not None:
            if pbr.baseColorFactor is not None:
                factor = _numbers(pbr.baseColorFactor, 4, f"{pkey}.baseColorFactor", 0.0, 1.0)
            if pbr.metallicFactor is not None:
                metallic = _number(pbr.metallicFactor, f"{pkey}.metallicFactor", 0.0, 1.0)
            if pbr.roughnessFactor is not None:
                roughness = _number(pbr.roughnessFactor, f"{pkey}.roughnessFactor", 0.0, 1.0)
        override = self.factors.get(index)  # the scene's, read in the file's place
        if override is not None:
            factor, metallic, roughness = override.pbr(factor, metallic, roughness)
        params = MaterialParams(
            base_color=(float(factor[0]), float(factor[1]), float(factor[2])),
            metallic=metallic,
            roughness=roughness,
            f0=fallback.f0,
        )
        extensions = _object(m.extensions, f"{key}.extensions")
        mapping = map_material_extensions(extensions, params, key)
        params = mapping.params
        for note in mapping.notes:  # what the project approximates or leaves out
            _LOG.warning("%s: %s", self.path, note)
        maps: dict[str, Texture] = {}
        transforms: dict[str, UvTransform] = {}
        # Each map in the material's order, made now or, a colour map, once every image of
        # the material is open (``made``): its texels wait for its decode and its mips are
        # made on this thread, while the images opened after it (the normal and
        # metallic-roughness maps the chain waits for) would not yet be decoding.
        entries: list[tuple[str, MapMaker, dict, UvTransform]] = []

        def put(name: str, texture: MapMaker, sampler: dict, transform: UvTransform) -> None:
            entries.append((name, texture, sampler, transform))
            if isinstance(texture, Texture):
                # A prepared map is made on the cache's background thread from now on,
                # while the material's other images are decoded and the parts built.
                prefetch_map(texture)

        def made() -> None:
            for name, texture, sampler, transform in entries:
                texture = texture if isinstance(texture, Texture) else texture()
                for attr, value in sampler.items():
                    setattr(texture, attr, value)
                maps[name] = texture
                if not transform.identity:
                    transforms[name] = transform
            entries.clear()

        if pbr is not None and pbr.baseColorTexture is not None:
            tkey = f"{pkey}.baseColorTexture"
            img, sampler, tr = self._texture(pbr.baseColorTexture, tkey, reduced=True)
            self._map_cost(img, "colour", tkey)
            first = self._first_level(img)  # a whole image's (a JPEG is decoded reduced)
            put("base_color", partial(colour_texture, img, first), sampler, tr)  # RGBA kept
        mr = None
        if pbr is not None and pbr.metallicRoughnessTexture is not None:
            tkey = f"{pkey}.metallicRoughnessTexture"
            mr = self._texture(pbr.metallicRoughnessTexture, tkey)
            # Roughness joins the normal chain: built at the normal map's size where there
            # is one (charged with it), else at this image's.
            self._map_cost(mr[0], "scalar" if m.normalTexture is not None else "normal", tkey)
            put("metallic", channel_texture(mr[0], 2, self._first_level(mr[0])), mr[1], mr[2])
        normal_image = None
        scale = 1.0
        if m.normalTexture is not None:
            nkey = f"{key}.normalTexture"
            img, n_sampler, n_tr = self._texture(m.normalTexture, nkey)
            self._map_cost(img, "normal", nkey)
            scale = getattr(m.normalTexture, "scale", None)
            # Bounded so that scaled x and y cannot overflow float64 (the map's normals
            # are already flat to the eye past a few hundred).
            scale = 1.0 if scale is None else _number(scale, f"{nkey}.scale", -1e3, 1e3)
            normal_image = img
        if normal_image is not None or mr is not None:
            # One chain for normals and roughness (app/textures/mips.py): built at the normal
            # map's size with its sampler and UVs where there is one (the roughness image is
            # resampled to it), else at the metallic-roughness image's.
            # (Prepared once per image content: app/textures/cache.py.)
            mr_image = None if mr is None else mr[0]
            sized = normal_image if normal_image is not None else mr_image
            assert sized is not None
            first = self._first_level(sized)
            if normal_filter == AUTO:  # lean where the normals' spread keeps a direction
                normal_filter = "variance"
                if normal_image is not None:
                    normal_filter = auto_normal_filter(normal_image, scale)
            chain = normal_roughness_map(
                normal_image, scale, roughness, mr_image, normal_filter, first
            )
            if normal_image is not None:
                put("normal_roughness", chain, n_sampler, n_tr)
                if normal_filter == LEAN:  # the normals' spread as a covariance map, read
                    # through the normal map's UVs (app/textures/lean.py)
                    self._map_cost(normal_image, "normal", nkey)  # charged as one more
                    covariance = slope_covariance_map(normal_image, scale)
                    put("slope_covariance", covariance, n_sampler, UvTransform())
                    params = lean_params(params)
            else:
                assert mr is not None
                put("normal_roughness", chain, mr[1], mr[2])
        layer = SurfaceLayer(params, maps, normal_mapped=normal_image is not None)
        if m.occlusionTexture is not None:
            okey = f"{key}.occlusionTexture"
            img, sampler, tr = self._texture(m.occlusionTexture, okey)
            self._map_cost(img, "scalar", okey)
            put("occlusion", channel_texture(img, 0, self._first_level(img)), sampler, tr)
            strength = getattr(m.occlusionTexture, "strength", None)
            layer.occlusion_strength = (
                1.0 if strength is None else _number(strength, f"{okey}.strength", 0.0, 1.0)
            )
        emissive_factor = np.zeros(3)
        if m.emissiveFactor is not None:
            emissive_factor = _numbers(m.emissiveFactor, 3, f"{key}.emissiveFactor", 0.0, 1.0)
        strength = 1.0
        strength_ext = extensions.get("KHR_materials_emissive_strength")
        if strength_ext is not None:
            skey = f"{key}.extensions.KHR_materials_emissive_strength"
            value = _object(strength_ext, skey).get("emissiveStrength", 1.0)
            strength = _number(value, f"{skey}.emissiveStrength", 0.0, MAX_RADIANCE)
        if override is not None:
            emissive_factor, strength = override.emission(emissive_factor, strength)
        emissive = emissive_factor * strength
        layer.emissive = (float(emissive[0]), float(emissive[1]), float(emissive[2]))
        if m.emissiveTexture is not None and not emissive_factor.any():
            # The texture multiplies emissiveFactor, whose default is black: nothing is
            # emitted (a scene file refuses emissive_map without emissive; glTF allows it).
            _LOG.warning(
                "%s: %s.emissiveTexture: emissiveFactor is black, so the texture emits "
                "nothing; it is not read", self.path, key,
            )  # fmt: skip
        elif m.emissiveTexture is not None:
            img, sampler, tr = self._texture(
                m.emissiveTexture, f"{key}.emissiveTexture", reduced=True
            )
            self._map_cost(img, "colour", f"{key}.emissiveTexture")
            put("emissive", partial(colour_texture, img, self._first_level(img)), sampler, tr)
        layer.alpha = float(factor[3])
        mode = m.alphaMode if m.alphaMode is not None else "OPAQUE"
        if mode not in ("OPAQUE", "MASK", "BLEND"):
            raise GltfError(f"{key}.alphaMode", f"{mode!r} is not OPAQUE, MASK or BLEND")
        layer.alpha_mode = mode.lower()
        if m.alphaCutoff is not None:
            layer.alpha_cutoff = _number(m.alphaCutoff, f"{key}.alphaCutoff", 0.0)
        for name, ext_texture in mapping.maps.items():
            declared = EXTENSION_MAP.get(name)
            colour = declared is not None and declared.srgb  # else whole, every level
            img, sampler, tr = self._texture(
                _texture_info(ext_texture), ext_texture.key, reduced=colour
            )
            kind = {"coat_normal": "normal", "anisotropy_direction": "direction"}.get(name)
            if declared is not None:
                kind = "colour" if declared.srgb else "scalar"
            self._map_cost(img, kind or "scalar", ext_texture.key)
            wait_decoded(img)  # read here with Pillow's own calls, not through _decoded
            put(name, _extension_map(name, ext_texture, img), sampler, tr)
        made()
        layer.uv_transforms = transforms
        layer.anisotropy_rotation = mapping.anisotropy_rotation
        # The checks every material front-end shares (app/common/material_checks.py), on
        # what this material became; a problem names the JSON key it comes from.
        for problem in material_problems(layer.params, maps, emissive_factor, strength):
            raise GltfError(_problem_key(key, problem.key), problem.message)
        return layer


# A material map, or what makes it once the material's images are open (``_layer``).
MapMaker = Texture | Callable[[], Texture]


def _reads_moved_uv(value: object) -> bool:
    """Whether a material's JSON names a ``texCoord`` other than 0 or a
    KHR_texture_transform anywhere (its textureInfos, its extensions' textures; the
    reader applies a transform whether or not ``extensionsUsed`` declares it)."""
    if isinstance(value, JsonObject):
        value = value.__dict__
    if isinstance(value, dict):
        if value.get("texCoord", 0) not in (0, None) or "KHR_texture_transform" in value:
            return True
        return any(_reads_moved_uv(v) for v in value.values())
    if isinstance(value, list):
        return any(_reads_moved_uv(v) for v in value)
    return False


# The JSON key (after "materials[i]") that gives what a resolved check's scene-file key is
# about (app/common/material_checks.py); any other: the material itself.
_PROBLEM_KEYS = {
    "anisotropy": ".extensions.KHR_materials_anisotropy",
    "anisotropy_map": ".extensions.KHR_materials_anisotropy",
    "anisotropy_direction_map": ".extensions.KHR_materials_anisotropy",
    "clearcoat": ".extensions.KHR_materials_clearcoat",
    "clearcoat_ior": ".extensions.KHR_materials_clearcoat",
    "clearcoat_normal_map": ".extensions.KHR_materials_clearcoat",
    "emissive_map": ".emissiveTexture",
    "emissive_strength": ".extensions.KHR_materials_emissive_strength",
    "metallic": ".pbrMetallicRoughness.metallicFactor",
    "sheen_color": ".extensions.KHR_materials_sheen",
    "thin_film": ".extensions.KHR_materials_iridescence",
    "fresnel": ".extensions.KHR_materials_specular",
}


def _problem_key(material: str, scene_key: str) -> str:
    """The JSON key of material ``material`` (``materials[3]``) a problem about the scene
    file's ``scene_key`` names."""
    return material + _PROBLEM_KEYS.get(scene_key, "")


def _texture_info(texture: ExtensionTexture) -> SimpleNamespace:
    """An extension's textureInfo (parsed JSON) with the attributes ``_texture`` reads."""
    info = texture.info
    return SimpleNamespace(
        index=info.get("index"),
        texCoord=info.get("texCoord", 0),
        extensions=info.get("extensions"),
    )


def _extension_map(name: str, texture: ExtensionTexture, image: Image.Image) -> Texture:
    """The map a KHR_materials_* texture fills (docs/gltf.md): the clear coat's own normal
    map (its ``scale`` applied; mips of the normals alone, as a scene's
    ``clearcoat_normal_map``), the anisotropy direction (RG decoded to 2 rg - 1, as a
    scene's ``anisotropy_direction_map``), or one channel of a scalar map."""
    if name == "coat_normal":
        scale = _number(texture.info.get("scale", 1.0), f"{texture.key}.scale", -1e3, 1e3)
        return coat_normal_texture(image, scale)
    if name == "anisotropy_direction":
        return direction_texture(image)
    declared = EXTENSION_MAP.get(name)  # app/common/extension_maps.py
    if declared is not None and declared.srgb:  # sRGB, decoded by the GL
        return colour_texture(image)
    channel = "rgba".index(texture.channel)
    pixels = np.asarray(image.convert("RGBA"), np.float64) / 255.0
    return scalar_texture(pixels[..., channel])


def _slice(data: bytes, offset: object, length: object, key: str) -> bytes:
    start = _int(offset, f"{key}.byteOffset")
    size = _int(length, f"{key}.byteLength", low=1)
    if start + size > len(data):
        raise GltfError(key, f"bytes {start}..{start + size} run past the buffer's {len(data)}")
    return data[start : start + size]


def _triangles(indices: np.ndarray, mode: int) -> np.ndarray:
    """(M, 3) triangles of a TRIANGLES, TRIANGLE_STRIP or TRIANGLE_FAN index list (glTF
    2.0 sec. 3.7.2.1: strip triangle i is (i, i + 1 + i % 2, i + 2 - i % 2), keeping one
    winding; fan triangle i is (i + 1, i + 2, 0))."""
    if mode == 4:
        return indices[: len(indices) // 3 * 3].reshape(-1, 3)
    count = len(indices) - 2
    if count <= 0:
        return np.zeros((0, 3), np.int64)
    i = np.arange(count)
    if mode == 5:
        odd = i % 2
        return np.stack([indices[i], indices[i + 1 + odd], indices[i + 2 - odd]], axis=1)
    return np.stack([indices[i + 1], indices[i + 2], np.full(count, indices[0])], axis=1)


def _assemble(
    key: str,
    attrs: dict[str, np.ndarray],
    faces: np.ndarray,
    world: np.ndarray,
    material: int | None,
) -> GltfPrimitive:
    """The primitive's arrays: without NORMAL, each triangle gets its own three vertices
    and its face normal (glTF 2.0: "client implementations MUST calculate flat normals")."""
    if "NORMAL" not in attrs:
        corners = faces.reshape(-1)
        attrs = {name: values[corners] for name, values in attrs.items() if name != "TANGENT"}
        faces = np.arange(len(corners), dtype=np.int64).reshape(-1, 3)
        p = attrs["POSITION"]
        n = np.cross(p[faces[:, 1]] - p[faces[:, 0]], p[faces[:, 2]] - p[faces[:, 0]])
        attrs["NORMAL"] = np.repeat(n, 3, axis=0)
    normals = attrs["NORMAL"][:, :3]
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.where(length > 1e-12, normals / np.where(length > 1e-12, length, 1.0), [0, 1, 0])
    out = GltfPrimitive(key, attrs["POSITION"][:, :3], normals, faces, world, material)
    for name, attr in (("TEXCOORD_0", "uv"), ("TEXCOORD_1", "uv1")):
        if name in attrs:
            uv = attrs[name][:, :2].copy()
            uv[:, 1] = 1.0 - uv[:, 1]
            setattr(out, attr, uv)
    if "TANGENT" in attrs:
        t = attrs["TANGENT"]
        xyz = t[:, :3]
        tl = np.linalg.norm(xyz, axis=1, keepdims=True)
        if np.all(tl > 1e-12):
            w = np.where(t[:, 3:4] < 0.0, -1.0, 1.0)
            out.tangents = np.hstack([xyz / tl, w])
    if "COLOR_0" in attrs:
        c = attrs["COLOR_0"]
        if c.shape[1] == 3:
            c = np.hstack([c, np.ones((len(c), 1))])
        out.colors = c
    return out
