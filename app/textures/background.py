"""The end of the texture layer's background work: what a process waits for before it ends.

The layer runs its work on thread pools of its own (``maps``: the decodes and the colour
maps' levels; ``mips``: a chain's bands; ``cache``: the prepared entries' lookups and their
writes to disk). Python's exit joins them, and then tears down every module and object,
which a ``pbs render`` of a textured model paid for after its PNG was written
(docs/performance.md, "A real asset against f3d"). ``finish_background_work`` is the join
alone, so that such a process can end at once afterwards with nothing of its lost: every
cache entry handed to the writer is on disk when it returns.
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager

# The pools in the order they are finished: the lookups and the colour levels first (they
# wait for decodes and bands and hand entries to the writer), then the decodes and the bands
# nothing waits for any more, the writer last. (module, the attribute holding its pool)
_POOLS = (
    ("app.textures.cache", "_PREPARER"),
    ("app.textures.maps", "_COLOUR_MAKER"),
    ("app.textures.maps", "_DECODER"),
    ("app.textures.mips", "_BAND_POOL"),
    ("app.textures.cache", "_WRITER"),
)


# Set while the prepared-texture cache's writer may write the entries handed to it; clear
# within ``writes_held``.
_WRITES_FREE = threading.Event()
_WRITES_FREE.set()


@contextmanager
def writes_held() -> Iterator[None]:
    """Within the block the cache's writer leaves the entries handed to it queued
    (app/textures/cache.py), until ``release_writes`` or the block's end. ``pbs render``
    holds them while a still's scene is read, where the decodes, the levels and the GL's
    chain keep both cores busy, and lets them go when the renderer is set up on the main
    thread alone, the other core idle (docs/performance.md, "A real asset against f3d").
    A wait for a queued entry (its key looked up again, ``flush``, the end's join) lets
    them go first, so that nothing waits on a held write."""
    _WRITES_FREE.clear()
    try:
        yield
    finally:
        _WRITES_FREE.set()


def release_writes() -> None:
    """Let the cache's writer write what it holds (``writes_held``); nothing where it
    holds nothing."""
    _WRITES_FREE.set()


def when_writes_free() -> None:
    """Return once the cache's writer may write (at once outside ``writes_held``)."""
    _WRITES_FREE.wait()


def finish_background_work() -> None:
    """Wait for every task of the layer's pools to end, each pool then shut (a task given
    to it afterwards is refused, as at the interpreter's exit). A module this process never
    imported is not imported here. Held writes are let go first (``writes_held``)."""
    release_writes()
    for module_name, attribute in _POOLS:
        module = sys.modules.get(module_name)
        if module is None:
            continue
        pool: ThreadPoolExecutor | None = getattr(module, attribute)  # a renamed one raises
        if pool is not None:  # None until the module's first task made it
            pool.shutdown(wait=True)
