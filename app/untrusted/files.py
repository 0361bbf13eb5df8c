"""The one way pbs opens a file an input names, and the outputs it will not write.

``confine`` turns a reference as written (a scene's ``file``, a glTF ``uri``, an MTL map)
into a path inside the allowed folders, or refuses it. The refusal is the same sentence
whether the target exists or not, so a refused reference tells nothing about the file.
``open_regular`` and ``read_bytes`` refuse what is not a plain file before opening it (a
FIFO would block ``open``, ``/dev/zero`` never ends) and a file past its size limit before
reading it. Every file read through them is noted, so that a command can refuse an output
path that would replace one of its inputs (``check_output``).
"""

from __future__ import annotations

import contextlib
import os
import re
import stat
from collections.abc import Iterator
from contextvars import ContextVar
from pathlib import Path
from urllib.parse import unquote

from app.untrusted import RefusedError
from app.untrusted.policy import InputPolicy

# A URI scheme (RFC 3986 sec. 3.1); a one-letter one would be a Windows drive.
_SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]+:")

_READ: ContextVar[set[Path] | None] = ContextVar("pbs_inputs_read", default=None)


def _shown(reference: str) -> str:
    """A reference as written, cut short where it is long (a URI can be megabytes)."""
    return reference if len(reference) <= 300 else reference[:297] + "..."


def confine(reference: str, referencing: Path, policy: InputPolicy) -> Path:
    """The resolved path of ``reference`` (relative to the folder of the file
    ``referencing``, or absolute), which must lie inside ``policy.roots(referencing)``
    once every symlink is resolved; ``RefusedError`` otherwise, naming only the reference."""
    if not isinstance(reference, str) or not reference or "\x00" in reference:
        raise RefusedError("is not a file path")
    roots = policy.roots(referencing)
    target = (Path(referencing).resolve().parent / reference).resolve()
    if not any(target == root or target.is_relative_to(root) for root in roots):
        raise RefusedError(
            f"'{_shown(reference)}' is outside the folder this file may read from "
            f"({roots[0]}); pass --allow-path (allow_paths= in the API) to widen it"
        )
    return target


def confine_uri(uri: str, referencing: Path, policy: InputPolicy) -> Path:
    """A glTF ``uri`` that is not a ``data:`` URI: a relative reference, percent-decoded
    as glTF 2.0 says (so ``%2e%2e/`` is ``../``), then ``confine``d. A scheme (``file:``,
    ``http:``) is refused: pbs reads local files only."""
    if _SCHEME.match(uri):
        raise RefusedError(
            f"'{_shown(uri)}' has a URI scheme; only relative paths and data: URIs are read"
        )
    return confine(unquote(uri), referencing, policy)


def _regular(path: Path) -> os.stat_result:
    """``stat`` of a plain file, or ``RefusedError`` (missing, a folder, a FIFO, a device)."""
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise RefusedError(f"{path}: no such file") from None
    except OSError as exc:
        raise RefusedError(f"{path}: cannot be read ({exc.strerror})") from None
    if stat.S_ISDIR(info.st_mode):
        raise RefusedError(f"{path}: is a folder, not a file")
    if not stat.S_ISREG(info.st_mode):
        raise RefusedError(f"{path}: is not a regular file (a FIFO, socket or device)")
    return info


@contextlib.contextmanager
def open_regular(path: Path, limit: int) -> Iterator[tuple[int, int]]:
    """(file descriptor, size) of the plain file ``path`` of at most ``limit`` bytes.

    Opened non-blocking, so a FIFO swapped in after the check cannot hang the open, and
    checked again on the open descriptor; closed on exit."""
    _regular(path)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError as exc:
        raise RefusedError(f"{path}: cannot be read ({exc.strerror})") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise RefusedError(f"{path}: is not a regular file (a FIFO, socket or device)")
        if info.st_size > limit:
            raise RefusedError(f"{path}: {_size(info.st_size)} is past the limit of {_size(limit)}")
        os.set_blocking(fd, True)
        _note(path)
        yield fd, info.st_size
    finally:
        os.close(fd)


def read_bytes(path: Path, limit: int) -> bytes:
    """The bytes of the plain file ``path``, at most ``limit`` of them (a file that grows
    while it is read, or a /proc file whose size reads 0, is still cut off there)."""
    with open_regular(path, limit) as (fd, _):
        chunks, total = [], 0
        while True:
            chunk = os.read(fd, min(1 << 24, limit + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
            if total > limit:
                raise RefusedError(f"{path}: is past the limit of {_size(limit)}")
        return b"".join(chunks)


def read_text(path: Path, limit: int) -> str:
    """A UTF-8 text file, whole; ``RefusedError`` where it is not text."""
    data = read_bytes(path, limit)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise RefusedError(f"{path}: not UTF-8 text ({exc.reason})") from None


def check_readable(path: Path, limit: int) -> None:
    """That ``path`` is a plain file of at most ``limit`` bytes that opens (read nothing)."""
    with open_regular(path, limit):
        pass


def _size(n: int) -> str:
    return f"{n / (1 << 30):.1f} GiB" if n >= 1 << 30 else f"{n / (1 << 20):.1f} MiB"


# --- outputs ----------------------------------------------------------------------------


def _note(path: Path) -> None:
    seen = _READ.get()
    if seen is not None:
        seen.add(Path(path).resolve())


@contextlib.contextmanager
def recording() -> Iterator[set[Path]]:
    """Collect the resolved path of every file opened through this module inside the
    block (a command's inputs, for ``check_output``)."""
    seen: set[Path] = set()
    token = _READ.set(seen)
    try:
        yield seen
    finally:
        _READ.reset(token)


def check_output(path: Path, inputs: set[Path] | frozenset[Path] = frozenset()) -> None:
    """``RefusedError`` where writing ``path`` would replace one of ``inputs`` or something that
    is not a plain file (a device node, a FIFO, a folder): outputs are written to a
    temporary file renamed over ``path``, which would replace the node itself."""
    try:
        info = os.lstat(path)
    except FileNotFoundError:
        info = None
    except OSError as exc:
        raise RefusedError(f"cannot write ({exc.strerror})") from None
    if info is not None and stat.S_ISDIR(info.st_mode):
        raise RefusedError("is a folder")
    if info is not None and not (stat.S_ISREG(info.st_mode) or stat.S_ISLNK(info.st_mode)):
        raise RefusedError(
            "is not a regular file (a device, FIFO or socket); refusing to replace it"
        )
    if Path(path).resolve() in inputs:
        raise RefusedError("is one of this command's input files; refusing to overwrite it")
