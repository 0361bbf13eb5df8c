"""A content-keyed cache of prepared texture data: mip chains of material maps, prefiltered
environments, anything that is a list of numpy arrays computed from some source data by
code that does not change between runs.

An entry's key is a SHA-256 over the kind of data, the source's bytes (or its arrays' dtype,
shape and bytes), the preparation's parameters and a code version (a hash of the source
files of the code that prepares it), so an edited image, another filter or edited code is
a new key and nothing stale is ever returned. Two levels:

* in process: the arrays themselves, read-only, least recently used first out past
  ``memory_bytes``; a batch's frames, a viewer's reload and a second Renderer of the same
  asset reuse them;
* on disk: one ``.npy`` per entry, a flat uint8 array (``pack_entry``: a JSON header of
  dtypes, shapes and offsets, and a CRC-32 of the data checked on every read: a torn or
  flipped entry is caught, as by a SHA-256, in a fraction of its time; the key is what
  SHA-256 secures), mapped (``np.load`` with ``mmap_mode="r"``: no copy, no fresh
  memory) with ``allow_pickle=False``: an entry is data, never code; a corrupt or
  unreadable entry is deleted and rebuilt. Written to a temporary file
  and renamed, so a killed process leaves no half entry. An entry whose arrays' shapes
  are known before they are made (``filled``) is made in that file: the builder writes
  into views of the file mapped, and the writer thread adds the checksum and the header
  (no second copy of the data, no ``write`` of it: docs/performance.md). Bounded by
  ``disk_bytes``: the least recently used entries (by modification time, refreshed on
  each hit) go first.

Where: ``$PBS_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/pbs`` (``~/.cache/pbs``).
``PBS_CACHE=off`` (or ``0``, ``no``, ``false``) turns both levels off: every call builds.

Below the disk level, read-only **seed** folders (``seed_directories``: ``$PBS_CACHE_SEED``,
folders separated by ``os.pathsep``, else ``<sys.prefix>/share/pbs/prepared``): entries made
when the project was installed (app/render/prepared_seed.py: the bundled environments'
prefiltered levels, which depend on nothing a scene brings), looked up by the same key when
the disk level has none. A seed is never written, refreshed or pruned here; an unreadable
seed entry is skipped (and the entry built as on any miss).
"""

from __future__ import annotations

import io
import json
import logging
import mmap
import os
import sys
import tempfile
import threading
import time
import zlib
from collections import OrderedDict
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO

import numpy as np

from app.textures.background import release_writes, when_writes_free
from app.textures.cache_keys import (
    SUFFIX,
    cache_directory,
    cache_enabled,
    entry_file,
    entry_key,
    seed_directories,
    textures_directory,
)
from app.waiting import waited

if TYPE_CHECKING:
    from app.textures.cache_keys import Part

_LOG = logging.getLogger(__name__)

MEMORY_BYTES = 1 << 30  # in-process entries kept (DamagedHelmet's prepared maps: ~140 MiB)
DISK_BYTES = 4 << 30  # on-disk entries kept
_TEMPORARY = ".tmp-"  # prefix of an entry being written (renamed into place when whole)
_STALE_NS = 3600 * 10**9  # a temporary file this old was left by a killed process
_ALIGN = 64
SWITCH_INTERVAL_S = 0.001  # the GIL's switch interval once a background build can run


def pack_entry(arrays: Sequence[np.ndarray]) -> np.ndarray:
    """Arrays as one entry, a flat uint8 array: an 8-byte little-endian header length, a
    JSON header ({"arrays": [[dtype, shape, offset], ...], "crc32": of the data}),
    then each array's bytes at a 64-byte aligned offset. One read, no per-array copies."""
    prefix, pieces = _entry_pieces(arrays)
    return np.concatenate([np.frombuffer(prefix, np.uint8), *pieces])


def write_entry(out: BinaryIO, arrays: Sequence[np.ndarray]) -> None:
    """``np.save(out, pack_entry(arrays))`` byte for byte, written piece by piece: the
    .npy header, the entry's prefix and each array's own buffer, never a packed copy
    (a render's entries are ~100 MiB)."""
    prefix, pieces = _entry_pieces(arrays)
    out.write(_npy_header(len(prefix) + sum(p.nbytes for p in pieces)))
    out.write(prefix)
    for piece in pieces:
        out.write(piece.data)


Shape = tuple[int, ...]


def entry_layout(layout: Sequence[tuple[Shape, np.dtype | type]]) -> tuple[list, int]:
    """An entry's layout of arrays of these shapes and dtypes, known before their data:
    ([[dtype, shape, offset], ...], the data's length), each array at a 64-byte aligned
    offset."""
    arrays, offset = [], 0
    for shape, dtype in layout:
        offset = -(-offset // _ALIGN) * _ALIGN
        dt = np.dtype(dtype)
        arrays.append([dt.str, [int(n) for n in shape], offset])
        offset += int(np.prod(shape, dtype=np.int64)) * dt.itemsize
    return arrays, offset


def _entry_pieces(arrays: Sequence[np.ndarray]) -> tuple[bytes, list[np.ndarray]]:
    """An entry's prefix (header length and JSON header, padded) and its data, as the
    arrays' bytes and the zero padding between them (the CRC-32 taken over them in turn)."""
    layout, _ = entry_layout([(a.shape, a.dtype) for a in arrays])
    pieces: list[np.ndarray] = []
    end, crc = 0, 0
    for a, (_, _, offset) in zip(arrays, layout, strict=True):
        if offset > end:
            pieces.append(np.zeros(offset - end, np.uint8))
        pieces.append(np.frombuffer(np.ascontiguousarray(a).data, np.uint8))
        end = offset + a.nbytes
    for piece in pieces:
        crc = zlib.crc32(piece.data, crc)
    return _prefix(layout, crc, fixed_width=False), pieces


def _prefix(arrays: list, crc: int, fixed_width: bool = True) -> bytes:
    """An entry's prefix: the header's length (8 bytes, little-endian) and its JSON,
    zero-padded to a 64-byte boundary. ``fixed_width``: the JSON padded with spaces to the
    length the largest CRC-32 gives it (JSON allows trailing white space), so that the
    data's offset does not depend on the checksum, which an entry made in place
    (``_InPlace``) writes after its data."""
    head = json.dumps({"arrays": arrays, "crc32": crc})
    if fixed_width:
        head = head.ljust(len(json.dumps({"arrays": arrays, "crc32": 0xFFFFFFFF})))
    encoded = head.encode()
    size = -(-(8 + len(encoded)) // _ALIGN) * _ALIGN
    prefix = len(encoded).to_bytes(8, "little") + encoded
    return prefix + bytes(size - len(prefix))


def _npy_header(size: int) -> bytes:
    """The .npy header of a flat uint8 array of ``size`` bytes (an entry on disk)."""
    out = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        out, {"descr": "|u1", "fortran_order": False, "shape": (size,)}
    )
    return out.getvalue()


class _InPlace:
    """An entry being made in its temporary file, mapped: ``arrays`` are writable views of
    the file at their offsets (``entry_layout``); ``finish`` (on the writer thread) takes
    the CRC-32 of the data, writes the header in front of it and renames the file into
    place. Its pages are the page cache's: the builder's writes are the entry's only copy."""

    def __init__(self, directory: Path, layout: Sequence[tuple[Shape, np.dtype | type]]):
        self.layout, data_size = entry_layout(layout)
        prefix = _prefix(self.layout, 0)  # its length, whatever the checksum
        self.head = _npy_header(len(prefix) + data_size)
        self.data_start = len(self.head) + len(prefix)
        size = self.data_start + data_size
        directory.mkdir(parents=True, exist_ok=True)
        fd, self.temporary = tempfile.mkstemp(prefix=_TEMPORARY, suffix=SUFFIX, dir=directory)
        try:
            # The file's blocks reserved before it is mapped: a write into a mapped sparse
            # file that finds the disk full is a SIGBUS, not an OSError; here it is an
            # OSError, and the entry is made in memory (``filled``)
            os.posix_fallocate(fd, 0, size)
            self.mapping = mmap.mmap(fd, size)
        except BaseException:
            os.close(fd)
            Path(self.temporary).unlink(missing_ok=True)
            raise
        os.close(fd)  # the mapping keeps the file
        self.arrays = tuple(
            np.frombuffer(self.mapping, np.dtype(dt), int(np.prod(shape, dtype=np.int64)),
                          self.data_start + offset).reshape(shape)
            for dt, shape, offset in self.layout
        )  # fmt: skip

    def finish(self, path: Path) -> None:
        """Checksum, header, rename (the writer thread's part)."""
        data = memoryview(self.mapping)[self.data_start :]
        try:
            crc = zlib.crc32(data)
        finally:
            data.release()
        self.mapping[: self.data_start] = self.head + _prefix(self.layout, crc)
        os.replace(self.temporary, path)

    def discard(self) -> None:
        Path(self.temporary).unlink(missing_ok=True)


def unpack_entry(entry: np.ndarray) -> tuple[np.ndarray, ...]:
    """The arrays of ``pack_entry``'s output (views of it); ValueError when it is not one
    or its data's CRC-32 is not the header's."""
    if entry.dtype != np.uint8 or entry.ndim != 1 or entry.size < 8:
        raise ValueError("not an entry")
    length = int.from_bytes(entry[:8].tobytes(), "little")
    if length > min(entry.size - 8, 1 << 20):
        raise ValueError("header length out of range")
    header = json.loads(entry[8 : 8 + length].tobytes())
    start = -(-(8 + length) // _ALIGN) * _ALIGN
    data = entry[start:]
    if "crc32" not in header:  # an entry of an older pbs, checked by a SHA-256
        raise ValueError("an entry of an older format")
    if zlib.crc32(data.data) != header["crc32"]:
        raise ValueError("checksum mismatch")
    arrays = []
    for dtype_str, shape, offset in header["arrays"]:
        dtype = np.dtype(dtype_str)
        if dtype.hasobject:
            raise ValueError("object arrays are never read")
        count = int(np.prod(shape, dtype=np.int64))
        arrays.append(np.frombuffer(data, dtype, count, int(offset)).reshape(shape))
    return tuple(arrays)


def _load(path: Path) -> np.ndarray:
    """An entry file mapped, not read: its arrays are views of the page cache's copy of
    the file (read-only, as every entry is handed out), so a render's ~100 MiB of levels
    cost no fresh memory and no copy before the GL takes its own (page faults are dear in
    a virtual machine: docs/performance.md). An entry is never changed in place (written
    whole and renamed; evicted by unlinking, which leaves a mapping valid). A file system
    that cannot map the file has it read instead."""
    try:
        return np.load(path, mmap_mode="r", allow_pickle=False)
    except OSError:
        return np.load(path, allow_pickle=False)


class PreparedCache:
    """The two-level cache (module docstring). ``directory`` None: in process only;
    ``enabled`` False: nothing is kept anywhere."""

    def __init__(
        self,
        directory: Path | None,
        enabled: bool = True,
        memory_bytes: int = MEMORY_BYTES,
        disk_bytes: int = DISK_BYTES,
        seeds: Sequence[Path] = (),
    ) -> None:
        self.directory = directory
        self.seeds = tuple(seeds)  # read-only folders of entries made at install
        self.enabled = enabled
        self.memory_bytes = memory_bytes
        self.disk_bytes = disk_bytes
        self._memory: OrderedDict[str, tuple[np.ndarray, ...]] = OrderedDict()
        self._held = 0
        self._lock = threading.Lock()
        self._writing: dict[str, Future] = {}  # entries being written (``_write``) by key
        self._building: dict[str, Future] = {}  # entries being built (``_keyed``) by key
        # What happened to each lookup, for tests and the bench: memory, disk, seed, built,
        # rebuilt.
        self.events: list[str] = []

    def arrays(
        self, kind: str, parts: Iterable[Part], build: Callable[[], Sequence[np.ndarray]]
    ) -> tuple[np.ndarray, ...]:
        """The arrays ``build()`` makes from the source and parameters in ``parts``: from
        memory, else from disk (checksum verified), else built and stored in both. The
        returned arrays are read-only (they may be shared)."""
        if not self.enabled:
            self.events.append("built")
            return tuple(np.asarray(a) for a in build())
        return self._keyed(entry_key(kind, parts), build)

    def _keyed(self, key: str, build: Callable[[], Sequence[np.ndarray]]) -> tuple[np.ndarray, ...]:
        """``arrays`` of the entry ``key`` (the cache on). An entry another thread is
        building is waited for (``waited``: this thread's work declared ahead first), not
        built a second time beside it (a still render's early decode makes a normal map's
        spread while the reader asks for it); its build's exception is raised to both."""
        arrays = self._looked_up(key)
        if arrays is not None:
            return arrays
        mine: Future = Future()
        with self._lock:
            building = self._building.setdefault(key, mine)
        if building is not mine:
            return waited(building)
        try:
            arrays = tuple(np.ascontiguousarray(a) for a in build())
            self._write(key, arrays)
            self.events.append("built")
            for a in arrays:
                a.setflags(write=False)
            self._remember(key, arrays)
        except BaseException as exc:
            mine.set_exception(exc)
            raise
        else:
            mine.set_result(arrays)
        finally:
            with self._lock:
                del self._building[key]
        return arrays

    def kept(self, kind: str, parts: Iterable[Part]) -> tuple[np.ndarray, ...] | None:
        """``arrays(kind, parts, ...)`` where the entry is kept (in memory, on disk or in a
        seed), None where it is not: nothing is built. For arrays that only another maker
        makes (the levels the GL drew, app/textures/maps.py ``PreparedLevels.prefetch``),
        which a build here would store under their key with other bits."""
        if not self.enabled:
            return None
        return self._looked_up(entry_key(kind, parts))

    def _looked_up(self, key: str) -> tuple[np.ndarray, ...] | None:
        """Entry ``key`` from memory, else from disk (checksum verified), else from a seed,
        read-only and remembered in memory; None where none has it."""
        with self._lock:
            held = self._memory.get(key)
            if held is not None:
                self._memory.move_to_end(key)
                self.events.append("memory")
                return held
        arrays = self._read(key)
        if arrays is not None:
            self.events.append("disk")
        elif (arrays := self._seeded(key)) is not None:
            self.events.append("seed")
        else:
            return None
        for a in arrays:
            a.setflags(write=False)
        self._remember(key, arrays)
        return arrays

    def filled(
        self,
        kind: str,
        parts: Iterable[Part],
        layout: Sequence[tuple[Shape, np.dtype | type]],
        fill: Callable[[tuple[np.ndarray, ...]], None],
    ) -> tuple[np.ndarray, ...]:
        """``arrays`` for an entry whose arrays' shapes and dtypes (``layout``) are known
        before they are made: on a miss ``fill(arrays)`` writes them in place, into the
        entry's file mapped (``_InPlace``), where ``arrays`` builds them in fresh memory
        and the writer copies them into the file (a GL read-back, a copy of a decoded
        image's rows). Without a directory, or where the file cannot be mapped, they are
        filled in memory and written as ``arrays`` writes them."""

        def in_memory() -> tuple[np.ndarray, ...]:
            made = tuple(np.empty(shape, dtype) for shape, dtype in layout)
            fill(made)
            return made

        if not self.enabled or self.directory is None:
            return self.arrays(kind, parts, in_memory)
        key = entry_key(kind, parts)
        with self._lock:
            writing = key in self._writing
        if writing or self._holds(key):  # read (after its write) as ``arrays`` reads
            return self._keyed(key, in_memory)
        try:
            entry = _InPlace(self.directory, layout)
        except (OSError, ValueError) as exc:  # no room, or a file system that cannot map
            # (or reserve: posix_fallocate)
            _LOG.debug("texture cache: %s not made in place (%s)", key, exc)
            return self._keyed(key, in_memory)
        try:
            fill(entry.arrays)
        except BaseException:
            entry.discard()
            raise
        future = _writer().submit(_when_free, self._finish_in_place, key, entry)
        with self._lock:
            self._writing[key] = future
        future.add_done_callback(lambda _: self._written(key, future))
        self.events.append("built")
        for a in entry.arrays:
            a.setflags(write=False)
        self._remember(key, entry.arrays)
        return entry.arrays

    def prepare(
        self, kind: str, parts: Iterable[Part], build: Callable[[], Sequence[np.ndarray]]
    ) -> Future:
        """``arrays(kind, parts, build)`` on a background thread, started now: its caller
        has other work to do before it needs them (a model file's maps are looked up from
        the moment its parts are built, while the camera is framed, the GL started and
        the environment prefiltered). Reading a file, checking it, numpy's arithmetic on
        large arrays and Pillow's decoding release the GIL, so a read or a build runs
        beside that work. The future's result is what ``arrays`` returns (its exception
        where ``build`` raised one)."""
        parts = tuple(parts)
        return _preparer().submit(self.arrays, kind, parts, build)

    def prepare_kept(self, kind: str, parts: Iterable[Part]) -> Future:
        """``kept(kind, parts)`` on the background thread ``prepare`` uses, started now."""
        return _preparer().submit(self.kept, kind, tuple(parts))

    def flush(self) -> None:
        """Wait until every entry handed to the writer is on disk."""
        with self._lock:
            pending = list(self._writing.values())
        release_writes()  # held ones (background.writes_held) are written first
        for future in pending:  # a write handed over meanwhile follows one of these
            future.result()

    def clear_memory(self) -> None:
        """Forget the in-process entries (a second process's view of the disk level:
        what was built is on disk first)."""
        self.flush()
        with self._lock:
            self._memory.clear()
            self._held = 0

    def _remember(self, key: str, arrays: tuple[np.ndarray, ...]) -> None:
        size = sum(a.nbytes for a in arrays)
        if size > self.memory_bytes:
            return
        with self._lock:
            if key in self._memory:
                return
            self._memory[key] = arrays
            self._held += size
            while self._held > self.memory_bytes:
                _, old = self._memory.popitem(last=False)
                self._held -= sum(a.nbytes for a in old)

    def holds(self, kind: str, parts: Iterable[Part]) -> bool:
        """Whether an entry of ``arrays(kind, parts, ...)`` is at hand (in memory, on
        disk or in a seed), without reading or checking it."""
        return self.enabled and self._holds(entry_key(kind, parts))

    def _holds(self, key: str) -> bool:
        with self._lock:
            if key in self._memory:
                return True
        return entry_file(self.directory, self.seeds, key) is not None

    def path(self, key: str) -> Path | None:
        """Where entry ``key`` lives on disk (None without a directory)."""
        return None if self.directory is None else self.directory / f"{key}{SUFFIX}"

    def _read(self, key: str) -> tuple[np.ndarray, ...] | None:
        writing = self._writing.get(key)
        if writing is not None:  # this process is writing it: read it whole
            release_writes()  # a held write (background.writes_held) is written now
            writing.result()
        path = self.path(key)
        if path is None or not path.is_file():
            return None
        try:
            arrays = unpack_entry(_load(path))
            os.utime(path)  # most recently used
            return arrays
        except (OSError, ValueError, KeyError, TypeError, EOFError) as exc:
            _LOG.warning("texture cache: %s is unreadable (%s); rebuilding it", path, exc)
            self.events.append("rebuilt")
            path.unlink(missing_ok=True)
            return None

    def _seeded(self, key: str) -> tuple[np.ndarray, ...] | None:
        """Entry ``key`` from the first seed folder that holds a readable one (read-only:
        never refreshed, and a bad one is left where it is and skipped)."""
        for seed in self.seeds:
            path = seed / f"{key}{SUFFIX}"
            if not path.is_file():
                continue
            try:
                return unpack_entry(_load(path))
            except (OSError, ValueError, KeyError, TypeError, EOFError) as exc:
                _LOG.warning("texture cache: seed entry %s is unreadable (%s)", path, exc)
        return None

    def _write(self, key: str, arrays: tuple[np.ndarray, ...]) -> None:
        """Hand the entry to the writer thread (``_writer``): the caller goes on with the
        arrays at once while the entry is packed, checksummed and written. The process
        still waits for the writes at exit (the executor's threads are joined then), so
        none is lost; a lookup of the key in this process waits for its write."""
        if self.directory is None:
            return
        future = _writer().submit(_when_free, self._write_now, key, arrays)
        with self._lock:
            self._writing[key] = future
        future.add_done_callback(lambda _: self._written(key, future))

    def _written(self, key: str, future: Future) -> None:
        with self._lock:
            if self._writing.get(key) is future:
                del self._writing[key]

    def _write_now(self, key: str, arrays: tuple[np.ndarray, ...]) -> None:
        path = self.path(key)
        if path is None:
            return
        made: list[str] = []  # the temporary file, once there is one

        def write() -> None:
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=_TEMPORARY, suffix=SUFFIX, dir=path.parent)
            made.append(tmp)
            with os.fdopen(fd, "wb") as out:
                write_entry(out, arrays)
            os.replace(tmp, path)

        self._stored(path, write, lambda: [Path(tmp).unlink(missing_ok=True) for tmp in made])

    def _finish_in_place(self, key: str, entry: _InPlace) -> None:
        path = self.path(key)
        assert path is not None
        self._stored(path, lambda: entry.finish(path), entry.discard)

    def _stored(self, path: Path, write: Callable[[], None], undo: Callable[[], object]) -> None:
        """An entry's file written at ``path`` (by ``write``; ``undo`` removes what a failed
        write left), then the directory evicted down to its budget. A read-only or full
        disk is a warning, not an error: the cache is an optimisation."""
        try:
            try:
                write()
            except BaseException:
                undo()
                raise
            self._evict()
        except OSError as exc:
            _LOG.warning("texture cache: cannot write %s (%s)", path, exc)

    def _evict(self) -> None:
        """Delete the least recently used entries until the directory fits ``disk_bytes``."""
        assert self.directory is not None
        entries = []
        now = time.time_ns()
        for entry in self.directory.glob(f"*{SUFFIX}"):
            try:
                stat = entry.stat()
            except OSError:
                continue
            if entry.name.startswith(_TEMPORARY):  # another process's write in progress,
                if now - stat.st_mtime_ns > _STALE_NS:  # or a killed one's leftover
                    entry.unlink(missing_ok=True)
                continue
            entries.append((stat.st_mtime_ns, stat.st_size, entry))
        total = sum(size for _, size, _ in entries)
        for _, size, entry in sorted(entries):
            if total <= self.disk_bytes:
                break
            entry.unlink(missing_ok=True)
            total -= size


_PREPARER: ThreadPoolExecutor | None = None


def _preparer() -> ThreadPoolExecutor:
    """One background worker a process for ``prepare``: entries are read one after another,
    as a disk likes them, and a build beside the main thread uses the second core."""
    global _PREPARER
    if _PREPARER is None:
        _PREPARER = ThreadPoolExecutor(max_workers=1, thread_name_prefix="pbs-cache-prepare")
        # A build takes the GIL back after each numpy call (a chain makes over a thousand);
        # while the main thread runs Python each such wait lasts up to the switch interval,
        # 5 ms by default, so the interval is shortened for the process (docs/filtering.md,
        # "Prepared textures are cached", measures both).
        sys.setswitchinterval(min(sys.getswitchinterval(), SWITCH_INTERVAL_S))
    return _PREPARER


_WRITER: ThreadPoolExecutor | None = None


def _when_free(write: Callable[..., None], *args: object) -> None:
    """``write(*args)`` on the writer thread once writes are not held
    (app/textures/background.py ``writes_held``)."""
    when_writes_free()
    write(*args)


def _writer() -> ThreadPoolExecutor:
    """One background writer a process (entries are written one after another)."""
    global _WRITER
    if _WRITER is None:
        _WRITER = ThreadPoolExecutor(max_workers=1, thread_name_prefix="pbs-cache-write")
    return _WRITER


_SHARED: dict[tuple[str, bool, tuple[Path, ...]], PreparedCache] = {}


def prepared_cache() -> PreparedCache:
    """The process's cache for the current environment variables (one per setting, so a
    test or a bench that changes them gets a fresh one)."""
    seeds = tuple(seed_directories())
    setting = (str(cache_directory()), cache_enabled(), seeds)
    cache = _SHARED.get(setting)
    if cache is None:
        directory = textures_directory()
        cache = _SHARED[setting] = PreparedCache(directory, setting[1], seeds=seeds)
    return cache
