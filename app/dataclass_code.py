"""The methods ``dataclasses`` writes for each class, compiled once per installation.

``@dataclass`` writes the source of each class's ``__init__``, ``__repr__``, ``__eq__``
(and ``__hash__``, ``__setattr__``, ``__delattr__`` where frozen) and compiles it with
``exec``, every time a module defining the class is imported. A ``pbs render`` of a model
file imports some 125 dataclasses (the project's declarations, pydantic's, annotated_types')
and compiled about 600 such functions: 70–90 ms of the main thread on Python 3.11, before
the scene is read (docs/performance.md, "Start-up").

Imported first by the command line (app/cli.py), this module gives ``dataclasses`` an
``exec`` of its own that looks each source text up in a table of code objects compiled
from exactly that text, and compiles (then keeps) only the texts it has not seen. The table
lives where Python keeps the package's bytecode (``importlib.util.cache_from_source``: the
package's ``__pycache__``, or under ``sys.pycache_prefix``), so it is trusted as the
bytecode is, and written as the bytecode is written: not under ``sys.dont_write_bytecode``
(PYTHONDONTWRITEBYTECODE). It is keyed by the source text itself and the interpreter's
bytecode magic number, so a table from another Python, a damaged file or a changed class
is never used for a text it was not compiled from.

A code object compiled from a text is what ``exec`` would compile from it: the same
filename ("<string>"), mode, optimisation level, and no ``__future__`` flags inherited
(``dataclasses`` has none to pass on). Other sources (code objects, bytes) go to the
built-in ``exec`` as they are. ``dataclasses`` calls ``exec`` in one place in 3.11–3.13
(``_create_fn``, then ``_FuncBuilder``); the name is looked up in the module's globals
first, which is what this sets, and nothing else of the standard library changes.
"""

from __future__ import annotations

import atexit
import builtins
import dataclasses
import importlib.util
import marshal
import os
import sys
from pathlib import Path
from types import CodeType
from typing import Any

# Entries kept past this many: the table starts again from this process's texts (a
# checkout whose classes change keeps compiling new texts; the old ones are never used).
MAX_ENTRIES = 4096
_SUFFIX = ".dataclasses"  # beside the package's .pyc files, never taken for one


class _Table:
    """Code objects by source text: those read from the file, those compiled here, and
    which of them this process used."""

    def __init__(self, path: Path | None) -> None:
        self.path = path
        self.codes: dict[str, CodeType] = _read(path) if path is not None else {}
        self.used: set[str] = set()
        self.compiled = 0

    def exec(self, source: Any, scope: dict | None = None, local: Any = None) -> None:
        """``exec`` for ``dataclasses``: a text compiled once, then its code object run
        (``scope`` and ``local`` as ``exec``'s globals and locals)."""
        if isinstance(source, str):
            code = self.codes.get(source)
            if code is None:
                code = compile(source, "<string>", "exec", 0, True)
                self.codes[source] = code
                self.compiled += 1
            self.used.add(source)
            source = code
        builtins.exec(source, scope, local)

    def save(self) -> None:
        """Write the table where this process compiled a text the file did not hold (and
        Python would write its bytecode), through a temporary file renamed into place."""
        if self.path is None or not self.compiled or sys.dont_write_bytecode:
            return
        codes = self.codes
        if len(codes) > MAX_ENTRIES:
            codes = {text: codes[text] for text in self.used}
        temporary = self.path.with_name(f"{self.path.name}.{os.getpid()}.tmp")
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            temporary.write_bytes(importlib.util.MAGIC_NUMBER + marshal.dumps(codes))
            os.replace(temporary, self.path)
        except OSError:  # a read-only installation: compiled again next time, as before
            temporary.unlink(missing_ok=True)
            return
        self.compiled = 0


def _read(path: Path) -> dict[str, CodeType]:
    """The table in ``path``; empty where there is none, it is another interpreter's, or
    it does not read as one."""
    try:
        data = path.read_bytes()
    except OSError:
        return {}
    magic = importlib.util.MAGIC_NUMBER
    if not data.startswith(magic):
        return {}
    try:
        codes = marshal.loads(data[len(magic) :])
    except (EOFError, ValueError, TypeError):
        return {}
    if not isinstance(codes, dict):
        return {}
    return {
        text: code
        for text, code in codes.items()
        if isinstance(text, str) and isinstance(code, CodeType)
    }


def table_path() -> Path | None:
    """Where this installation's table lives (beside the package's bytecode); None where
    Python keeps no bytecode file for it."""
    try:
        pyc = importlib.util.cache_from_source(str(Path(__file__).resolve()))
    except NotImplementedError:  # sys.implementation.cache_tag is None
        return None
    return Path(pyc).with_suffix(_SUFFIX)


TABLE = _Table(table_path())
dataclasses.exec = TABLE.exec  # type: ignore[attr-defined]
atexit.register(TABLE.save)
