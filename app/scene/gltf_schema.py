"""The raw JSON of a glTF 2.0 file checked against the specification's schema before
anything reads it.

A permissive parser repairs what it should refuse: a texture index of 0.5, a byte offset
of 1.5 or a factor written as the string "1" would become numbers the reader never saw
written. Here every property the glTF 2.0 specification (Khronos, 2021, sec. 5, the JSON
schema) defines for the objects pbs reads is checked for its JSON type, integer-ness,
enumeration and range, with the JSON path of the first one that is wrong
(``accessors[3].byteOffset``). Two checks run over the whole document, extensions and
extras included: every number is finite (Python reads ``1e400`` as infinity) and no array
is longer than ``Limits.max_entries``.

Unknown properties are ignored, as the specification lets a reader do.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

# The largest magnitude of a number that places geometry (node transforms, positions), in
# metres: far past any model, and small enough that products in float32 stay finite
# (docs/stability.md, "Limits").
MAX_COORDINATE = 1e9
INDEX = 2**31 - 1  # an index or a byte count: JSON integers past this are never valid


@dataclass(frozen=True)
class Int:
    lo: int = 0
    hi: int = INDEX
    enum: tuple[int, ...] = ()


@dataclass(frozen=True)
class Num:
    lo: float = -MAX_COORDINATE
    hi: float = MAX_COORDINATE


@dataclass(frozen=True)
class Str:
    enum: tuple[str, ...] = ()


@dataclass(frozen=True)
class Bool:
    pass


@dataclass(frozen=True)
class Anything:
    """Any JSON value (extras; the whole-document checks still apply)."""


@dataclass(frozen=True)
class Arr:
    item: Any
    lo: int = 0
    hi: int | None = None  # None: Limits.max_entries
    unique: bool = False


@dataclass(frozen=True)
class Obj:
    props: dict[str, Any] = field(default_factory=dict)
    required: tuple[str, ...] = ()
    values: Any = None  # a map: every value of this spec (attributes, extensions)


_COMMON = {"name": Str(), "extensions": Obj(values=Obj()), "extras": Anything()}


def _obj(props: dict[str, Any], required: tuple[str, ...] = ()) -> Obj:
    return Obj({**_COMMON, **props}, required)


INDEXES = Arr(Int(), unique=True)
TEXTURE_INFO = _obj({"index": Int(), "texCoord": Int()}, ("index",))
NORMAL_INFO = _obj({"index": Int(), "texCoord": Int(), "scale": Num()}, ("index",))
OCCLUSION_INFO = _obj({"index": Int(), "texCoord": Int(), "strength": Num(0.0, 1.0)}, ("index",))
COMPONENT_TYPES = (5120, 5121, 5122, 5123, 5125, 5126)
ACCESSOR_TYPES = ("SCALAR", "VEC2", "VEC3", "VEC4", "MAT2", "MAT3", "MAT4")
FILTERS = (9728, 9729, 9984, 9985, 9986, 9987)
WRAPS = (33071, 33648, 10497)
BOUNDS = Arr(Num(-math.inf, math.inf), 1, 16)

SCHEMA = _obj(
    {
        "asset": _obj(
            {"version": Str(), "minVersion": Str(), "generator": Str(), "copyright": Str()},
            ("version",),
        ),
        "extensionsUsed": Arr(Str(), unique=True),
        "extensionsRequired": Arr(Str(), unique=True),
        "scene": Int(),
        "scenes": Arr(_obj({"nodes": INDEXES})),
        "nodes": Arr(
            _obj(
                {
                    "camera": Int(),
                    "children": INDEXES,
                    "skin": Int(),
                    "matrix": Arr(Num(), 16, 16),
                    "mesh": Int(),
                    "rotation": Arr(Num(-1e6, 1e6), 4, 4),
                    "scale": Arr(Num(), 3, 3),
                    "translation": Arr(Num(), 3, 3),
                    "weights": Arr(Num(-math.inf, math.inf), 1),
                }
            )
        ),
        "meshes": Arr(
            _obj(
                {
                    "primitives": Arr(
                        _obj(
                            {
                                "attributes": Obj(values=Int()),
                                "indices": Int(),
                                "material": Int(),
                                "mode": Int(0, 6),
                                "targets": Arr(Obj(values=Int()), 1),
                            },
                            ("attributes",),
                        ),
                        1,
                    ),
                    "weights": Arr(Num(-math.inf, math.inf), 1),
                },
                ("primitives",),
            )
        ),
        "accessors": Arr(
            _obj(
                {
                    "bufferView": Int(),
                    "byteOffset": Int(),
                    "componentType": Int(enum=COMPONENT_TYPES),
                    "normalized": Bool(),
                    "count": Int(1),
                    "type": Str(ACCESSOR_TYPES),
                    "max": BOUNDS,
                    "min": BOUNDS,
                    "sparse": _obj(
                        {
                            "count": Int(1),
                            "indices": _obj(
                                {
                                    "bufferView": Int(),
                                    "byteOffset": Int(),
                                    "componentType": Int(enum=(5121, 5123, 5125)),
                                },
                                ("bufferView", "componentType"),
                            ),
                            "values": _obj(
                                {"bufferView": Int(), "byteOffset": Int()}, ("bufferView",)
                            ),
                        },
                        ("count", "indices", "values"),
                    ),
                },
                ("componentType", "count", "type"),
            )
        ),
        "bufferViews": Arr(
            _obj(
                {
                    "buffer": Int(),
                    "byteOffset": Int(),
                    "byteLength": Int(1),
                    "byteStride": Int(4, 252),
                    "target": Int(enum=(34962, 34963)),
                },
                ("buffer", "byteLength"),
            )
        ),
        "buffers": Arr(_obj({"uri": Str(), "byteLength": Int(1)}, ("byteLength",))),
        "materials": Arr(
            _obj(
                {
                    "pbrMetallicRoughness": _obj(
                        {
                            "baseColorFactor": Arr(Num(0.0, 1.0), 4, 4),
                            "baseColorTexture": TEXTURE_INFO,
                            "metallicFactor": Num(0.0, 1.0),
                            "roughnessFactor": Num(0.0, 1.0),
                            "metallicRoughnessTexture": TEXTURE_INFO,
                        }
                    ),
                    "normalTexture": NORMAL_INFO,
                    "occlusionTexture": OCCLUSION_INFO,
                    "emissiveTexture": TEXTURE_INFO,
                    "emissiveFactor": Arr(Num(0.0, 1.0), 3, 3),
                    "alphaMode": Str(("OPAQUE", "MASK", "BLEND")),
                    "alphaCutoff": Num(0.0),
                    "doubleSided": Bool(),
                }
            )
        ),
        "textures": Arr(_obj({"sampler": Int(), "source": Int()})),
        "images": Arr(_obj({"uri": Str(), "mimeType": Str(), "bufferView": Int()})),
        "samplers": Arr(
            _obj(
                {
                    "magFilter": Int(enum=(9728, 9729)),
                    "minFilter": Int(enum=FILTERS),
                    "wrapS": Int(enum=WRAPS),
                    "wrapT": Int(enum=WRAPS),
                }
            )
        ),
        "cameras": Arr(
            _obj(
                {
                    "type": Str(("perspective", "orthographic")),
                    "perspective": _obj(
                        {
                            "aspectRatio": Num(0.0),
                            "yfov": Num(0.0),
                            "zfar": Num(0.0),
                            "znear": Num(0.0),
                        },
                        ("yfov", "znear"),
                    ),
                    "orthographic": _obj(
                        {"xmag": Num(), "ymag": Num(), "zfar": Num(0.0), "znear": Num(0.0)},
                        ("xmag", "ymag", "zfar", "znear"),
                    ),
                },
                ("type",),
            )
        ),
        "skins": Arr(
            _obj(
                {"inverseBindMatrices": Int(), "skeleton": Int(), "joints": Arr(Int(), 1)},
                ("joints",),
            )
        ),
        "animations": Arr(
            _obj(
                {
                    "channels": Arr(
                        _obj(
                            {
                                "sampler": Int(),
                                "target": _obj({"node": Int(), "path": Str()}, ("path",)),
                            },
                            ("sampler", "target"),
                        ),
                        1,
                    ),
                    # The interpolation (the schema allows any string) and what the
                    # indices point at are checked by app/scene/gltf_animation.py, for
                    # every animation whatever the pose.
                    "samplers": Arr(
                        _obj(
                            {"input": Int(), "interpolation": Str(), "output": Int()},
                            ("input", "output"),
                        ),
                        1,
                    ),
                },
                ("channels", "samplers"),
            )
        ),
    },
    ("asset",),
)


class SchemaError(ValueError):
    """The first property that is not as glTF 2.0 defines it: its JSON path and why."""

    def __init__(self, key: str, message: str) -> None:
        super().__init__(f"{key}: {message}" if key else message)
        self.key = key
        self.message = message


def _path(parent: str, child: str | int) -> str:
    if isinstance(child, int):
        return f"{parent}[{child}]"
    return f"{parent}.{child}" if parent else child


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _check(spec: Any, value: Any, key: str, max_entries: int, work: list) -> None:
    """Check ``value`` against ``spec`` at ``key``; nested values go on ``work``."""
    if isinstance(spec, Anything):
        return
    if isinstance(spec, Int):
        if isinstance(value, bool) or not isinstance(value, int):
            raise SchemaError(key, f"must be an integer, not {_show(value)}")
        if spec.enum and value not in spec.enum:
            raise SchemaError(key, f"{value} is not one of {', '.join(map(str, spec.enum))}")
        if not spec.lo <= value <= spec.hi:
            raise SchemaError(key, f"{value} is outside [{spec.lo}, {spec.hi}]")
        return
    if isinstance(spec, Num):
        if not _is_number(value):
            raise SchemaError(key, f"must be a number, not {_show(value)}")
        if not spec.lo <= value <= spec.hi:
            raise SchemaError(key, f"{value:g} is outside [{spec.lo:g}, {spec.hi:g}]")
        return
    if isinstance(spec, Str):
        if not isinstance(value, str):
            raise SchemaError(key, f"must be a string, not {_show(value)}")
        if spec.enum and value not in spec.enum:
            raise SchemaError(key, f"{_show(value)} is not one of {', '.join(spec.enum)}")
        return
    if isinstance(spec, Bool):
        if not isinstance(value, bool):
            raise SchemaError(key, f"must be true or false, not {_show(value)}")
        return
    if isinstance(spec, Arr):
        if not isinstance(value, list):
            raise SchemaError(key, f"must be an array, not {_show(value)}")
        hi = max_entries if spec.hi is None else spec.hi
        if not spec.lo <= len(value) <= hi:
            count = f"exactly {spec.lo}" if spec.lo == spec.hi else f"{spec.lo} to {hi}"
            raise SchemaError(key, f"must hold {count} entries, not {len(value)}")
        if spec.unique and len(set(map(repr, value))) != len(value):
            raise SchemaError(key, "must not repeat an entry")
        work.extend((spec.item, item, _path(key, i)) for i, item in enumerate(value))
        return
    if isinstance(spec, Obj):
        if not isinstance(value, dict):
            raise SchemaError(key, f"must be a JSON object, not {_show(value)}")
        for name in spec.required:
            if name not in value:
                raise SchemaError(_path(key, name), "is required")
        for name, item in value.items():
            child = spec.props.get(name, spec.values)
            if child is not None:
                work.append((child, item, _path(key, name)))
        return
    raise AssertionError(spec)


def _whole_document(doc: Any, max_entries: int) -> None:
    """Every number finite and every array at most ``max_entries`` long, anywhere."""
    stack: list[tuple[Any, str]] = [(doc, "")]
    while stack:
        value, key = stack.pop()
        if isinstance(value, float) and not math.isfinite(value):
            raise SchemaError(key, "must be a finite number")
        if isinstance(value, dict):
            stack.extend((item, _path(key, str(name))) for name, item in value.items())
        elif isinstance(value, list):
            if len(value) > max_entries:
                raise SchemaError(key, f"holds {len(value)} entries, more than {max_entries}")
            stack.extend((item, _path(key, i)) for i, item in enumerate(value))


def validate(doc: Any, max_entries: int) -> None:
    """``SchemaError`` at the first property of ``doc`` (parsed JSON) that glTF 2.0 does
    not allow; also a document whose ``asset.version`` is not 2.x."""
    _whole_document(doc, max_entries)
    work: list[tuple[Any, Any, str]] = [(SCHEMA, doc, "")]
    while work:
        spec, value, key = work.pop()
        _check(spec, value, key, max_entries, work)
    version = doc["asset"]["version"]
    major = version.split(".")[0]
    if not major.isdigit() or int(major) != 2:
        raise SchemaError("asset.version", f"{_show(version)}: pbs reads glTF 2.0 files")
