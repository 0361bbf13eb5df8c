"""Where the prepared-texture cache keeps its entries and what names them, with the
standard library alone (app/textures/cache.py is the cache itself).

A still render asks whether an image decoded before while the process is still importing
numpy and the scene's modules (app/textures/early.py ``decoded_before``): a question that
imported numpy would wait for the import the main thread is making, and the decode behind
it with it, where it could run on the core the imports leave idle. A key whose parts hold
an array can only be made once numpy is imported, so ``entry_key`` looks numpy up only then.
"""

from __future__ import annotations

import hashlib
import os
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np

    Part = bytes | str | int | float | bool | None | np.ndarray | tuple

ENV_DIR = "PBS_CACHE_DIR"
ENV_SWITCH = "PBS_CACHE"
ENV_SEED = "PBS_CACHE_SEED"
OFF_VALUES = ("off", "0", "no", "false")
SUFFIX = ".npy"  # an entry's file: the key, then this


def entry_key(kind: str, parts: Iterable[Part]) -> str:
    """The SHA-256 (hex) of ``kind`` and ``parts``, each part tagged with its type (and an
    array with its dtype and shape) so that no two different inputs run together."""
    digest = hashlib.sha256(kind.encode())
    for part in parts:
        _feed(digest, part)
    return digest.hexdigest()


def _feed(digest: hashlib._Hash, part: Part) -> None:
    # No array exists before numpy is imported (or while its import is under way, on
    # another thread: the module is in sys.modules without its names yet).
    ndarray = getattr(sys.modules.get("numpy"), "ndarray", None)
    if ndarray is not None and isinstance(part, ndarray):
        a = sys.modules["numpy"].ascontiguousarray(part)
        digest.update(f"|a{a.dtype.str}{a.shape}|".encode())
        digest.update(a.data)
    elif isinstance(part, bytes):
        digest.update(f"|b{len(part)}|".encode())
        digest.update(part)
    elif isinstance(part, tuple):
        digest.update(f"|t{len(part)}|".encode())
        for item in part:
            _feed(digest, item)
    else:
        digest.update(f"|{type(part).__name__}:{part!r}|".encode())


def entry_file(directory: Path | None, seeds: Iterable[Path], key: str) -> Path | None:
    """The file that holds entry ``key``: in ``directory`` (the cache's own folder, None
    for none) or else the first of the read-only ``seeds`` that has one; None where none
    does. Nothing is read or checked."""
    for folder in ([directory] if directory is not None else []) + list(seeds):
        path = folder / f"{key}{SUFFIX}"
        if path.is_file():
            return path
    return None


def cache_directory() -> Path:
    """``$PBS_CACHE_DIR``, else ``$XDG_CACHE_HOME/pbs``, else ``~/.cache/pbs``."""
    given = os.environ.get(ENV_DIR)
    if given:
        return Path(given)
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "pbs"


def textures_directory() -> Path:
    """The folder of the prepared-texture entries inside ``cache_directory()``."""
    return cache_directory() / "textures"


def seed_directories() -> list[Path]:
    """The read-only seed folders: ``$PBS_CACHE_SEED`` (folders separated by
    ``os.pathsep``; set and empty: none), else ``<sys.prefix>/share/pbs/prepared``, where
    ``scripts/dev.sh`` seeds an installation (app/render/prepared_seed.py)."""
    given = os.environ.get(ENV_SEED)
    if given is not None:
        return [Path(p) for p in given.split(os.pathsep) if p.strip()]
    return [default_seed_directory()]


def default_seed_directory() -> Path:
    return Path(sys.prefix) / "share" / "pbs" / "prepared"


def cache_enabled() -> bool:
    return os.environ.get(ENV_SWITCH, "").strip().lower() not in OFF_VALUES


def held_on_disk(kind: str, parts: Iterable[Part]) -> bool:
    """Whether the process's cache (the current environment variables') has an entry of
    ``kind`` and ``parts`` on disk or in a seed: what ``PreparedCache.holds`` answers in a
    process whose cache holds nothing in memory yet."""
    if not cache_enabled():
        return False
    return entry_file(textures_directory(), seed_directories(), entry_key(kind, parts)) is not None
