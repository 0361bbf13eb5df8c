"""Code that the standard library compiles from text at every import, compiled once per
installation.

Two places compile source text each time a module is imported:

* ``@dataclass`` writes each class's ``__init__``, ``__repr__``, ``__eq__`` (and
  ``__hash__``, ``__setattr__``, ``__delattr__`` where frozen) as source and compiles it
  with ``exec``;
* ``typing.ForwardRef`` compiles each annotation written as a string with ``compile``
  (every annotation of a module with ``from __future__ import annotations``, which
  pydantic evaluates to build its models).

A ``pbs render`` of a model file imports some hundred dataclasses (the project's
declarations, pydantic's, annotated_types') and hundreds of such annotations, all compiled
on the main thread before the scene is read (their count and cost: docs/performance.md,
"Start-up").

Imported first by the command line (app/cli.py), this module gives ``dataclasses`` an
``exec`` and ``typing`` a ``compile`` of its own that look each text up in a table of code
objects compiled from exactly that text in that mode, and compile (then keep) only the
texts they have not seen. The table lives where Python keeps the package's bytecode
(``importlib.util.cache_from_source``: the package's ``__pycache__``, or under
``sys.pycache_prefix``), so it is trusted as the bytecode is, and written as the bytecode
is written: not under ``sys.dont_write_bytecode`` (PYTHONDONTWRITEBYTECODE). It is keyed by
the mode and the source text themselves, under the interpreter's bytecode magic number, so
a table from another Python, a damaged file or a changed class is never used for a text it
was not compiled from.

A code object taken from the table is what the built-in would compile from the text: the
same filename ("<string>"), mode and optimisation level, and no ``__future__`` flags
(neither ``dataclasses`` nor ``typing`` has any to pass on). Any other call (a code object,
bytes, flags, another filename) goes to the built-in as it is. In Python 3.11–3.13 each
module makes exactly one such call (``dataclasses``: ``_create_fn``, then ``_FuncBuilder``;
``typing``: ``ForwardRef.__init__``), looking the name up in the module's globals first,
which is all this sets: nothing else of the standard library changes. The table is
written by the command's own process as it ends (app/cli.py ``main``), not by a process
that calls the CLI with arguments (a test run, a script): what they compile is theirs.
"""

from __future__ import annotations

import builtins
import dataclasses
import importlib.util
import marshal
import os
import sys
import typing
from pathlib import Path
from types import CodeType
from typing import Any

# Entries kept past this many: the table starts again from this process's texts (a
# checkout whose classes change keeps compiling new texts; the old ones are never used).
MAX_ENTRIES = 8192
_SUFFIX = ".codes"  # beside the package's .pyc files, never taken for one
_FILENAME = "<string>"  # what exec gives a text, and what typing passes


class _Table:
    """Code objects by (mode, source text): those read from the file, those compiled here,
    and which of them this process used."""

    def __init__(self, path: Path | None) -> None:
        self.path = path
        self.codes: dict[tuple[str, str], CodeType] = _read(path) if path is not None else {}
        self.used: set[tuple[str, str]] = set()
        self.compiled = 0

    def code(self, mode: str, text: str) -> CodeType:
        """``text`` compiled in ``mode`` as the built-ins compile it for these callers."""
        key = (mode, text)
        code = self.codes.get(key)
        if code is None:
            code = builtins.compile(text, _FILENAME, mode, 0, True)
            self.codes[key] = code
            self.compiled += 1
        self.used.add(key)
        return code

    def exec(self, source: Any, scope: dict | None = None, local: Any = None) -> None:
        """``exec`` for ``dataclasses`` (``scope``, ``local``: its globals and locals; where
        no globals are given, the caller's, as the built-in takes them)."""
        if isinstance(source, str):
            source = self.code("exec", source)
        if scope is None:
            caller = sys._getframe(1)
            scope, local = caller.f_globals, caller.f_locals if local is None else local
        builtins.exec(source, scope, local)

    def compile(
        self,
        source: Any,
        filename: Any,
        mode: str,
        flags: int = 0,
        dont_inherit: bool = False,
        optimize: int = -1,
    ) -> Any:
        """``compile`` for ``typing``: a text of a ``<string>`` from the table."""
        if isinstance(source, str) and filename == _FILENAME and flags == 0 and optimize == -1:
            return self.code(mode, source)
        return builtins.compile(source, filename, mode, flags, True, optimize)

    def save(self) -> None:
        """Write the table where this process compiled a text the file did not hold (and
        Python would write its bytecode), through a temporary file renamed into place."""
        if self.path is None or not self.compiled or sys.dont_write_bytecode:
            return
        codes = self.codes
        if len(codes) > MAX_ENTRIES:
            codes = {key: codes[key] for key in self.used}
        temporary = self.path.with_name(f"{self.path.name}.{os.getpid()}.tmp")
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            temporary.write_bytes(importlib.util.MAGIC_NUMBER + marshal.dumps(codes))
            os.replace(temporary, self.path)
        except OSError:  # a read-only installation: compiled again next time, as before
            temporary.unlink(missing_ok=True)
            return
        self.compiled = 0


def _read(path: Path) -> dict[tuple[str, str], CodeType]:
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
        key: code
        for key, code in codes.items()
        if isinstance(key, tuple)
        and len(key) == 2
        and key[0] in ("exec", "eval")
        and isinstance(key[1], str)
        and isinstance(code, CodeType)
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
typing.compile = TABLE.compile  # type: ignore[attr-defined]
