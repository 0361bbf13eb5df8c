"""GLSL assembly: ``#include`` resolution, feature defines, and a program cache.

A program is built from one vertex and one fragment file plus a set of defines, so a
scene compiles only the features it uses (as the glTF Sample Viewer's shader cache
does). Included files are spliced once each, at their first ``#include``; the GLSL keeps
``#ifndef`` guards too. Every library file (``glsl/**/*.glsl``) includes what it uses, so
each compiles on its own after the ``#version`` and defines header
(tests/test_glsl_includes.py). Includes are expanded before the GLSL preprocessor runs:
an ``#include`` inside ``#if`` is spliced (and counts as done) whatever the condition.

Every program starts with the constants shared with Python (``app.common.glsl``: model
names, ``TERM_*``, ``LIGHT_*``, ``TONEMAP_*``), generated from their one definition, and,
after its defines, the declarations generated from the render core's other one-place
contracts: the G-buffer's (``app.common.gbuffer``: GBUFFER_OUTPUTS, GBUFFER_SAMPLERS and the
layout's defaults) and the material row's struct and fetch functions
(``app.common.models.material_glsl``). An ``#include`` of a name in
``app.common.extension_maps.GENERATED_INCLUDES`` ("generated/...") splices the text
generated from the extension maps' declarations instead of a file.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import moderngl

from app.common.extension_maps import GENERATED_INCLUDES
from app.common.gbuffer import glsl_declarations
from app.common.glsl import shared_defines
from app.common.models import material_glsl
from app.resources import GLSL_INCLUDE as _INCLUDE
from app.resources import glsl_dir

GLSL_VERSION = "#version 330 core"
GLSL_VERSION_FINE_DERIVATIVES = "#version 400 core"
DERIVATIVE_CONTROL = "GL_ARB_derivative_control"


@dataclass(frozen=True)
class Needs:
    """What a program's feature define needs of the GLSL: the ``#version`` line of both
    stages (each program's is the highest its defines need) and the extension its
    fragment stage names (a vertex stage gains nothing from them, and a strict compiler
    may refuse them there)."""

    version: str
    extension: str


# Feature defines that need more than GLSL 3.30 core, declared once: the header names
# their version and extension (``_header``), and ``supports`` asks a GL for them.
NEEDS: dict[str, Needs] = {
    # gl_SampleMask (passes/gbuffer.frag, the geometry samples' program)
    "GBUFFER_SAMPLE_MASK": Needs(GLSL_VERSION, "GL_ARB_sample_shading"),
    # dFdxFine, dFdyFine (passes/gbaa.frag): the extension needs GLSL 4.00, so a 3.30
    # shader cannot name them; core from 4.50
    "FINE_DERIVATIVES": Needs(GLSL_VERSION_FINE_DERIVATIVES, DERIVATIVE_CONTROL),
}


def _needed(defines: Mapping[str, object]) -> list[Needs]:
    """``NEEDS`` of the defines a program sets (present, and not 0 or False)."""
    return [NEEDS[name] for name in NEEDS if name in defines and defines[name] not in (0, False)]


def _version_number(line: str) -> int:
    return int(line.split()[1])


def supports(ctx: moderngl.Context, define: str) -> bool:
    """Whether ``ctx`` compiles a program with feature ``define`` (``NEEDS``): its GL
    version reaches the GLSL version the define needs, and it lists the extension."""
    needs = NEEDS[define]
    return ctx.version_code >= _version_number(needs.version) and needs.extension in ctx.extensions


Origin = tuple[str, int]  # (file under glsl/ or "<text>", 1-based line)


def _expand(name: str, text: str, root: Path, seen: set[str]) -> tuple[list[str], list[Origin]]:
    """The lines of ``text`` (of source ``name``) with each #include replaced by the
    file's expanded lines (a file already spliced leaves an empty line), and where each
    output line came from, so that a compiler's line number can be traced to a file."""
    lines: list[str] = []
    origins: list[Origin] = []
    for number, line in enumerate(text.split("\n"), start=1):
        match = _INCLUDE.match(line)
        if match is None:
            lines.append(line)
            origins.append((name, number))
            continue
        child = match.group(1)
        if child in seen:
            lines.append("")
            origins.append((name, number))
            continue
        seen.add(child)
        generated = GENERATED_INCLUDES.get(child)
        body = generated() if generated is not None else (root / child).read_text("utf-8")
        child_lines, child_origins = _expand(child, body, root, seen)
        lines += child_lines
        origins += child_origins
    return lines, origins


def _includes(text: str) -> tuple[list[str], list[tuple[int, str]]]:
    """``text``'s lines and its #include lines as (index, included name): ``_expand``'s
    line by line match, tried only on the lines that hold "#include"."""
    lines = text.split("\n")
    found: list[tuple[int, str]] = []
    start = text.find("#include")
    while start >= 0:
        index = text.count("\n", 0, start)
        match = _INCLUDE.match(lines[index])
        if match is not None and (not found or found[-1][0] != index):
            found.append((index, match.group(1)))
        end = text.find("\n", start)
        start = -1 if end < 0 else text.find("#include", end)
    return lines, found


# ``_includes`` of each source text this process expanded: a program's files are mostly
# the same library files, each read every time but split and searched once.
_PARSED: dict[str, tuple[list[str], list[tuple[int, str]]]] = {}


def _expand_lines(text: str, root: Path, seen: set[str], out: list[str]) -> None:
    """``_expand``'s lines of ``text`` appended to ``out`` (without their origins, which
    only a compiler's error needs): the same lines, its library files parsed once."""
    parsed = _PARSED.get(text)
    if parsed is None:
        parsed = _PARSED[text] = _includes(text)
    lines, includes = parsed
    done = 0
    for index, child in includes:
        out += lines[done:index]
        done = index + 1
        if child in seen:
            out.append("")
            continue
        seen.add(child)
        generated = GENERATED_INCLUDES.get(child)
        body = generated() if generated is not None else (root / child).read_text("utf-8")
        _expand_lines(body, root, seen, out)
    out += lines[done:]


def expand_includes(relative: str, root: Path | None = None, _seen: set[str] | None = None) -> str:
    """The source of ``relative`` (under ``glsl/``) with every #include spliced in once."""
    root = glsl_dir() if root is None else root
    seen = set() if _seen is None else _seen
    if relative in seen:
        return ""
    seen.add(relative)
    out: list[str] = []
    _expand_lines((root / relative).read_text(encoding="utf-8"), root, seen, out)
    return "\n".join(out)


def _expand_file(
    relative: str, root: Path | None = None, seen: set[str] | None = None
) -> tuple[list[str], list[Origin]]:
    root = glsl_dir() if root is None else root
    seen = set() if seen is None else seen
    if relative in seen:
        return [""], [(relative, 1)]
    seen.add(relative)
    return _expand(relative, (root / relative).read_text(encoding="utf-8"), root, seen)


def expand_text(text: str, root: Path | None = None) -> str:
    """GLSL source text (not a file) with every #include spliced in once."""
    return "\n".join(_expand("<text>", text, glsl_dir() if root is None else root, set())[0])


def _header(defines: Mapping[str, object] | None, fragment: bool = True) -> str:
    """``#version``, the shared constants, a program's feature ``defines``, the lines
    generated from them (``_generated``), then ``#line 1``: the compiler numbers the
    expanded source from 1. ``fragment``: the stage may name fragment-only extensions."""
    needed = _needed(defines or {})
    lines = [max([GLSL_VERSION, *(n.version for n in needed)], key=_version_number)]
    if fragment:
        lines += [f"#extension {n.extension} : require" for n in needed]
    lines += [f"#define {name} {value}" for name, value in shared_defines().items()]
    for name, value in sorted((defines or {}).items()):
        lines.append(f"#define {name} {value}" if value is not None else f"#define {name}")
    lines += _generated(defines or {})
    return "\n".join(lines) + "\n#line 1\n"


def _generated(defines: Mapping[str, object]) -> list[str]:
    """Header lines generated from a Python declaration for a program of ``defines``: the
    G-buffer's (app/common/gbuffer.py ``glsl_declarations``: the layout's defines the
    program leaves out, at their defaults, and the GBUFFER_OUTPUTS / GBUFFER_SAMPLERS
    declarations of its targets), then the material row's (app/common/models.py
    ``material_glsl``: struct ModelParams, fetch_model_params, fetch_model_group and, under
    UBER_MODELS, hence after the program's defines, fetch_model_codes)."""
    return [*glsl_declarations(defines), material_glsl()]


def assemble(relative: str, defines: Mapping[str, object] | None = None) -> str:
    """``#version`` line, then the defines, then the expanded source of a file."""
    return _header(defines, not relative.endswith((".vert", ".geom"))) + expand_includes(relative)


def assemble_text(text: str, defines: Mapping[str, object] | None = None) -> str:
    """``#version`` line, then the defines, then ``text`` with its includes expanded."""
    return _header(defines) + expand_text(text)


class ShaderError(RuntimeError):
    """A program failed to compile or link; the message names each error's file and line."""


_LOG_LOCATION = re.compile(r"\b\d+:(\d+)\((\d+)\)")


def describe_log(log: str, stages: Mapping[str, list[Origin]]) -> str:
    """A compiler log's error lines with Mesa's "0:line(column)" locations, which count
    lines of the expanded source, as "glsl/file:line:column" (``stages``: each stage's
    line origins, keyed by the stage name the log prints, e.g. "fragment_shader")."""
    out, origins = [], None
    for line in log.splitlines():
        if line.strip() in stages:
            origins = stages[line.strip()]
            continue
        match = _LOG_LOCATION.search(line)
        if match is None:
            continue
        number = int(match[1])
        if origins is not None and 1 <= number <= len(origins):
            name, own = origins[number - 1]
            where = f"glsl/{name}:{own}:{match[2]}" if name != "<text>" else f"{own}:{match[2]}"
            line = line[: match.start()] + where + line[match.end() :]
        out.append(line.strip())
    return "; ".join(out) or log.strip()


class ShaderCache:
    """Compiled programs keyed by (vertex file, fragment file, defines)."""

    def __init__(self, ctx: moderngl.Context) -> None:
        self._ctx = ctx
        self._programs: dict[tuple, moderngl.Program] = {}

    def program(
        self,
        vertex: str,
        fragment: str,
        defines: Mapping[str, object] | None = None,
        geometry: str | None = None,
    ) -> moderngl.Program:
        """The program of ``vertex`` and ``fragment`` (and a ``geometry`` stage between
        them where named) with ``defines``, compiled at its first request."""
        key = (vertex, fragment, tuple(sorted((defines or {}).items())))
        if geometry is not None:
            key += (geometry,)
        prog = self._programs.get(key)
        if prog is None:
            try:
                prog = self._ctx.program(
                    vertex_shader=assemble(vertex, defines),
                    fragment_shader=assemble(fragment, defines),
                    geometry_shader=None if geometry is None else assemble(geometry, defines),
                )
            except moderngl.Error as exc:
                stages = {
                    "vertex_shader": _expand_file(vertex)[1],
                    "fragment_shader": _expand_file(fragment)[1],
                }
                if geometry is not None:
                    stages["geometry_shader"] = _expand_file(geometry)[1]
                message = describe_log(str(exc), stages)
                raise ShaderError(f"{vertex} + {fragment}: {message}") from None
            self._programs[key] = prog
        return prog

    def __len__(self) -> int:
        return len(self._programs)

    def release(self) -> None:
        for prog in self._programs.values():
            prog.release()
        self._programs.clear()
