"""app/code_cache.py: the code the standard library compiles from text at every import
(dataclasses' methods, typing's forward references), compiled once per installation.

A class made with the table's ``exec`` has the very methods the built-in ``exec`` gives it,
and a forward reference the code ``compile`` gives it (the same code, the same behaviour);
a process writes the table where Python writes its bytecode, and only then; the next
process compiles none of the texts it holds; a table from another interpreter or a damaged
one is not used.
"""

from __future__ import annotations

import builtins
import dataclasses
import importlib.util
import os
import subprocess
import sys
import typing
from dataclasses import InitVar, dataclass, field
from pathlib import Path
from typing import ClassVar

import pytest

from app import code_cache
from tests.conftest import REPO

CODE_PARTS = (
    "co_code", "co_consts", "co_names", "co_varnames", "co_freevars", "co_cellvars",
    "co_filename", "co_name", "co_flags", "co_argcount", "co_kwonlyargcount",
    "co_posonlyargcount",
)  # fmt: skip


def declare():  # -> tuple of classes
    """Classes of the kinds the project and its libraries declare, made anew each call."""

    @dataclass(frozen=True)
    class Frozen:
        """Frozen, with a default and a factory."""

        name: str
        size: int = 3
        tags: tuple[str, ...] = field(default_factory=tuple)

    @dataclass(order=True, kw_only=True)
    class Ordered:
        """Ordered, keyword-only, a class variable and an init-only one."""

        rank: float
        shared: ClassVar[int] = 1
        scale: InitVar[float] = 1.0
        scaled: float = field(init=False, default=0.0)

        def __post_init__(self, scale: float) -> None:
            self.scaled = self.rank * scale

    @dataclass(eq=False, slots=True)
    class Slotted:
        """No equality, slots."""

        x: int
        y: list[int] = field(default_factory=list, repr=False)

    return Frozen, Ordered, Slotted


def methods(cls) -> dict:
    """The functions ``dataclasses`` wrote for ``cls``, by name."""
    names = ("__init__", "__repr__", "__eq__", "__hash__", "__setattr__", "__delattr__",
             "__lt__", "__le__", "__gt__", "__ge__")  # fmt: skip
    found = {}
    for name in names:
        fn = cls.__dict__.get(name)
        code = getattr(getattr(fn, "__wrapped__", fn), "__code__", None)
        if code is not None:
            found[name] = code
    return found


def test_the_table_gives_the_code_exec_compiles(monkeypatch: pytest.MonkeyPatch) -> None:
    table = code_cache._Table(None)
    monkeypatch.setattr(dataclasses, "exec", table.exec, raising=False)
    cached = declare()
    assert table.compiled > 10  # every method text compiled through the table
    monkeypatch.setattr(dataclasses, "exec", builtins.exec, raising=False)
    plain = declare()
    for ours, theirs in zip(cached, plain, strict=True):
        a, b = methods(ours), methods(theirs)
        assert sorted(a) == sorted(b) and a, ours.__name__
        for name in a:
            for part in CODE_PARTS:
                assert getattr(a[name], part) == getattr(b[name], part), (ours, name, part)


def test_classes_made_through_the_table_behave_as_dataclasses(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    table = code_cache._Table(None)
    monkeypatch.setattr(dataclasses, "exec", table.exec, raising=False)
    for _ in range(2):  # made, then made again from the texts compiled the first time
        frozen, ordered, slotted = declare()
        f = frozen("a")
        assert repr(f) == "declare.<locals>.Frozen(name='a', size=3, tags=())"
        assert f == frozen("a") and hash(f) == hash(frozen("a")) and f != frozen("b")
        with pytest.raises(dataclasses.FrozenInstanceError):
            f.size = 4  # type: ignore[misc]
        assert ordered(rank=1.0) < ordered(rank=2.0, scale=3.0)
        assert ordered(rank=2.0, scale=3.0).scaled == 6.0
        with pytest.raises(TypeError):
            ordered(1.0)  # type: ignore[misc]  # keyword-only
        s = slotted(1)
        assert s != slotted(1) and s == s and repr(s) == "declare.<locals>.Slotted(x=1)"
        assert not hasattr(s, "__dict__")
    assert table.compiled > 0 and len(table.used) == table.compiled


def test_exec_without_globals_takes_the_callers() -> None:
    """Given no globals, the table's ``exec`` runs the text in its caller's, as the
    built-in does (``dataclasses`` always passes its class's module's)."""
    table = code_cache._Table(None)
    ours: dict = {}
    table.exec("r = __name__", None, ours)
    theirs: dict = {}
    exec("r = __name__", None, theirs)
    assert ours == theirs == {"r": __name__}


@pytest.mark.parametrize(
    "text", ["int", "list[tuple[str, float]]", "Frozen | None", "*Ts", "'quoted'"]
)
def test_a_forward_reference_gets_the_code_compile_gives(
    monkeypatch: pytest.MonkeyPatch, text: str
) -> None:
    """typing compiles a string annotation into the reference's code: the table's is the
    built-in's (and a text that is no expression raises as before)."""
    table = code_cache._Table(None)
    argument = not text.startswith("*")
    monkeypatch.setattr(typing, "compile", table.compile, raising=False)
    ours = typing.ForwardRef(text, is_argument=argument)
    monkeypatch.setattr(typing, "compile", builtins.compile, raising=False)
    theirs = typing.ForwardRef(text, is_argument=argument)
    for part in CODE_PARTS:
        assert getattr(ours.__forward_code__, part) == getattr(theirs.__forward_code__, part)
    assert table.compiled == 1
    monkeypatch.setattr(typing, "compile", table.compile, raising=False)
    with pytest.raises(SyntaxError):
        typing.ForwardRef("not an expression")


def _run(code: str, cache: Path, *args: str, write: bool = True) -> str:
    """Run ``code`` with ``args`` in a fresh interpreter whose bytecode goes under
    ``cache`` (not written where ``write`` is off); its standard output."""
    env = {**os.environ, "PYTHONPATH": str(REPO), "PYTHONPYCACHEPREFIX": str(cache)}
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    if not write:
        env["PYTHONDONTWRITEBYTECODE"] = "1"
    proc = subprocess.run(
        [sys.executable, "-c", code, *args], cwd=REPO, env=env,
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


def _child(code: str, cache: Path, write: bool = True, how: str = "own") -> str:
    """Run ``code`` (``PROBE``) as ``_run`` does on a bad scene beside ``cache``, the CLI
    in its own process (``how``: "own") or called."""
    scene = cache / "bad.toml"
    scene.parent.mkdir(parents=True, exist_ok=True)
    scene.write_text(BAD_SCENE, encoding="utf-8")
    return _run(code, cache, str(scene), str(cache / "x.png"), how, write=write)


# ``pbs render`` of a scene that is refused once validated (the CLI's and the scene layer's
# imports: pydantic's and the project's declarations among them), in its own process
# (``main()``) or called with its arguments (``main(argv)``); then what the table compiled
# and held, and where it lives. The interpreter's exit follows (a refused render returns).
PROBE = """
import sys
from app.cli import main
from app.code_cache import TABLE
scene, out, how = sys.argv[1:]
argv = ["render", scene, "-o", out]
if how == "own":
    sys.argv = ["pbs", *argv]
    code = main()
else:
    code = main(argv)
assert code == 2, code
print(TABLE.compiled, len(TABLE.codes), TABLE.path)
"""
BAD_SCENE = "[materials.m]\nroughness = 2.0\n"


def test_a_process_writes_the_table_and_the_next_compiles_nothing(tmp_path: Path) -> None:
    compiled, held, path = _child(PROBE, tmp_path).split()
    assert int(compiled) > 50 and int(held) == int(compiled)
    table = Path(path)
    assert table.is_file() and table.is_relative_to(tmp_path)  # under sys.pycache_prefix
    assert table.read_bytes().startswith(importlib.util.MAGIC_NUMBER)
    compiled, held, _ = _child(PROBE, tmp_path).split()
    assert int(compiled) == 0 and int(held) > 50


def test_no_table_is_written_where_python_writes_no_bytecode(tmp_path: Path) -> None:
    compiled, _, path = _child(PROBE, tmp_path, write=False).split()
    assert int(compiled) > 50
    assert not Path(path).exists()


def test_a_caller_of_the_cli_writes_no_table(tmp_path: Path) -> None:
    """``main(argv)`` runs in a caller's process (a test run, a script): the texts it
    compiled through the table are not written for the command's processes."""
    compiled, _, path = _child(PROBE, tmp_path, how="called").split()
    assert int(compiled) > 50
    assert not Path(path).exists()


@pytest.mark.parametrize("content", [b"", b"not a table", b"\x00\x00\r\n" + b"{}", None])
def test_a_foreign_or_damaged_table_is_not_used(tmp_path: Path, content: bytes | None) -> None:
    """An empty or damaged file, another interpreter's magic number, or a marshalled
    object that is no table of texts: read as empty, then written again."""
    _, _, path = _child(PROBE, tmp_path).split()
    table = Path(path)
    if content is None:  # this interpreter's magic, a dict of the wrong kinds
        import marshal

        content = importlib.util.MAGIC_NUMBER + marshal.dumps({1: "x", "y": 2})
    table.write_bytes(content)
    compiled, held, _ = _child(PROBE, tmp_path).split()
    assert int(compiled) > 50 and int(held) == int(compiled)
    assert code_cache._read(table).keys()  # written whole again


def test_a_full_table_keeps_only_what_its_process_used(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(sys, "dont_write_bytecode", False)
    table = code_cache._Table(tmp_path / "t.codes")
    table.codes = {("exec", f"x = {i}"): compile(f"x = {i}", "<string>", "exec") for i in range(5)}
    table.exec("y = 1", {}, {})
    table.exec("x = 0", {}, {})
    table_max = code_cache.MAX_ENTRIES
    try:
        code_cache.MAX_ENTRIES = 4
        table.save()
    finally:
        code_cache.MAX_ENTRIES = table_max
    assert sorted(code_cache._read(table.path)) == [("exec", "x = 0"), ("exec", "y = 1")]


@pytest.mark.gl
def test_a_render_process_writes_the_table(tmp_path: Path) -> None:
    """``pbs render`` ends its process through the C library's exit (no atexit): the
    table is written before it."""
    out = tmp_path / "x.png"
    code = (
        "import sys; sys.argv = ['pbs', 'render', 'sec3_lambert', '-o', sys.argv[1],"
        " '--size', '16x9', '-q']\nfrom app.cli import main\nmain()"
    )
    _run(code, tmp_path / "c", str(out))
    assert out.is_file()
    tables = list((tmp_path / "c").rglob("*.codes"))
    assert len(tables) == 1 and len(code_cache._read(tables[0])) > 50
