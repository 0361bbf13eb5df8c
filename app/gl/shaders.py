"""GLSL assembly: ``#include`` resolution, feature defines, and a program cache.

A program is built from one vertex and one fragment file plus a set of defines, so a
scene compiles only the features it uses (as the glTF Sample Viewer's shader cache
does). Included files are spliced once each, at their first ``#include``; the GLSL keeps
``#ifndef`` guards too. Every library file (``glsl/**/*.glsl``) includes what it uses, so
each compiles on its own after the ``#version`` and defines header
(tests/test_glsl_includes.py). Includes are expanded before the GLSL preprocessor runs:
an ``#include`` inside ``#if`` is spliced (and counts as done) whatever the condition.

Every program starts with the constants shared with Python (``app.common.glsl``: model
names, ``TERM_*``, ``LIGHT_*``, ``TONEMAP_*``), generated from their one definition.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path

import moderngl

from app.common.glsl import shared_defines
from app.resources import glsl_dir

GLSL_VERSION = "#version 330 core"
_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$', re.M)


def expand_includes(relative: str, root: Path | None = None, _seen: set[str] | None = None) -> str:
    """The source of ``relative`` (under ``glsl/``) with every #include spliced in once."""
    root = glsl_dir() if root is None else root
    seen = set() if _seen is None else _seen
    if relative in seen:
        return ""
    seen.add(relative)
    text = (root / relative).read_text(encoding="utf-8")

    def splice(match: re.Match[str]) -> str:
        return expand_includes(match.group(1), root, seen)

    return _INCLUDE.sub(splice, text)


def expand_text(text: str, root: Path | None = None) -> str:
    """GLSL source text (not a file) with every #include spliced in once."""
    root = glsl_dir() if root is None else root
    seen: set[str] = set()
    return _INCLUDE.sub(lambda m: expand_includes(m.group(1), root, seen), text)


def _header(defines: Mapping[str, object] | None) -> str:
    """``#version``, the shared constants, then a program's feature ``defines``."""
    lines = [GLSL_VERSION]
    lines += [f"#define {name} {value}" for name, value in shared_defines().items()]
    for name, value in sorted((defines or {}).items()):
        lines.append(f"#define {name} {value}" if value is not None else f"#define {name}")
    return "\n".join(lines) + "\n#line 1\n"


def assemble(relative: str, defines: Mapping[str, object] | None = None) -> str:
    """``#version`` line, then the defines, then the expanded source of a file."""
    return _header(defines) + expand_includes(relative)


def assemble_text(text: str, defines: Mapping[str, object] | None = None) -> str:
    """``#version`` line, then the defines, then ``text`` with its includes expanded."""
    return _header(defines) + expand_text(text)


class ShaderCache:
    """Compiled programs keyed by (vertex file, fragment file, defines)."""

    def __init__(self, ctx: moderngl.Context) -> None:
        self._ctx = ctx
        self._programs: dict[tuple, moderngl.Program] = {}

    def program(
        self, vertex: str, fragment: str, defines: Mapping[str, object] | None = None
    ) -> moderngl.Program:
        key = (vertex, fragment, tuple(sorted((defines or {}).items())))
        prog = self._programs.get(key)
        if prog is None:
            prog = self._ctx.program(
                vertex_shader=assemble(vertex, defines),
                fragment_shader=assemble(fragment, defines),
            )
            self._programs[key] = prog
        return prog

    def __len__(self) -> int:
        return len(self._programs)

    def release(self) -> None:
        for prog in self._programs.values():
            prog.release()
        self._programs.clear()
