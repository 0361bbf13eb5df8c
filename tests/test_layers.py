"""The package's layers point one way (docs/architecture.md): every ``import`` of every module
under app/, read with ``ast`` (function-level and TYPE_CHECKING imports included), names
only its own package or a lower layer; and no module imports itself through others.

    shared definitions (app.common) and utilities
      -> float64 twins (app.reference) | GL plumbing (app.gl)
      -> CPU texture maps (app.textures)
      -> scene (app.scene)
      -> frame data (app.frame)
      -> passes (app.render)
      -> the Python API (app.api)
      -> tools on top: BRDF probe, walkthrough, viewer, bench, CLI, screenshots
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from tests.conftest import REPO

APP = REPO / "app"

# Packages (or modules) in layer order. Within a layer, peers may not import each other:
# the twins and the GL plumbing know nothing of one another.
LAYERS: list[tuple[str, ...]] = [
    (
        "app.common",
        "app.errors",
        "app.resources",
        "app.output",
        "app.progress",
        "app.waiting",
        "app.code_cache",
    ),
    ("app.untrusted",),  # every input file opened, parsed and budgeted (docs/stability.md)
    ("app.reference", "app.gl"),
    ("app.textures",),
    ("app.scene",),
    ("app.frame",),
    ("app.render",),
    ("app.api",),  # the public Python API (docs/api.md): a renderer that changes, into numpy
    ("app.brdf", "app.assets", "app.batch"),
    ("app.walkthrough",),  # the classroom lesson: renders, plots, labels, handout
    ("app.viewer",),
    ("app.bench", "app.gallery"),  # the bench measures the viewer too
    ("app.cli", "app.screenshots"),
    ("app.__main__",),
]


def unit_of(module: str) -> str:
    """The layer entry ``module`` belongs to (``app.render.lighting`` -> ``app.render``)."""
    for layer in LAYERS:
        for unit in layer:
            if module == unit or module.startswith(unit + "."):
                return unit
    raise AssertionError(f"{module} is in no layer of tests/test_layers.py: add it")


def level(unit: str) -> int:
    return next(i for i, layer in enumerate(LAYERS) if unit in layer)


def module_name(path: Path) -> str:
    parts = path.relative_to(REPO).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path) -> list[tuple[int, str]]:
    """(line, module) of every import of an ``app`` module in the file, relative ones
    resolved."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = module_name(path)
    if path.name != "__init__.py":
        package = package.rsplit(".", 1)[0]
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                name = f"{base}.{node.module}" if node.module else base
            else:
                name = node.module or ""
            found.append((node.lineno, name))
            # `from app import x` / `from app.reference import ndf` import submodules
            found += [(node.lineno, f"{name}.{alias.name}") for alias in node.names]
    return [(line, name) for line, name in found if name == "app" or name.startswith("app.")]


def known(module: str) -> bool:
    """Whether ``module`` is a module or package of app/ (not a name inside a module)."""
    rel = Path(*module.split("."))
    return (REPO / rel).with_suffix(".py").is_file() or (REPO / rel / "__init__.py").is_file()


def violations() -> list[str]:
    bad = []
    for path in sorted(APP.rglob("*.py")):
        me = module_name(path)
        if me == "app":
            continue
        mine = unit_of(me)
        for line, target in imports(path):
            if target == "app" or not known(target):
                continue
            theirs = unit_of(target)
            if theirs == mine:
                continue
            if level(theirs) >= level(mine):
                rel = path.relative_to(REPO)
                bad.append(f"{rel}:{line}: {mine} (layer {level(mine)}) imports {target}")
    return bad


def test_layers_point_one_way() -> None:
    bad = violations()
    assert not bad, "imports against the layers:\n" + "\n".join(bad)


def test_every_package_has_a_layer() -> None:
    for path in APP.rglob("*.py"):
        if module_name(path) != "app":
            unit_of(module_name(path))


@pytest.mark.parametrize(
    ("source", "expect"),
    [
        ("from app.render.renderer import Renderer\n", "app.reference"),
        ("def f():\n    from app.scene.model import Scene\n", "app.reference"),
        ("import app.frame\n", "app.scene"),
        ("from app.gl import shaders\n", "app.reference"),
    ],
)
def test_the_check_catches_an_upward_import(tmp_path, monkeypatch, source, expect) -> None:
    """A module planted in a lower layer that imports upwards (at the top, inside a
    function, or a peer) is reported."""
    package = tmp_path / "app"
    target = package / Path(*expect.split(".")[1:])
    target.mkdir(parents=True)
    (package / "__init__.py").write_text("")
    (target / "__init__.py").write_text("")
    (target / "planted.py").write_text(source)
    for name in ("render", "scene", "frame", "gl"):
        (package / name).mkdir(exist_ok=True)
        (package / name / "__init__.py").write_text("")
    for module in ("render/renderer.py", "scene/model.py", "gl/shaders.py"):
        (package / module).write_text("")
    monkeypatch.setattr(f"{__name__}.REPO", tmp_path)
    monkeypatch.setattr(f"{__name__}.APP", package)
    found = violations()
    assert found and all("planted.py" in line for line in found), found


def import_graph(root: Path = APP) -> dict[str, set[str]]:
    """Module -> the app modules it imports (at the top, inside a function or under
    TYPE_CHECKING), each a module of the tree."""
    graph: dict[str, set[str]] = {}
    for path in sorted(root.rglob("*.py")):
        me = module_name(path)
        targets = set()
        for _, target in imports(path):
            while target and not known(target):
                target = target.rpartition(".")[0]
            if target and target != me and target != "app":
                targets.add(target)
        graph[me] = targets
    return graph


def loops(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected groups of more than one module (Tarjan's algorithm)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                found.append(sorted(group))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_module_imports_itself_through_others() -> None:
    """No loop of imports anywhere in app/: function-level ones included (a loop hidden in
    a function is still a loop), and those under TYPE_CHECKING (a module that names
    another in its annotations depends on it as much). The bench's suites, the scene
    loader and the viewer's window, panels and lesson each were one; a shared module below
    them broke it (app/bench/context.py, app/scene/placement.py, app/viewer/host.py)."""
    found = loops(import_graph())
    assert not found, "import loops:\n" + "\n".join(" -> ".join(g) for g in found)


def test_the_loop_check_finds_a_loop(tmp_path, monkeypatch) -> None:
    """Loops through a function-level import and through a TYPE_CHECKING one are found; a
    module that only imports into a loop is not part of it."""
    package = tmp_path / "app" / "pkg"
    package.mkdir(parents=True)
    (tmp_path / "app" / "__init__.py").write_text("")
    (package / "__init__.py").write_text("")
    (package / "a.py").write_text("from app.pkg.b import x\n")
    (package / "b.py").write_text("def f():\n    from app.pkg.a import y\n")
    (package / "c.py").write_text("from app.pkg.a import z\n")
    (package / "d.py").write_text("from app.pkg import e\n")
    (package / "e.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                                  "    from app.pkg.d import Host\n")  # fmt: skip
    monkeypatch.setattr(f"{__name__}.REPO", tmp_path)
    assert loops(import_graph(tmp_path / "app")) == [["app.pkg.a", "app.pkg.b"],
                                                     ["app.pkg.d", "app.pkg.e"]]  # fmt: skip
