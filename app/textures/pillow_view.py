"""A decoded Pillow image's texels as a numpy view of Pillow's own storage, without a copy.

Pillow keeps an RGB image 4 bytes a texel (the 4th unused), row after row. ``np.asarray``
copies them into a packed array (``Image.tobytes``): 12 MiB of fresh memory for a 2048²
map, whose pages cost as much as the copy on a virtual machine (docs/performance.md). Pillow
exports an image through the Arrow C data interface (``Image.__arrow_c_array__``, Pillow
11.2 and later): an RGB image is a fixed-size list of 4 ``uint8`` per texel, its child array
one buffer holding every row, so its texels can be read where they are. The structures below
are the interface's, as the Arrow specification declares them
(https://arrow.apache.org/docs/format/CDataInterface.html); the view keeps the exported
capsules, whose release lets Pillow free the storage once no view needs it. The view
shares the image's memory: a loaded texture image is never changed after its decode (no
``paste`` or drawing on it), which keeps every view's texels the decoded ones.
"""

from __future__ import annotations

import ctypes

import numpy as np
from PIL import Image


class _ArrowSchema(ctypes.Structure):
    pass


_ArrowSchema._fields_ = [
    ("format", ctypes.c_char_p),
    ("name", ctypes.c_char_p),
    ("metadata", ctypes.c_char_p),
    ("flags", ctypes.c_int64),
    ("n_children", ctypes.c_int64),
    ("children", ctypes.POINTER(ctypes.POINTER(_ArrowSchema))),
    ("dictionary", ctypes.c_void_p),
    ("release", ctypes.c_void_p),
    ("private_data", ctypes.c_void_p),
]


class _ArrowArray(ctypes.Structure):
    pass


_ArrowArray._fields_ = [
    ("length", ctypes.c_int64),
    ("null_count", ctypes.c_int64),
    ("offset", ctypes.c_int64),
    ("n_buffers", ctypes.c_int64),
    ("n_children", ctypes.c_int64),
    ("buffers", ctypes.POINTER(ctypes.c_void_p)),
    ("children", ctypes.POINTER(ctypes.POINTER(_ArrowArray))),
    ("dictionary", ctypes.c_void_p),
    ("release", ctypes.c_void_p),
    ("private_data", ctypes.c_void_p),
]

_CAPSULE_POINTER = ctypes.pythonapi.PyCapsule_GetPointer
_CAPSULE_POINTER.restype = ctypes.c_void_p
_CAPSULE_POINTER.argtypes = [ctypes.py_object, ctypes.c_char_p]


def rgbx_view(image: Image.Image) -> np.ndarray | None:
    """A loaded RGB ``image``'s storage as a read-only (H, W, 4) uint8 view (the 4th byte
    Pillow's padding), or None where Pillow cannot export it so (an older Pillow, an image
    whose rows lie in several blocks of its allocator, another layout): the caller copies
    the texels then. ``view[..., :3]`` holds ``np.asarray(image)``'s values."""
    if image.mode != "RGB" or image.width == 0 or image.height == 0:
        return None
    export = getattr(image, "__arrow_c_array__", None)
    if export is None:
        return None
    try:
        schema_capsule, array_capsule = export()
    except ValueError:  # "Image rows are not contiguous in memory"
        return None
    schema = _ArrowSchema.from_address(_CAPSULE_POINTER(schema_capsule, b"arrow_schema"))
    array = _ArrowArray.from_address(_CAPSULE_POINTER(array_capsule, b"arrow_array"))
    size = image.width * image.height * 4
    if (
        schema.format != b"+w:4"
        or schema.n_children != 1
        or schema.children[0].contents.format != b"C"
        or array.n_children != 1
        or array.offset != 0
        or array.length != image.width * image.height
    ):
        return None
    child = array.children[0].contents
    if child.n_buffers != 2 or child.offset != 0 or child.length != size or not child.buffers[1]:
        return None
    storage = (ctypes.c_uint8 * size).from_address(child.buffers[1])
    storage.kept = (schema_capsule, array_capsule, image)  # released with the last view
    readonly = memoryview(storage).toreadonly()  # neither the view nor its base writable
    return np.frombuffer(readonly, np.uint8).reshape(image.height, image.width, 4)
