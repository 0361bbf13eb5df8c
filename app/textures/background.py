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
from concurrent.futures import ThreadPoolExecutor

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


def finish_background_work() -> None:
    """Wait for every task of the layer's pools to end, each pool then shut (a task given
    to it afterwards is refused, as at the interpreter's exit). A module this process never
    imported is not imported here."""
    for module_name, attribute in _POOLS:
        module = sys.modules.get(module_name)
        if module is None:
            continue
        pool: ThreadPoolExecutor | None = getattr(module, attribute)  # a renamed one raises
        if pool is not None:  # None until the module's first task made it
            pool.shutdown(wait=True)
