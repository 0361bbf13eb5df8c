"""The images this process decoded, by their file's digest, for a later load of the same
bytes: a model file's parts are built once to frame the camera and again for the frame,
a batch renders many frames, a viewer reloads. Callers share an image and only read it
(every map is made from a ``convert`` or an array of the texels): a copy for each caller
was 60 MiB of memcpy and fresh pages for DamagedHelmet's five maps. The least recently
used go past ``KEPT_BYTES`` of texels.

Standard library only: ``pbs render`` turns the keeping off before it reads the scene,
and a scene refused by validation then never imports Pillow or the texture layer
(docs/performance.md, "Start-up").
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from typing import Any

KEPT_BYTES = 256 << 20

_IMAGES: OrderedDict[str, tuple[Any, int]] = OrderedDict()  # digest -> (image, bytes)
_KEEPING = [True]
_LOCK = threading.Lock()


def keep_decoded_images(keep: bool) -> bool:
    """Whether this process keeps the images it decodes for a later load. A one-frame
    render (``pbs render``) has no later load: an image no map holds any more is then
    freed as soon as its maps are made (a colour map's once its texels are in the
    prepared-texture entry), and the GL's textures made next take its pages instead of
    fresh ones (a first touch of memory is dear on a virtual machine: docs/performance.md,
    "A real asset against f3d"). Returns the setting it replaces."""
    with _LOCK:
        before, _KEEPING[0] = _KEEPING[0], keep
        if not keep:
            _IMAGES.clear()
    return before


def keep(digest: str, image: Any, size: int) -> None:
    """Keep ``image`` (a decoded PIL image of ``size`` bytes of texels) by ``digest``,
    where this process keeps them."""
    with _LOCK:
        if not _KEEPING[0]:
            return
        _IMAGES[digest] = (image, size)
        total = sum(held for _, held in _IMAGES.values())
        while total > KEPT_BYTES and len(_IMAGES) > 1:
            _, (_, held) = _IMAGES.popitem(last=False)
            total -= held


def kept(digest: str) -> Any | None:
    """The image kept by ``digest`` (now the most recently used), else None."""
    with _LOCK:
        entry = _IMAGES.get(digest)
        if entry is None:
            return None
        _IMAGES.move_to_end(digest)
        return entry[0]


def holding() -> int:
    """How many images are kept."""
    with _LOCK:
        return len(_IMAGES)


def forget() -> None:
    """Keep none of the images kept so far (as a new process starts)."""
    with _LOCK:
        _IMAGES.clear()
